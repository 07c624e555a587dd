"""The ``python -m skmba demo`` main job."""

import subprocess
import sys

import pytest

from skmba.__main__ import main, run_demo


def test_demo_reports_an_accurate_emulator_and_writes_a_figure(tmp_path):
    pytest.importorskip("matplotlib")
    report = run_demo(tmp_path, n_simulations=40, seed=1)
    assert report["figure"].exists() and report["figure"].suffix == ".png"
    assert report["r2"].min() > 0.999
    # Coverage of the 95 % intervals on 500 held-out points; plug-in ML
    # hyperparameters make the intervals a little optimistic (reported, not
    # hidden): demand at least 60 %.
    assert report["coverage"].min() > 0.6


def test_command_line(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "skmba", "demo", "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "held-out R^2" in result.stdout
    assert list((tmp_path / "o").glob("*.png"))
    with pytest.raises(SystemExit):
        main(["demo", "--n-simulations", "3"])
    with pytest.raises(SystemExit):
        main([])
