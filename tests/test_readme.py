"""The README's quick-start code block runs as written."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_quick_start_runs():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert len(blocks) >= 2, "README.md lost its python code blocks"
    namespace = {}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    cal = namespace["cal"]
    assert abs(cal.theta_mean_[0] / 67.8e3 - 1) < 0.01  # as the comments say
    # As the README says: sharp at E_eff (the data cannot tell the spring
    # from E), warned through identifiability_; the thesis' plug-in is
    # about 2.4 GPa wide only because of its floor on the discrepancy.
    sd = cal.theta_cov_[0, 0] ** 0.5
    assert 0.05e3 < sd < 0.5e3 and abs(cal.theta_mean_[0] - 70e3) > 5 * sd
    assert 0.05 < cal.identifiability_[0] < 0.25  # "about 0.13", below 1/3
    assert namespace["std"].shape == (3, 2)
    # The best fit: E_eff of the beam (the fixed-support model's E that
    # reproduces it), inside its interval, 67.863 GPa with sd 0.010 GPa.
    data, best = namespace["data"], namespace["best"]
    b = data.reality
    e_eff = b.E / (1 + 3 * b.E * b.I / (b.spring_stiffness * b.length))
    low, high = np.quantile(best.theta_samples_[:, 0], [0.025, 0.975])
    assert low < e_eff < high and abs(best.theta_mean_[0] / 67.863e3 - 1) < 1e-4
    assert 0.005e3 < best.theta_cov_[0, 0] ** 0.5 < 0.02e3
    # the kernel search on raw inputs, scaled in the pipeline
    search = namespace["search"]
    assert search.best_params_ == {"multiresponsegp__kernel": None}
    assert search.score(namespace["X_te"], namespace["y_te"]) > 0.99999
    gp = namespace["gp"]
    assert gp.sigma2_.shape == (2, 2)
    # the comment in the README promises noise close to [1e-4, 2.5e-3]
    assert 0.5e-4 < gp.noise_[0] < 2e-4 and 1.2e-3 < gp.noise_[1] < 5e-3
    # two weekly updates, recorded in theta_history_: the readings so far
    # (rows with a measured frequency), fewer distinct 2-degC bins
    Y = namespace["Y"].to_numpy()
    kept = np.isfinite(Y).any(axis=1)
    history = namespace["monitor"].theta_history_
    assert list(history["n_readings"]) == [kept[:168].sum(), kept[:336].sum()]
    assert np.all(history["n_means"] < 30)
    # the change detector: a 10 % loss of one element seen in a week, on the
    # deck's E (one element of 20: well under 2 % of the effective E)
    detector = namespace["detector"]
    damaged = namespace["damaged"]
    assert detector.predict(damaged.X_obs, damaged.y_obs) == -1
    report = detector.report(damaged.X_obs, damaged.y_obs)
    assert report["log10_bf"].idxmax() == "E"
    assert -0.02 < report.loc["E", "2.5%"] and report.loc["E", "97.5%"] < 0
