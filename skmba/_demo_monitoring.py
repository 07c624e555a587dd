"""The monitoring case of ``python -m skmba demo --monitoring``.

A bridge watched for two years (:func:`~skmba.datasets.make_bridge_monitoring`):
the first, healthy, calibrates the reference state of a
:class:`~skmba.ChangeDetector`; in the second, one deck element loses 5 % of
its stiffness on 1 September, and each week is judged against the
reference. The report counts the alarms before and after the damage and
gives September's relative changes; the figure is the weekly control chart
(:func:`~skmba.plotting.plot_change_history`).

Examples
--------
>>> from skmba._demo_monitoring import MONITORING_SETTINGS
>>> MONITORING_SETTINGS["quick"]["damage_start"]
'2026-01-29'
"""

import time
import warnings
from pathlib import Path

import numpy as np

from skmba.calibration import ChangeDetector, ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring

#: The full case (two years) and the quick one (for tests: two months of
#: reference, eight weeks of the current state, the damage half way).
MONITORING_SETTINGS = {
    "full": {
        "reference_hours": 8760,
        "current_hours": 8760,
        "damage_start": "2026-09-01",
    },
    "quick": {
        "reference_hours": 24 * 60,
        "current_hours": 24 * 56,
        "damage_start": "2026-01-29",
    },
}
DAMAGE_SIZE, DAMAGE_ELEMENT = 0.05, 5


def run_monitoring_demo(out, *, seed=0, quick=False, say=print):
    """Fit the reference year, judge the next one week by week; report.

    Parameters
    ----------
    out : str or Path
        Folder for the figure (created if needed).
    seed : int, default=0
    quick : bool, default=False
        Two months of reference and eight weeks judged instead of two years.
    say : callable, default=print
        Where the report's lines go.

    Returns
    -------
    dict
        ``alarms_before``, ``weeks_before``, ``alarms_after``,
        ``weeks_after``, ``report`` (the relative changes of the first four
        weeks after the damage, a table), ``figures`` and ``seconds``.
    """
    started = time.perf_counter()
    settings = MONITORING_SETTINGS["quick" if quick else "full"]
    reference = make_bridge_monitoring(
        settings["reference_hours"], start="2025-01-01", random_state=seed
    )
    current = make_bridge_monitoring(
        settings["current_hours"],
        start="2026-01-01",
        damage_size=DAMAGE_SIZE,
        damage_location=DAMAGE_ELEMENT,
        damage_start=settings["damage_start"],
        random_state=seed + 1,
    )
    say(
        "skmba demo --monitoring: a 30 m bridge, hourly frequencies; element "
        f"{DAMAGE_ELEMENT} of 20 loses {DAMAGE_SIZE:.0%} of its stiffness on "
        f"{settings['damage_start']}"
    )
    detector = ChangeDetector(
        ModularBayesCalibrator(
            prior=reference.prior,
            discrepancy_uncertainty="plug-in",
            bin_width=1.0,
            random_state=seed,
        ),
        alpha=0.05,
        bin_width=0.5,
        simulator=reference.simulator,
    )
    with warnings.catch_warnings():
        # Temperature-only readings cannot tell E from the bearings and the
        # discrepancy; the reference calibration warns, as it should.
        warnings.simplefilter("ignore")
        detector.fit(
            reference.X_obs,
            reference.y_obs,
            X_sim=reference.X_sim,
            theta_sim=reference.theta_sim,
            y_sim=reference.y_sim,
        )
    say(f"[1/2] reference state fitted ({time.perf_counter() - started:.0f} s)")
    scan = detector.scan(current.X_obs, current.y_obs, batch_size=168)
    say(f"[2/2] {len(scan)} weeks judged ({time.perf_counter() - started:.0f} s)")
    start = current.damage["start_index"]
    after = np.asarray(scan.index if hasattr(scan, "index") else scan["from"]) >= start
    changed = np.asarray(scan["changed"], dtype=bool)
    first_month = slice(start, start + 4 * 168)
    report = detector.report(current.X_obs[first_month], current.y_obs[first_month])
    say(
        f"alarms at a 5 % false-alarm rate: {changed[~after].sum()} of "
        f"{(~after).sum()} weeks before the damage, {changed[after].sum()} of "
        f"{after.sum()} after it"
    )
    say("relative change in the four weeks after the damage:")
    say(str(report))
    figures = _figure(out, scan, start)
    for path in figures:
        say(f"figure: {path}")
    return {
        "alarms_before": int(changed[~after].sum()),
        "weeks_before": int((~after).sum()),
        "alarms_after": int(changed[after].sum()),
        "weeks_after": int(after.sum()),
        "report": report,
        "figures": figures,
        "seconds": time.perf_counter() - started,
    }


def _figure(out, scan, start):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from skmba.plotting import plot_change_history
    except ImportError:
        return []
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig = plot_change_history(scan, alpha=0.05, events={"damage": start})
    path = out / "monitoring_change_chart.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]
