"""Studies of one question each, on the cases of the validity suite.

Each module is a script, ``python -m validation.studies.<name> --help``:

- ``missing_data``: readings removed at random from the field data; does
  theta stay, are the removed readings covered? (``docs/monitoring_data.rst``)
- ``designer_vs_calibrator``: does ``PreposteriorDesigner`` predict the
  posterior variance the calibrator gets? (``docs/validity.rst``,
  ``docs/sensor_design.rst``)
- ``reference_sd``: the posterior sd with the defaults over that of a
  discrepancy-free fit on the same data;
- ``spike_probe``: what a prior mass on "no discrepancy" would do;
- ``new_observation_noise``: why new observations are covered a little
  under 95 % (the noise, the emulator, the ideal reference);
- ``joint_reference``: the default posterior of theta against the joint
  posterior of theta and the module-2 hyperparameters (long MCMC);
- ``converged_integral``: with ``discrepancy_tol``, the spread of theta's
  posterior over ``random_state`` and its agreement with that reference;
- ``discrepancy_continuum``: coverage and the warning along a continuum of
  discrepancies from a1 to c3 (inside and outside the span of E's
  sensitivity, 10-50 dB) and on designs with two inputs, four responses
  and three parameters (cases in :mod:`validation.continuum_cases`);
- ``update_reweighting`` and ``update_chain_spread``: the bridge year's
  updates, reweighted or by chains, against long chains, and the chains'
  reported errors against their spread over chain seeds on one target
  (``docs/internals.rst``, section skmba.mcmc._reweight).

They take their cases from :func:`validation.suite.registry` (or
:mod:`validation.cases`) and their statistics from
:mod:`validation.statistics`; their results are quoted in
``docs/validity.rst`` unless said otherwise.
"""
