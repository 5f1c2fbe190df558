"""The command line: help, simulate, the demo, and bad input as one message with exit 2."""

import json
import subprocess
import sys

import numpy as np
import pytest
from helpers import WHITE, write_log

from gyroid import MagneticProtocol, ThermalProtocol, load_bench_log
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


@pytest.mark.parametrize("bench", ["thermal", "magnetic"])
def test_simulate_any_length_and_rate(tmp_path, bench):
    out = tmp_path / "sim"
    assert main(["simulate", bench, "--hours", "0.25", "--rate-hz", "20", "--out",
                 str(out)]) == 0
    log = load_bench_log(out / "bench.csv", "bias")
    steps = np.diff(log.time_s)
    assert np.median(steps) == pytest.approx(0.05)
    # The whole schedule in a quarter of an hour, every row written.
    span_h = (log.time_s[-1] - log.time_s[0] + 0.05) / 3600.0
    assert span_h == pytest.approx(0.25, rel=1e-3)
    protocol = (ThermalProtocol() if bench == "thermal" else MagneticProtocol()).stretched(
        0.25, 20.0)
    expected = (int(round(protocol.duration_s / protocol.sample_s)) if bench == "thermal"
                else protocol.schedule()[0].size)
    assert log.n == expected


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--effect", "warmup:w_warmup=1"], "give a value for tau_warmup_min"),
        (["--effect", "warm_up:x=1"], "unknown effect 'warm_up'"),
        (["--set", "w1"], "is not NAME=NUMBER"),
        (["--set", "wq=1"], "parameter 'wq' belongs to no effect"),
        (["--rate-hz", "0"], "--rate-hz"),
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


@pytest.mark.slow
def test_reduced_demo_writes_a_report_whose_figures_exist(tmp_path):
    import re

    from gyroid.pipeline import DemoSize, run_demo

    out = tmp_path / "demo"
    report = run_demo(out, seed=1, echo=lambda _m: None,
                      size=DemoSize(propagate_draws=200, sobol_samples=100, lot_runs=3))
    text = report.read_text()
    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert len(figures) >= 5
    for figure in figures:
        assert (out / figure).exists(), figure
        assert f"*Figure {figures.index(figure) + 1}." in text
    for folder in ("thermal/fit", "magnetic/fit"):
        fit = json.loads((out / folder / "fit.json").read_text())
        assert all(v["r_hat"] <= 1.01 for v in fit["posterior"].values())
    assert json.loads((out / "propagate" / "propagate.json").read_text())["draws"] == 200
    assert json.loads((out / "discrepancy" / "discrepancy.json").read_text())["added"] == [
        "magnetic_hysteresis"]
    assert "audit" in json.loads((out / "reproduce" / "reproduce.json").read_text())
    assert not list(tmp_path.glob(".*staging*"))
    # Each figure sits in its own section, on a line of its own (the pooling figures once
    # came before the pooling heading, one inside a bullet).
    assert text.index("## 7.") < text.index("(pool/forest.png)")
    assert all(line.startswith("![Figure") for line in text.splitlines() if "![Figure" in line)
    # The discrepancy section gives the size of the effect it added, and RMS values that
    # differ where they differ.
    assert "hys_y = " in text
    rms = re.search(r"- RMS (\S+) -> (\S+) deg/h", text)
    assert rms and rms.group(1) != rms.group(2)
    # A summary first: each answer, whether to use it (the exit code's verdict), what to do
    summary = text[text.index("## Summary"):text.index("## 1.")]
    assert "| answer | found | use it? | what to do |" in summary
    for answer in ("thermal fit", "magnetic fit", "dK", "hidden effect", "compensated",
                   "runs pooled"):
        assert answer in summary, answer
    assert "| parameter | unit | truth |" in text


@pytest.fixture(scope="module")
def simulated_magnetic(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "magnetic"
    assert main(["simulate", "magnetic", "--out", str(out), "--seed", "5"]) == 0
    return out / "bench.csv"


@pytest.mark.slow
def test_progress_in_a_log_file_is_plain_lines(tmp_path, simulated_magnetic, capsys,
                                               monkeypatch):
    """stderr redirected to a file (not a terminal): emcee's progress, where importance
    sampling's weights send a fit to it (forced here), is whole lines, never carriage
    returns (a bar would write thousands of them into the file)."""
    import gyroid.inference._emcee as emcee_module
    from gyroid.inference._importance import Importance

    monkeypatch.setattr(emcee_module, "PLAIN_EVERY_S", 0.0)
    monkeypatch.setattr(Importance, "_weighted", lambda *_args, **_kwargs: None)
    assert main(["fit", *WHITE, str(simulated_magnetic), "--terms", "magnetic", "--out",
                 str(tmp_path / "fit")]) == 0
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = [line for line in err.splitlines() if line.startswith("emcee: ")]
    assert len(lines) > 100 and lines[-1].split()[1].isdigit()


def test_fit_writes_the_contract_outputs(tmp_path, simulated_magnetic):
    out = tmp_path / "fit"
    assert main(["fit", *WHITE, str(simulated_magnetic), "--terms", "magnetic", "--out", str(out),
                 "--seed", "1", "--no-progress"]) == 0
    fit = json.loads((out / "fit.json").read_text())
    names = ["w0", "wx", "wy", "wz"]
    assert fit["terms"] == ["bias", "magnetic_x", "magnetic_y", "magnetic_z"]
    assert fit["n_samples"] == 13500
    assert list(fit["point"]) == names and list(fit["point_sd"]) == names
    for name in names:
        summary = fit["posterior"][name]
        assert set(summary) >= {"mean", "sd", "ci95", "r_hat", "ess_bulk"}
        assert summary["r_hat"] <= 1.01 and summary["ess_bulk"] >= 400
        assert summary["ci95"][0] < summary["mean"] < summary["ci95"][1]
    assert 0.25 < fit["rms_residual_deg_h"] < 0.35
    for name in ("posterior.nc", "fit.png", "pair.png"):
        assert (out / name).exists()
    from gyroid.io import load_arviz
    az = load_arviz()

    idata = az.from_netcdf(str(out / "posterior.nc"))
    assert set(names) <= set(idata.posterior.data_vars)
    assert "log_likelihood" in idata.groups() and "observed_data" in idata.groups()
    # How the draws were made travels with them.
    assert fit["convergence"]["sampler"]["move"] == "psis"
    assert idata.attrs["sampler"].startswith("importance sampling of the noise level (PSIS")
    assert idata.attrs["sampler"].endswith("coefficients exact given each")
    loo = az.loo(idata)
    assert np.isfinite(loo.elpd_loo)


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (lambda t: t.replace("time_s,", "t,", 1), "column 'time_s' is missing"),
        (lambda t: "\n".join(t.splitlines()[:20] + ["1,abc" + t.splitlines()[20][3:]]
                             + t.splitlines()[21:]), "not a number"),
        (lambda t: t.replace("Hz_uT", "Hz_nT"), "column 'Hz_uT' is missing"),
    ],
)
def test_fit_refuses_a_malformed_log_and_writes_nothing(tmp_path, capsys, simulated_magnetic,
                                                       edit, expected):
    bad = tmp_path / "bad.csv"
    bad.write_text(edit(simulated_magnetic.read_text()))
    out = tmp_path / "fit"
    assert main(["fit", *WHITE, str(bad), "--terms", "magnetic", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err
    assert not out.exists()


def test_discrepancy_help_names_both_log_kinds_and_every_effect():
    from click.testing import CliRunner

    from gyroid.cli import cli
    from gyroid.models import EFFECTS, ROLL_EFFECTS, ROLL_PRESETS

    text = " ".join(CliRunner().invoke(cli, ["discrepancy", "--help"]).output.split())
    assert "bench log" in text and "roll log" in text
    for name in (*EFFECTS, *ROLL_EFFECTS, *ROLL_PRESETS):
        assert name in text, name


def test_a_second_writer_to_one_out_is_refused_and_a_stale_lock_taken_over(
        tmp_path, capsys, simulated_magnetic):
    """Two commands writing one --out at once: the second is refused before it reads the
    log, naming the folder and the process; a lock whose process is gone is taken over and
    removed when the command ends."""
    import subprocess
    import sys

    out = tmp_path / "fit"
    lock = tmp_path / ".fit.lock"
    writer = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        lock.write_text(f"{writer.pid}\n")
        args = ["fit", *WHITE, str(simulated_magnetic), "--terms", "magnetic", "--out", str(out),
                "--no-progress"]
        assert main(args) == 2
        err = capsys.readouterr().err
        assert f"--out {out} is being written by another gyroid command (process " \
               f"{writer.pid})" in err and "Traceback" not in err
        assert not out.exists() and lock.exists()
    finally:
        writer.kill()
        writer.wait()
    # The writer is gone: its lock is stale.
    assert main(args) in (0, 3)
    assert (out / "fit.json").exists() and not lock.exists()


def test_quiet_prints_only_the_failed_checks_and_verbose_the_time(tmp_path, capsys):
    """-q: nothing on stdout, and on stderr only the failed self-checks and the verdict;
    -v: the command's wall time too. The files are the same."""
    rng = np.random.default_rng(0)
    time_s = np.arange(2000.0)
    drift = 1.0 + np.cumsum(rng.normal(0.0, 0.05, 2000)) + rng.normal(0.0, 0.3, 2000)
    log = write_log(tmp_path / "wander.csv", {"time_s": time_s, "drift_deg_h": drift})
    white = ["--noise", "white"]  # which refuses this wander
    assert main(["fit", *WHITE, str(log), "--terms", "bias", "--out", str(tmp_path / "loud"),
                 "--no-progress", *white]) == 3
    loud = capsys.readouterr()
    assert main(["fit", *WHITE, str(log), "--terms", "bias", "--out", str(tmp_path / "quiet"), "-q",
                 *white]) == 3
    quiet = capsys.readouterr()
    assert quiet.out == "" and loud.out
    lines = quiet.err.splitlines()
    assert lines and all(line.startswith(("error:", "warning:", "NOT TRUSTWORTHY"))
                         for line in lines), lines
    assert set(lines) <= set(loud.err.splitlines())
    assert sorted(p.name for p in (tmp_path / "quiet").iterdir()) == sorted(
        p.name for p in (tmp_path / "loud").iterdir())
    assert main(["simulate", "thermal", "--hours", "0.2", "--out", str(tmp_path / "sim"),
                 "--verbose"]) == 0
    assert "gyroid simulate: " in capsys.readouterr().err


def test_the_noise_choices_the_help_lists_are_the_models_gyroid_fits():
    """The command line writes --noise's names out (importing them imports JAX)."""
    from gyroid.cli.base import NOISE_CHOICES
    from gyroid.noise import NOISE_MODELS

    assert set(NOISE_CHOICES) == {"auto", *NOISE_MODELS}


def test_the_terms_the_help_lists_are_the_registries():
    """--terms's help names the presets and effects without importing JAX: the same names,
    in the same order, as the registries gyroid fits them from."""
    from gyroid.cli.base import CANDIDATE_EFFECTS, PAPER_EFFECTS, TERM_PRESETS
    from gyroid.models._effects import CANDIDATES, EFFECTS
    from gyroid.models._terms import PRESETS

    assert TERM_PRESETS == tuple(PRESETS)
    assert CANDIDATE_EFFECTS == tuple(CANDIDATES)
    assert PAPER_EFFECTS == tuple(n for n in EFFECTS if n not in CANDIDATES)
