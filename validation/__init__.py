"""The validity suite of skmba and its studies (not shipped with the package).

How honest are the calibrator's intervals? Seeded replicates of problems
with a known answer, scored with the package's current defaults; the
results and how to read them are in ``docs/validity.rst``.

Map:

- ``__main__.py``: the command line, ``python -m validation --help``;
- ``suite.py``: the case registry, one replicate (fit and score), many
  through joblib;
- ``statistics.py``: the scores and summaries (Wilson interval, rms z, SBC
  ranks and their chi-square and KS tests, the exact coverage of new
  observations, the t-interval of a mean coverage);
- ``report.py``: the printed tables, ``replicates.csv`` / ``.npz`` with the
  git commit and date, the rank histograms;
- ``cases.py``: the seeded problems a1, a2, b1, b2, c1, c3, freq (and the
  earlier SBC runs, ``sbc0_a1``, ``sbc0_a2``);
- ``sbc_cases.py``: ``sbc_a1``, ``sbc_a2``, everything drawn from the
  default priors;
- ``continuum_cases.py``: the continuum of discrepancies from a1 to c3 and
  the larger designs (two inputs, four responses, three parameters) of
  ``studies/discrepancy_continuum``;
- ``joint_posterior.py``: the joint posterior of theta and the module-2
  hyperparameters on a fitted calibrator's pieces (the gold standard of
  ``studies/joint_reference``);
- ``studies/``: one-question studies run as ``python -m
  validation.studies.<name>`` (``missing_data``, ``designer_vs_calibrator``,
  ``reference_sd``, ``spike_probe``, ``new_observation_noise``,
  ``joint_reference``);
- ``results/``: stored tables, with the command that produced each
  (``results/README.md``).

The tests are in ``tests/validation/`` (the slow-marked subsets pin
today's numbers). Run from the repository root, where ``skmba`` and
``validation`` are both importable; ``pyproject.toml`` ships only
``skmba``.
"""
