"""gyroid batch: many logs on Dask, one bad log failing alone (contract section 3)."""

import csv
import json

import pytest
from helpers import SHORT_THERMAL, WHITE, write_log

from gyroid.cli import main
from gyroid.simulation import simulate_thermal_bench


@pytest.mark.slow
def test_a_lot_is_fitted_on_dask_and_a_bad_log_fails_alone(tmp_path, capsys):
    # Two units' logs named alike in their own folders (as 'gyroid simulate --runs' and many
    # test stands write them): each fit goes to its folder's name.
    logs = []
    for seed in (1, 2):
        sim = simulate_thermal_bench(seed=seed, protocol=SHORT_THERMAL)
        (tmp_path / f"unit{seed}").mkdir()
        logs.append(write_log(tmp_path / f"unit{seed}" / "bench.csv", sim.log.columns))
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,drift_deg_h,temperature_C\n0,1,20\n1,x,20\n2,1,21\n")
    out = tmp_path / "lot"
    code = main(["batch", *WHITE, str(logs[0]), str(bad), str(logs[1]), "--terms", "thermal",
                 "--out", str(out), "--workers", "2", "--priors", "paper_a_fog",
                 "--prior", "w0=normal(0,5)", "--t0", "20", "--rate-window", "900",
                 "--noise", "white"])
    assert code == 3  # a log failed: the lot's summary is incomplete
    summary = json.loads((out / "batch.json").read_text())
    assert summary["workers"] == 2 and summary["scheduler"] == "LocalCluster"
    assert summary["logs"] == [str(logs[0]), str(bad), str(logs[1])]
    assert [f["log"] for f in summary["failed"]] == [str(bad)]
    assert "row 2" in summary["failed"][0]["message"]
    rows = list(csv.DictReader((out / "batch.csv").open()))
    assert [r["log"] for r in rows] == [str(logs[0]), str(logs[1])]
    for row, log in zip(rows, logs, strict=True):
        fit = json.loads((out / log.parent.name / "fit.json").read_text())
        assert (out / log.parent.name / "posterior.nc").exists()
        assert fit["prior_set"] == "paper_a_fog" and fit["priors"]["w0"] == "Normal(0, 5)"
        assert fit["t0_C"] == 20.0 and fit["rate_window_s"] == 900.0
        assert float(row["w1_mean"]) == pytest.approx(fit["posterior"]["w1"]["mean"])
        assert row["trustworthy"] == str(fit["trustworthy"])
        assert int(row["n_samples"]) == fit["n_samples"]
    assert "failed: " in capsys.readouterr().err


def test_logs_that_would_share_a_folder_are_refused_before_any_work(tmp_path, capsys):
    # Same file name and same folder name (two stands' day1/unit.csv): no label tells
    # them apart.
    for stand in ("x", "y"):
        (tmp_path / stand / "day1").mkdir(parents=True)
        (tmp_path / stand / "day1" / "unit.csv").write_text("time_s,drift_deg_h\n0,1\n")
    code = main(["batch", *WHITE, str(tmp_path / "x" / "day1" / "unit.csv"),
                 str(tmp_path / "y" / "day1" / "unit.csv"), "--terms", "thermal", "--out",
                 str(tmp_path / "lot")])
    assert code == 2
    assert "the same name 'unit' and folder" in capsys.readouterr().err
    assert not (tmp_path / "lot").exists()


def test_batch_takes_every_option_fit_takes():
    from gyroid.cli import cli

    def options(command) -> set[str]:
        return {name for p in command.params for name in p.opts if name.startswith("--")}

    fit, batch = cli.commands["fit"], cli.commands["batch"]
    assert options(fit) <= options(batch), options(fit) - options(batch)


def test_bad_options_are_refused_before_any_log_is_read(tmp_path, capsys):
    log = tmp_path / "does_not_exist.csv"
    for args, message in ((["--seed", "-1"], "--seed"), (["--t0", "nan"], "--t0"),
                          (["--rate-window", "-5"], "--rate-window")):
        for command in ("fit", "batch"):
            code = main([command, str(log), "--terms", "thermal", "--out",
                         str(tmp_path / "o"), *args])
            assert code == 2, (command, args)
            err = capsys.readouterr().err
            assert message in err and "no such file" not in err, err
