"""gyroid noise (docs/formats.md section 5): the IEEE Std 952 terms of a static log with
posterior intervals, against logs simulated here (independently of gyroid) with known
terms; the Haar statistics it rests on; the command's files and refusals."""

import json

import numpy as np
import pytest
from helpers import write_log
from scipy import stats

from gyroid.cli import main
from gyroid.inference import fit_noise
from gyroid.inference._haar import haar_statistics


def _static_rate(rng, n: int, dt: float, *, N: float = 0.0, K: float = 0.0,
                 Q: float = 0.0, R: float = 0.0) -> np.ndarray:
    """Rate, deg/h: angle random walk N (deg/sqrt(h)), rate random walk K (deg/h/sqrt(h)),
    angle quantisation Q (deg), rate ramp R (deg/h^2), by their IEEE definitions."""
    rate = rng.normal(0.0, 60.0 * N / np.sqrt(dt), n)
    rate += np.cumsum(rng.normal(0.0, K / 60.0 * np.sqrt(dt), n))
    rate += np.diff(rng.normal(0.0, 3600.0 * Q, n + 1)) / dt
    return rate + R / 3600.0 * dt * np.arange(n)


def test_haar_statistics_of_a_ramp_are_exact_and_never_span_a_gap():
    dt, slope = 0.5, 2.0  # s, deg/h per s
    rate = slope * dt * np.arange(64)
    one = haar_statistics(rate, dt)
    # Every pair of blocks of m samples differs by slope * m * dt: AVAR = (slope tau)^2 / 2.
    np.testing.assert_allclose(one.avar, (slope * one.tau_s) ** 2 / 2, rtol=1e-12)
    split = haar_statistics(np.concatenate([rate[:32], rate[32:] + 1e6]), dt,
                            [(0, 32), (32, 64)])
    np.testing.assert_allclose(split.avar, (slope * split.tau_s) ** 2 / 2, rtol=1e-12)
    assert split.count[0] == 32 and split.segments == 2


def test_white_and_rate_random_walk_recovered_with_honest_intervals():
    rng = np.random.default_rng(7)
    truth = {"N": 0.3, "K": 20.0}
    result = fit_noise(_static_rate(rng, 400_000, 0.01, **truth), 0.01, seed=1)
    summary = result.summary()
    assert result.trustworthy, result.checks.failed
    assert summary["N"]["resolved"] and summary["K"]["resolved"]
    for name, value in truth.items():
        # A 90 % interval misses with probability 0.1 per term: both miss one seed in 100.
        lo, hi = summary[name]["ci90"]
        assert lo < value < hi, (name, summary[name])
    assert not summary["Q"]["resolved"] and summary["Q"]["ci90"] is None
    assert summary["Q"]["upper_bound_95"] > 0


@pytest.mark.slow
def test_intervals_cover_at_their_nominal_rate():
    """24 logs of white noise, a rate random walk and quantisation: each resolved term's 90 %
    interval (or an unresolved term's 95 % bound) holds its truth at a rate inside the
    binomial band of 24 draws at 0.9 (99 % two-sided)."""
    truth = {"N": 0.2, "K": 30.0, "Q": 2e-4}
    inside = dict.fromkeys(truth, 0)
    for seed in range(24):
        rng = np.random.default_rng(100 + seed)
        summary = fit_noise(_static_rate(rng, 60_000, 0.01, **truth), 0.01,
                            seed=seed).summary()
        for name, value in truth.items():
            entry = summary[name]
            inside[name] += (entry["ci90"][0] <= value <= entry["ci90"][1] if entry["resolved"]
                             else value <= entry["upper_bound_95"])
    low = stats.binom.ppf(0.005, 24, 0.9)
    assert all(count >= low for count in inside.values()), inside


def test_noise_command_writes_each_axis(tmp_path):
    rng = np.random.default_rng(3)
    n, dt = 50_000, 0.01
    columns = {"time_s": dt * np.arange(n)}
    for axis, arw in (("x", 0.2), ("y", 0.5), ("z", 1.0)):
        columns[f"drift_{axis}_deg_h"] = _static_rate(rng, n, dt, N=arw) + 40.0
    log = write_log(tmp_path / "static.csv", columns)
    out = tmp_path / "noise"
    assert main(["noise", str(log), "--out", str(out)]) == 0
    record = json.loads((out / "axes.json").read_text())
    assert list(record["axes"]) == ["x", "y", "z"]
    for axis, arw in (("x", 0.2), ("y", 0.5), ("z", 1.0)):
        noise = json.loads((out / axis / "noise.json").read_text())
        assert set(noise["terms"]) == {"N", "B", "K", "Q", "R"}
        entry = noise["terms"]["N"]
        assert entry["unit"] == "deg/sqrt(h)" and entry["resolved"]
        assert entry["ci90"][0] < arw < entry["ci90"][1]
        assert noise["trustworthy"] and (out / axis / "allan.png").exists()


def test_noise_refuses_an_irregular_clock(tmp_path, capsys):
    rng = np.random.default_rng(0)
    time_s = np.cumsum(rng.uniform(0.005, 0.015, 5000))
    log = write_log(tmp_path / "jitter.csv", {"time_s": time_s,
                                                "drift_deg_h": rng.normal(0, 10, 5000)})
    assert main(["noise", str(log), "--out", str(tmp_path / "out")]) == 2
    assert "regular clock" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_drifting_log_fails_the_level_check(tmp_path):
    """A log that is not static (a periodic disturbance, 20 s period) leaves averaging times
    no sum of the noise terms can fit."""
    rng = np.random.default_rng(2)
    n, dt = 100_000, 0.01
    t = dt * np.arange(n)
    rate = _static_rate(rng, n, dt, N=0.1) + 20.0 * np.sin(2 * np.pi * t / 20.0)
    result = fit_noise(rate, dt, seed=0)
    assert not result.trustworthy
    assert any(c.name == "level_fit" for c in result.checks.failed)


@pytest.mark.slow
def test_static_keeps_the_still_stretches_of_a_log_that_moves(tmp_path, capsys):
    """A hand-held IMU still but for two turns (up to 30 deg/s for 20 s and 40 s about x):
    fitted whole, the turns are not noise (level_fit fails); with --static 0.05 (a 1 s
    mean's noise is 0.008 deg/s) only the still rows are fitted, in three stretches, and N
    is recovered on every axis."""
    rng = np.random.default_rng(8)
    n, dt, arw = 60_000, 0.01, 0.5
    t = dt * np.arange(n)
    turning = ((t >= 150) & (t < 170)) | ((t >= 400) & (t < 440))
    columns = {"time_s": t}
    for axis in "xyz":
        columns[f"drift_{axis}_deg_h"] = _static_rate(rng, n, dt, N=arw) + 36.0
    columns["drift_x_deg_h"] += np.where(turning, 30.0 * 3600.0, 0.0) * np.sin(
        np.pi * (t - 150.0) / 20.0) ** 2
    log = write_log(tmp_path / "handheld.csv", columns)
    assert main(["noise", str(log), "--axes", "x", "--out", str(tmp_path / "whole")]) == 3
    capsys.readouterr()
    out = tmp_path / "still"
    assert main(["noise", str(log), "--static", "0.05", "--out", str(out)]) == 0
    assert "in 3 still stretch(es)" in capsys.readouterr().err
    kept = json.loads((out / "axes.json").read_text())["source"]["static"]
    # The turns' 6000 rows go, and either side of each half the 1 s window (where the mean
    # sees the turn) and the 1 s margin: 150 rows per edge, 600 in all, give or take the
    # turns' gentle starts.
    assert n - 6900 < kept["rows_kept"] < n - 6500
    for axis in "xyz":
        entry = json.loads((out / axis / "noise.json").read_text())["terms"]["N"]
        assert entry["ci90"][0] < arw < entry["ci90"][1]
