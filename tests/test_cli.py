"""The command line: help, simulate, the demo, and bad input as one message with exit 2."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gyroid import load_bench_log
from gyroid.cli import main


def test_help_lists_the_commands(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in ("simulate", "demo"):
        assert command in out
    assert main(["simulate", "--help"]) == 0
    assert "--seed" in capsys.readouterr().out


@pytest.mark.parametrize("bench", ["thermal", "magnetic"])
def test_simulate_writes_a_contract_log_and_truth(tmp_path, bench):
    out = tmp_path / bench
    assert main(["simulate", bench, "--out", str(out), "--seed", "3"]) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert truth["seed"] == 3 and truth["bench"] == bench
    terms = "thermal" if bench == "thermal" else "magnetic"
    log = load_bench_log(out / "bench.csv", terms)
    header = next(
        line for line in (out / "bench.csv").read_text().splitlines() if not line.startswith("#")
    )
    assert header.split(",")[:2] == ["time_s", "drift_deg_h"]
    assert {"temperature_C", "Hx_uT", "Hy_uT", "Hz_uT"} <= set(header.split(","))
    assert log.n > 1000
    assert (out / "bench.png").exists()
    assert not list(tmp_path.glob(".*staging*"))


def test_simulate_with_a_candidate_effect(tmp_path):
    out = tmp_path / "sim"
    code = main(
        [
            "simulate",
            "thermal",
            "--out",
            str(out),
            "--set",
            "w1=-0.2",
            "--effect",
            "time_trend:w_trend=0.05",
        ]
    )
    assert code == 0
    truth = json.loads((out / "truth.json").read_text())
    assert truth["parameters"]["w1"] == -0.2
    assert truth["parameters"]["w_trend"] == 0.05
    assert "time_trend" in truth["effects"]


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--effect", "warmup:w_warmup=1"], "give a value for tau_warmup_min"),
        (["--effect", "warm_up:x=1"], "unknown effect 'warm_up'"),
        (["--set", "w1"], "is not NAME=NUMBER"),
        (["--set", "wq=1"], "parameter 'wq' belongs to no effect"),
    ],
)
def test_bad_options_end_with_one_message_and_write_nothing(tmp_path, capsys, args, expected):
    out = tmp_path / "never"
    assert main(["simulate", "thermal", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gyroid: error: ") and expected in err
    assert "Traceback" not in err
    assert not out.exists()


def test_console_script_exit_code_and_no_traceback(tmp_path):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "gyroid",
            "simulate",
            "thermal",
            "--out",
            str(tmp_path / "x"),
            "--set",
            "nonsense",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1


def test_demo_writes_a_report_whose_figures_exist(tmp_path):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    import re

    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    assert len(figures) >= 2
    for figure in figures:
        assert (out / figure).exists(), figure
    results = json.loads((out / "demo.json").read_text())
    k = results["magnetic"]["K"]["wy"]
    assert np.isfinite(k["signed"])
