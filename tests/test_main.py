"""The ``python -m skmba demo`` main job, in its quick mode."""

import re
import subprocess
import sys

import pytest

from skmba.__main__ import build_parser, main, run_demo

FIGURES = {
    "calibrated_predictions.png",
    "posterior_E.png",
    "traces_E.png",
    "sensor_criterion_by_size.png",
}


def test_quick_demo_calibrates_ranks_sensors_and_writes_figures(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    report = run_demo(tmp_path / "out", seed=1, n_jobs=1, quick=True)
    text = capsys.readouterr().out

    # Calibration: a few percent of bias (model discrepancy), no more.
    assert abs(report["theta_mean"] / report["theta_true"] - 1) < 0.08
    low, high = report["interval"]
    assert low < report["theta_mean"] < high
    assert report["rhat"].shape == (1,) and report["ess"][0] > 0
    assert (report["acceptance"] > 0.05).all()
    assert report["r2"].min() > 0.999
    assert report["coverage"].shape == (2,)
    # Sensors: three responses, ranks 1..3; the best subset of each size.
    assert sorted(report["ranking"].values()) == [1, 2, 3]
    assert sorted(report["best_subsets"]) == [1, 2, 3]
    assert len(report["best_subsets"][3]) == 3

    assert {p.name for p in report["figures"]} == FIGURES
    for path in report["figures"]:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    for line in ("[1/5]", "[5/5]", "Report", "E: posterior mean", "95 % interval"):
        assert line in text
    assert "split R-hat" in text and "emulator R^2" in text
    assert "Sensors alone, best first" in text and "Best 1 sensor" in text


def test_command_line_quick_run(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "demo out"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "skmba",
            "demo",
            "--quick",
            "--out",
            str(out),
            "--n-jobs",
            "1",
            "--seed",
            "2",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert "E: posterior mean" in result.stdout
    assert "Best 3 sensors" in result.stdout
    assert {p.name for p in out.glob("*.png")} == FIGURES


def test_help_explains_the_options():
    result = subprocess.run(
        [sys.executable, "-m", "skmba", "demo", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0
    for option in ("--out", "--seed", "--n-jobs", "--n-simulations", "--quick"):
        assert option in result.stdout
    assert "skmba-demo" in result.stdout  # the default folder is shown


def test_parser_defaults_and_invalid_options():
    args = build_parser().parse_args(["demo"])
    assert (args.out, args.seed, args.n_jobs, args.quick) == (
        "skmba-demo",
        0,
        -1,
        False,
    )
    with pytest.raises(SystemExit):
        main(["demo", "--n-simulations", "3"])
    with pytest.raises(SystemExit):
        main(["demo", "--n-mc", "0"])
    with pytest.raises(SystemExit):
        main(["demo", "--n-jobs", "0"])
    with pytest.raises(SystemExit):
        main([])


@pytest.mark.slow  # 25-40 s: a fit, eight weeks judged, FE Jacobians
def test_monitoring_demo_alarms_after_the_damage_only(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "monitoring"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "skmba",
            "demo",
            "--monitoring",
            "--quick",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "weeks before the damage" in result.stdout
    assert [p.name for p in out.glob("*.png")] == ["monitoring_change_chart.png"]
    # Four weeks after a 5 % loss each alarm (a week detects it: the
    # validation study); before it, at most one of four unchanged weeks at a
    # 5 % false-alarm rate (P(more) = 1.4 %).
    found = re.search(
        r"(\d+) of (\d+) weeks before the damage, (\d+) of (\d+) after it",
        result.stdout,
    )
    before, weeks_before, after, weeks_after = map(int, found.groups())
    assert weeks_before == 4 and before <= 1
    assert after == weeks_after == 4
