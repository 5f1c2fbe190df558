"""gyroid noise (docs/formats.md section 5): the IEEE Std 952 terms of a static log with
posterior intervals, against logs simulated here (independently of gyroid) with known
terms; the Haar statistics it rests on; the command's files and refusals."""

import json
import math

import numpy as np
import pytest
from helpers import write_log
from scipy import stats

from gyroid.allan import fit_noise
from gyroid.allan._haar import haar_statistics
from gyroid.bench import BenchOptions
from gyroid.cli import main


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
    summary = result.term_summaries()
    assert result.trustworthy, result.checks.failed
    assert summary["N"]["resolved"] and summary["K"]["resolved"]
    for name, value in truth.items():
        # A 90 % interval misses with probability 0.1 per term: both miss one seed in 100.
        lo, hi = summary[name]["ci90"]
        assert lo < value < hi, (name, summary[name])
    assert not summary["Q"]["resolved"] and summary["Q"]["ci90"] is None
    assert summary["Q"]["upper_bound_95"] > 0


def test_a_term_sets_posterior_by_importance_sampling_matches_quadrature():
    """One set of terms (N and K) sampled with the default sampler (importance sampling on
    the log-amplitudes) against the exact posterior by quadrature on a fine grid of its
    own host log-posterior: each log-amplitude's mean within 4 Monte-Carlo standard errors
    (its sd over the square root of the effective draws) and its sd within 10 %. 400 s of
    log does not resolve K: its posterior keeps the prior's lower tail (sd 3.3 in log)."""
    from gyroid.allan._problem import NoiseProblem
    from gyroid.inference import fit

    rng = np.random.default_rng(11)
    stats_ = haar_statistics(_static_rate(rng, 40_000, 0.01, N=0.3, K=25.0), 0.01)
    problem = NoiseProblem.from_statistics(stats_, ("N", "K"))
    result = fit(problem, seed=3)
    assert result.sampled.move == "psis", result.sampled.method
    point = problem.mode()
    sd = np.sqrt(np.diag(point.covariance_u))
    loc, scale = np.asarray(problem.density.prior_loc), np.asarray(problem.density.prior_scale)
    # each axis: fine about the mode (10 sd) and coarse over the prior (5 sd), where an
    # unresolved level's posterior keeps the prior's tail; trapezoid weights
    axes, widths = [], []
    for u, s, a, b in zip(point.u, sd, loc, scale, strict=True):
        axis = np.unique(np.concatenate([np.linspace(u - 10 * s, u + 10 * s, 301),
                                         np.linspace(a - 5 * b, a + 5 * b, 601)]))
        step = np.diff(axis)
        axes.append(axis)
        widths.append(np.concatenate([[step[0]], step[:-1] + step[1:], [step[-1]]]) / 2)
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    log_p = problem.host_log_posterior()(grid)
    weight = np.exp(log_p - log_p.max()) * np.outer(*widths).ravel()
    weight /= weight.sum()
    exact_mean = weight @ grid
    exact_sd = np.sqrt(weight @ (grid - exact_mean) ** 2)
    draws = np.log(result.sampled.draws.reshape(-1, 2))
    effective = min(e["ess_bulk"] for e in result.sampled.summary.values())
    error = np.abs(draws.mean(axis=0) - exact_mean) / (exact_sd / np.sqrt(effective))
    assert np.all(error < 4.0), (error, exact_mean, draws.mean(axis=0))
    np.testing.assert_allclose(draws.std(axis=0), exact_sd, rtol=0.10)


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
                            seed=seed).term_summaries()
        for name, value in truth.items():
            entry = summary[name]
            inside[name] += (entry["ci90"][0] <= value <= entry["ci90"][1] if entry["resolved"]
                             else value <= entry["upper_bound_95"])
    low = stats.binom.ppf(0.005, 24, 0.9)
    assert all(count >= low for count in inside.values()), inside


@pytest.mark.slow
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
    fitted whole, the turns are not noise (level_fit and dispersion fail: warnings); with
    --static 0.05 (a 1 s mean's noise is 0.008 deg/s) only the still rows are fitted, in
    three stretches, and N is recovered on every axis."""
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
    main(["noise", str(log), "--axes", "x", "--out", str(tmp_path / "whole")])
    checks = json.loads((tmp_path / "whole" / "noise.json").read_text())["checks"]["checks"]
    assert {"level_fit", "dispersion"} <= {n for n, c in checks.items() if not c["passed"]}
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


def test_a_noise_fit_becomes_the_drift_fits_noise_prior_with_the_same_intervals():
    """--noise DIR: a resolved term's 90 % interval is its prior's 90 % interval (where it
    reaches zero, its interval where present), an unresolved term's bound its prior's 95 %
    quantile (datasheet units, any sample rate)."""
    from gyroid.noise import noise_model, priors_from_noise

    terms = {"N": {"resolved": True, "ci90": [0.29, 0.31]},
             "B": {"resolved": True, "ci90": [0.0, 7.0]},  # reaches 0: read as a bound
             "K": {"resolved": False, "ci90": None, "upper_bound_95": 25.0}}
    priors = priors_from_noise(terms, noise_model("white+flicker+rw"))
    z = stats.norm.ppf(0.95)
    n = priors["N_deg_sqrt_h"]
    np.testing.assert_allclose(np.exp(np.log(n.median) + np.array([-z, z]) * n.log_sd),
                               [0.29, 0.31], rtol=1e-12)
    for name, bound in (("B_deg_h", 7.0), ("K_deg_h_sqrt_h", 25.0)):
        assert math.exp(math.log(priors[name].median) + z * priors[name].log_sd) == \
            pytest.approx(bound, rel=1e-12)
    # the interval reaches 0 because sets without B (a bump read for the floor) have weight:
    # the drift model's B, which stands for that floor, takes B's interval where present
    terms["B"]["ci90_if_present"] = [5.0, 7.2]
    b = priors_from_noise(terms, noise_model("white+flicker+rw"))["B_deg_h"]
    np.testing.assert_allclose(np.exp(np.log(b.median) + np.array([-z, z]) * b.log_sd),
                               [5.0, 7.2], rtol=1e-12)


def _gyro_noise(rng, n: int, dt: float) -> np.ndarray:
    """N 0.3 deg/sqrt(h), flicker of B 6 deg/h, K 20 deg/h/sqrt(h), deg/h."""
    return (_static_rate(rng, n, dt, N=0.3, K=20.0)
            + 6.0 / math.sqrt(2.0 * math.pi * dt) * _unit_flicker(rng, n, dt))


def _unit_flicker(rng, n: int, dt: float) -> np.ndarray:
    spectrum = np.fft.rfft(rng.normal(size=2 * n))
    f = np.fft.rfftfreq(2 * n, dt)
    spectrum[1:] /= np.sqrt(f[1:])
    spectrum[0] = 0.0
    return np.fft.irfft(spectrum)[:n]


@pytest.mark.slow
def test_fit_takes_its_noise_priors_from_a_static_noise_fit(tmp_path):
    """gyroid noise on the gyro at rest (8 h at 2 Hz), then gyroid fit --noise DIR on a
    temperature ramp (1 Hz) of the same gyro: IEEE noise with the static posteriors as
    priors, said in fit.json; the ramp's own B interval is then narrower than it is under
    the default priors (the static log knows more about B), and still holds the truth.
    (At 2 h this gyro's flicker floor spans some 1.5 decades of averaging time, where a
    Gauss-Markov bump and the walk can stand in for it: the fit gives that reading weight,
    and B's interval reaches zero.)"""
    rng = np.random.default_rng(5)
    n, dt = 57_600, 0.5
    static = write_log(tmp_path / "static.csv", {"time_s": dt * np.arange(n),
                                                 "drift_x_deg_h": 40.0 + _gyro_noise(rng, n, dt)})
    noise_dir = tmp_path / "noise"
    assert main(["noise", str(static), "--out", str(noise_dir)]) == 0
    static_b = json.loads((noise_dir / "noise.json").read_text())["terms"]["B"]
    assert static_b["resolved"] and static_b["ci90"][0] < 6.0 < static_b["ci90"][1]
    t = np.arange(1500.0)
    temperature = 21.0 + 20.0 * np.sin(np.pi * t / t[-1])
    ramp = write_log(tmp_path / "ramp.csv", {
        "time_s": t, "temperature_C": temperature,
        "drift_x_deg_h": 2.0 + 0.5 * (temperature - 21.0) + _gyro_noise(rng, t.size, 1.0)})
    out = tmp_path / "fit"
    code = main(["fit", str(ramp), "--terms", "bias,temperature", "--noise", str(noise_dir),
                 "--out", str(out), "--no-progress"])
    record = json.loads((out / "fit.json").read_text())
    assert code == 0 and record["noise"]["model"] == "white+flicker+rw"
    assert f"from the noise fit in {noise_dir}" in record["noise_choice"]
    low, high = static_b["ci90"]
    assert record["priors"]["B_deg_h"].startswith(f"LogNormal(median {math.sqrt(low * high):g}")
    b = record["noise"]["posterior"]["B_deg_h"]
    assert b["ci95"][0] < 6.0 < b["ci95"][1]
    # the same ramp, default priors: its B is what the 1500 s ramp alone can say
    from gyroid.bench import fit_log
    from gyroid.io import load_bench_log

    alone = fit_log(load_bench_log(ramp, "bias,temperature", axis="x"), "bias,temperature",
                    BenchOptions(noise="white+flicker+rw"), sample=False).point.sd["B_deg_h"]
    assert record["noise"]["point_sd"]["B_deg_h"] < 0.7 * alone


def _noise_record(trustworthy: bool) -> str:
    """A noise.json as 'gyroid noise' writes it (the fields --noise DIR reads)."""
    terms = {"N": {"resolved": True, "ci90": [0.29, 0.31]},
             "B": {"resolved": True, "ci90": [5.5, 6.5]},
             "K": {"resolved": False, "ci90": None, "upper_bound_95": 25.0}}
    return json.dumps({"terms": terms, "allan": {"tau_s": [1.0, 2.0],
                                                 "model_adev_deg_h": [20.0, 14.0]},
                       "sample_s": 0.5, "trustworthy": trustworthy})


def test_fit_refuses_noise_folders_that_cannot_serve_as_priors(tmp_path, capsys):
    """Refused with one message before any fit: a noise fit that failed its own checks,
    one of other axes, a folder that is not there (the message names the choices)."""
    t = np.arange(200.0)
    log = write_log(tmp_path / "two.csv", {"time_s": t, "drift_x_deg_h": t * 0 + 1.0,
                                           "drift_y_deg_h": t * 0 + 2.0})
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "noise.json").write_text(_noise_record(False))
    x_only = tmp_path / "x_only"
    (x_only / "x").mkdir(parents=True)
    (x_only / "x" / "noise.json").write_text(_noise_record(True))
    (x_only / "axes.json").write_text(json.dumps({"axes": ["x"]}))
    for noise, axes, said in ((bad, "x", "not trustworthy"), (x_only, "x,y", "not of axis y"),
                              ("whit", "x", "auto, white, white+gm, white+flicker+rw")):
        assert main(["fit", str(log), "--terms", "bias", "--noise", str(noise), "--axes",
                     axes, "--out", str(tmp_path / "no")]) == 2
        assert said in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_a_prefiltered_output_is_modelled_not_read_as_white_noise():
    """A gyro's output through a two-tap average (a digital low-pass filter): its Allan
    variance is ``sigma^2 / m - 0.75 sigma^2 / m^2`` exactly, below white noise by a
    ``1 / tau^2`` term, the prefilter F. Read as independent Haar coefficients of white noise
    it had given N = 0.22 with a 90 % interval 5 % wide for a truth of 0.5 (60 000 samples),
    then, with the mismatch measured as overdispersion, a refusal; with F in the model the
    truth is covered. The same white noise unfiltered has no F and the same N."""
    rng = np.random.default_rng(0)
    dt, n, arw = 0.01, 20_000, 0.5
    white = rng.normal(0.0, 60.0 * arw / np.sqrt(dt), n + 1)
    filtered = fit_noise(0.5 * (white[1:] + white[:-1]), dt)
    assert filtered.trustworthy and filtered.prefilter()["resolved"]
    low, high = filtered.term_summaries()["N"]["ci90"]
    assert low < arw < high
    clean = fit_noise(white[1:], dt)
    assert clean.dispersion == 1.0 and clean.trustworthy
    assert not clean.prefilter()["resolved"]
    low, high = clean.term_summaries()["N"]["ci90"]
    assert low < arw < high


def _filtered_static(rng, hours: float, cutoff_hz: float) -> np.ndarray:
    """A phone-grade gyro at rest as its logger writes it: white noise (N 2.5 deg/sqrt(h))
    at 100 Hz, low-passed forward and backward (4th-order Butterworth) and decimated to
    10 Hz, deg/h."""
    from scipy import signal

    fs = 100.0
    white = rng.normal(0.0, 60.0 * 2.5 * np.sqrt(fs), int(hours * 3600 * fs))
    b, a = signal.butter(4, cutoff_hz / (fs / 2.0))
    return signal.filtfilt(b, a, white)[::10]


@pytest.mark.parametrize("cutoff_hz", [2.0, 1.5])
def test_a_filtered_logs_shortest_averaging_times_are_left_out_and_n_read_above_them(
        cutoff_hz):
    """A phone-grade log low-passed well below its new Nyquist frequency (lag-1
    correlation 0.8-0.9): its Allan deviation rises over the first few averaging times
    before white noise's fall. N with the deficit F could cross the shortest level there and
    pass its test while missing the next ones, so nothing was left out: for N 2.5 the 90 %
    intervals were [2.28, 2.44] (cutoff 2 Hz) and [0.00002, 0.22] (1.5 Hz, the white noise
    read as a Gauss-Markov bias at 0.2 s), each fit refused for its misfit at long averaging
    times. The three shortest levels are now tested together: those the filter shapes are
    left out (a warning), N is read above them and covered, and every level fits."""
    rate = _filtered_static(np.random.default_rng(0), 2.0, cutoff_hz)
    fit = fit_noise(rate, 0.1)
    assert fit.trustworthy, fit.summary()
    failed = {c.name for c in fit.checks.failed}
    assert "prefilter" in failed and not failed & {"level_fit", "level_runs", "dispersion"}
    # the levels left out are written beside the fitted ones (and drawn in allan.png)
    allan = fit.to_json()["allan"]
    left_out = allan["left_out"]["tau_s"]
    assert len(left_out) == next(c.value for c in fit.checks.checks if c.name == "prefilter")
    assert max(left_out) < min(allan["tau_s"]) and left_out[0] == pytest.approx(0.1)
    low, high = fit.term_summaries()["N"]["ci90"]
    assert low < 2.5 < high


@pytest.mark.slow
def test_a_filtered_logs_n_is_not_lifted_by_the_filters_shape():
    """Just above the levels a phone-grade filter visibly shapes, its deficit below white
    noise is still some 30 % and its shape there departs from F's ``1 / tau^2`` by about
    4 % of the Allan variance: read as F's, those levels lifted N by 0.8 % (its posterior sd
    0.6 %), and N's 90 % intervals held 21 of 50 truths. Over eight 6 h logs (N 2.5) each
    N's error over its posterior sd (the mean's sd is 0.35 under a calibrated fit) has a
    mean within 3 sd of zero and a spread near one; it was about 1.3 (by the levels' exact
    Allan variance). The filter's deficit read there enters as the log's own measurement,
    not as a prior the prior-data check would weigh (as one it warned on such logs)."""
    z = []
    for seed in range(8):
        fit = fit_noise(_filtered_static(np.random.default_rng(100 + seed), 6.0, 1.5), 0.1)
        assert fit.trustworthy and "F" in fit.terms
        # F's reading at the levels left out is the log's, not a prior to disagree with
        assert not [c.name for c in fit.checks.failed if c.name.startswith("prior_data")]
        draws = fit.draws("N")
        z.append((np.mean(draws) - 2.5) / np.std(draws))
    assert abs(np.mean(z)) < 3.0 / math.sqrt(len(z)), z
    assert 0.4 < np.std(z, ddof=1) < 2.0, z


def test_a_start_up_transient_does_not_make_the_samples_after_it_outliers():
    """A phone-grade log (white noise at 100 Hz low-passed forward and backward, decimated
    to 10 Hz) whose first raw sample is 4 sd high: the filter's edge leaves its first two
    samples some 24 and 10 sd off. The minute's running mean a flagged sample must also
    stand out from was padded with the first sample repeated half a minute's times, dragged
    far off, and the samples just after the transient (within 4 sd of the minute's mean)
    were named outliers in 4 of these 4 logs; the mean is now cut at the log's ends."""
    from scipy import signal

    from gyroid.allan._outliers import remove_outliers

    b, a = signal.butter(4, 1.5 / 50.0)
    for seed in (0, 2, 4, 8):
        white = np.random.default_rng(seed).normal(0.0, 1500.0, 360_000)
        white[0] = 4.0 * 1500.0
        rate = signal.filtfilt(b, a, white)[::10]
        _, found = remove_outliers(rate, sample_s=0.1)
        assert not set(found.rows.tolist()) - {0, 1}, (seed, found.rows)


@pytest.mark.parametrize("cutoff_hz", [2.0, 1.0])
def test_a_filtered_logs_samples_are_not_outliers_and_its_spikes_are(cutoff_hz):
    """A filtered log's neighbours sit close to each sample (lag-1 correlation 0.78 and
    0.94 here), so their medians' residuals have a collapsed scale: the neighbour test alone
    named 9 and 263 of 216,000 samples outliers (a real phone log: 24 %). A sample is an
    outlier only if it also stands beyond 5 robust sd of a minute's running mean: none
    here, while 12 sd spikes added to three samples are named, each that far from it."""
    from scipy.ndimage import uniform_filter1d

    from gyroid.allan._outliers import WITHIN_MEAN_SD, remove_outliers

    rate = _filtered_static(np.random.default_rng(7), 6.0, cutoff_hz)
    _, found = remove_outliers(rate, sample_s=0.1)
    assert found.rows.size == 0
    spiked = rate.copy()
    rows = [5_000, 90_000, 150_000]
    spiked[rows] += 12.0 * np.std(rate)
    _, found = remove_outliers(spiked, sample_s=0.1)
    assert found.rows.tolist() == rows
    about = spiked - uniform_filter1d(spiked, 601, mode="nearest")
    spread = 1.4826 * np.median(np.abs(about - np.median(about)))
    assert np.all(np.abs(about[found.rows]) > WITHIN_MEAN_SD * spread)
