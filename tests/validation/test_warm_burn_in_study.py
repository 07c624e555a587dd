"""The burn-in study's fixed-seed subset: what docs/internals.rst says of
the second pass's short burn-in (skmba.mcmc._chain). On sbc_a2 seed 35,
chains that each fitted their own Student-t to the latest half of a
250-step burn-in did not mix (R-hat 1.31, sds 0.39-0.76 of a long
reference's); the calibrator's answer now matches the reference (since
the shared mixture, after running its chains again past the full
burn-in). On sbc_a2 seed 108 the first pass located the posterior poorly
in log coordinates (R-hat 1.40, bulk ESS 5; a parameter pressed against
its prior's bound) and 250 steps left the chains unmixed (R-hat 1.83), so
the calibrator ran them again after the full burn-in; with the soft ends
of a finite support the 250 steps mix and agree with the full burn-in's
run. An update's chains start further from their posterior: on b2 seed
21, updated with three quarters of its field data, 250 steps need 1.75
times the full burn-in's steps for the same answer (before the predicted
stop they ran to n_samples and gave narrower sds), so updates keep the
full burn-in."""

import numpy as np
import pytest

from validation.studies.warm_burn_in import LONG, SHORT, one_fit


def _assert_agrees(fit, reference):
    """The mean, sd and 95 % ends of ``fit`` within four combined Monte
    Carlo errors of ``reference``'s, and its sds within 7 % of them."""
    (values, errors), (ref_values, ref_errors) = (
        fit["estimates"],
        reference["estimates"],
    )
    z = (values - ref_values) / np.hypot(errors, ref_errors)
    assert np.all(np.abs(z) < 4)
    ratio = values[1] / ref_values[1]
    assert np.all((0.93 < ratio) & (ratio < 1.07))


@pytest.mark.slow
def test_the_default_second_pass_samples_the_posterior_of_a_stuck_first_pass():
    short, reference = (one_fit("sbc_a2", 35, v, 20000) for v in (SHORT, "reference"))
    # One posterior: module 2 and the first pass are the same in both fits.
    np.testing.assert_array_equal(short["module2"], reference["module2"])
    assert reference["rhat"] < 1.005 and reference["draws"] == 20000
    # With the shared mixture the chains after 250 steps would warn of
    # R-hat here and run again after the full burn-in (measured; with one
    # shared Student-t they did not need to); either way the default's
    # answer is checked.
    assert short["rhat"] <= 1.01
    # The mean, sd and 95 % ends within four combined Monte Carlo errors of
    # the reference's, and the sd within 7 % from both sides (measured: 0.98
    # and 0.99 on an AVX-512 machine, 1.05 and 0.99 on an AMD EPYC without).
    # Four, not three: over the study's 120 fits these z have an rms of
    # 0.96-1.14 (docs/internals.rst), at which one of 8 quantities beyond 3
    # has a chance of 2-7 % (were they independent), and each kind of
    # processor draws another chain path (at most 1.7 on the first machine,
    # 3.16 on the EPYC: the first parameter's 97.5 % point, 0.19 posterior
    # sd above the reference's, with all four chains above it; with three
    # other chain seeds the default gave 1.486-1.506, z of -0.6 to 1.1,
    # and two other references 1.4905 and 1.4932); beyond 4 the chance is
    # 0.05-0.4 %. Stuck chains (sds 0.39-0.76 of the reference's here
    # before) fail both bounds.
    _assert_agrees(short, reference)


@pytest.mark.slow
def test_a_first_pass_stuck_at_a_bound_no_longer_needs_the_full_burn_in():
    default, long = (one_fit("sbc_a2", 108, v, 0) for v in (SHORT, LONG))
    np.testing.assert_array_equal(default["module2"], long["module2"])
    # In log coordinates the default fell back here (R-hat 1.83 after 250
    # steps); with soft ends one run mixes (measured R-hat 1.0007) and its
    # mean, sd and 95 % ends lie within 1.75 combined Monte Carlo errors of
    # the full burn-in's (sds 1.04 of its). The fallback itself is checked
    # in tests/calibration/test_estimator_calibration.py.
    assert not default["fell_back"] and default["runs"] == 1
    assert default["rhat"] <= 1.01 and long["rhat"] <= 1.01
    _assert_agrees(default, long)


@pytest.mark.slow
def test_an_update_after_the_short_burn_in_mixes_worse_at_a_higher_cost():
    short, long = (one_fit("b2", 21, v, 0, update_share=0.25) for v in (SHORT, LONG))
    # One posterior: the fit on the first quarter and the update's module 2
    # are the same in both; only the update's chains differ, one run each.
    np.testing.assert_array_equal(short["module2"], long["module2"])
    assert short["runs"] == long["runs"] == 1
    # Stopped where the ESS target is predicted to be met, the short
    # burn-in's chains meet it at 3,700 draws per chain (15,800 steps)
    # against 1,250 (9,000 steps) after the full burn-in, and agree with it
    # (sds 1.01 and 0.98 of its, |z| at most 1.4, measured). Run on to
    # n_samples without the predicted stop they gave sds 0.90 and 0.80 at
    # R-hat 1.003 (0.96 and 0.88 at R-hat 1.015 in log coordinates): the
    # short burn-in costs more steps for an answer no better.
    assert short["rhat"] <= 1.01 and long["rhat"] <= 1.01
    assert 1.4 * long["steps"] < short["steps"] < 21000
    assert short["draws"] > 2 * long["draws"]
    _assert_agrees(short, long)
