"""A Parquet log too long to hold, read as a stream (docs/formats.md section 1): the same block
means, spikes and errors as the log held whole, batch boundaries and pauses anywhere."""

import json
import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from gyroid.bench import BenchOptions, fit_log
from gyroid.cli import main
from gyroid.errors import GyroidInputError
from gyroid.inference._residual_checks import outliers_among
from gyroid.io import MeansOfBlocks, load_bench_log, stream_block_means


def _write(path, columns, row_group_rows=5000):
    pq.write_table(pa.table(columns), path, row_group_size=row_group_rows)
    return path


def _ramp(rng, n=60_000, dt=0.1):
    """Two axes of a temperature ramp (drift 2 + 0.5 t), a pause of 30 s after row 25 001,
    white noise and four spikes on x."""
    time_s = dt * np.arange(n) + np.where(np.arange(n) > 25_000, 30.0, 0.0)
    temperature = 21.0 + 20.0 * np.sin(np.pi * time_s / time_s[-1])
    columns = {"time_s": time_s, "temperature_C": temperature}
    for axis, sd in (("x", 3.0), ("y", 5.0)):
        columns[f"drift_{axis}_deg_h"] = 2.0 + 0.5 * (temperature - 21.0) + rng.normal(
            0.0, sd, n)
    columns["drift_x_deg_h"][[k for k in (7, 9_998, 25_003, 41_234) if k < n]] += 200.0
    return columns


@pytest.mark.parametrize("batch_rows", [7_777, 20_000])
def test_the_stream_gives_the_means_and_spikes_of_the_whole_log(tmp_path, batch_rows):
    columns = _ramp(np.random.default_rng(0))
    path = _write(tmp_path / "long.parquet", columns)
    streamed = stream_block_means(path, "bias,temperature", ("x", "y"), (), 60,
                                  batch_rows=batch_rows)
    for axis in ("x", "y"):
        whole = MeansOfBlocks.of(load_bench_log(path, "bias,temperature", axis=axis), 60)
        got = streamed[axis]
        assert got.rows_per_mean == 60 and got.log.n == whole.log.n
        for name, values in whole.log.columns.items():
            np.testing.assert_allclose(got.log.columns[name], values, rtol=1e-13, atol=1e-12)
        # the first block after the pause starts at its first row (25 002), named as the file
        assert any("row 25002 of long.parquet" in got.log.where(k) for k in range(got.log.n))
        for k in (0, 400, got.log.n - 1):
            assert got.log.where(k) == whole.log.where(k)
        a, b = got.samples, whole.samples
        assert a.n == b.n == 60_000
        assert a.within_sd == pytest.approx(b.within_sd, rel=1e-12)
        assert a.z_sum_sq == pytest.approx(b.z_sum_sq, rel=1e-9)
        # the spike check reads the same
        ca = outliers_among(a.n, a.rows, a.z, a.z_sum_sq, where=a.where)
        cb = outliers_among(b.n, b.rows, b.z, b.z_sum_sq, where=b.where)
        assert ca.message == cb.message and ca.passed == cb.passed
    spikes = outliers_among(streamed["x"].samples.n, streamed["x"].samples.rows,
                            streamed["x"].samples.z, streamed["x"].samples.z_sum_sq,
                            where=streamed["x"].samples.where)
    assert not spikes.passed and spikes.message.startswith("4 sample(s)")
    # the three worst named by the file's row, the fourth as "1 more"
    named = [row for row in (8, 9_999, 25_004, 41_235)
             if f"row {row} of long.parquet" in spikes.message]
    assert len(named) == 3 and "and 1 more" in spikes.message


@pytest.mark.slow  # two fits of block means: 15 s of the quick signal with an empty cache
def test_a_fit_of_the_stream_is_the_fit_of_the_whole_log(tmp_path):
    columns = _ramp(np.random.default_rng(1))
    for name in ("drift_x_deg_h", "drift_y_deg_h"):
        columns[name][[7, 9_998, 25_003, 41_234]] = columns[name][[6, 9_997, 25_002, 41_233]]
    path = _write(tmp_path / "long.parquet", columns)
    streamed = stream_block_means(path, "bias,temperature", ("x",), (), 60, batch_rows=9_000)
    whole = MeansOfBlocks.of(load_bench_log(path, "bias,temperature", axis="x"), 60)
    a = fit_log(streamed["x"], "bias,temperature", BenchOptions(noise="white+flicker+rw"),
                sample=False)
    b = fit_log(whole, "bias,temperature", BenchOptions(noise="white+flicker+rw"), sample=False)
    for name in a.point.names:
        assert a.point.value[name] == pytest.approx(b.point.value[name], rel=1e-6, abs=1e-9)
    assert a.to_json()["block_means"] == {"means": 999, "rows_per_mean": 60, "rows": 60_000}
    assert 1.9 - 3 * a.point.sd["w0"] < 2.0 < 2.0 + 3 * a.point.sd["w0"]


def _fit_axis_y(path, out, capsys) -> tuple[int, str, dict]:
    """`gyroid fit` of ``path``'s y axis (bias and temperature, white noise): the exit code,
    what it said on stderr and its fit.json."""
    code = main(["fit", str(path), "--terms", "bias,temperature", "--axes", "y",
                 "--noise", "white", "--out", str(out), "--no-progress"])
    said = capsys.readouterr().err
    return code, said, json.loads((out / "fit.json").read_text())


def test_fit_streams_a_parquet_log_longer_than_the_threshold(tmp_path, monkeypatch, capsys):
    """The command reads a log over STREAM_ROWS as a stream and says so; its fit.json
    records the block means; errors name the file's row wherever the batch boundary is."""
    import gyroid.pipeline._fit_file as fit_file

    monkeypatch.setattr(fit_file, "STREAM_ROWS", 10_000)
    columns = _ramp(np.random.default_rng(2), n=30_000)
    path = _write(tmp_path / "long.parquet", columns)
    code, said, record = _fit_axis_y(path, tmp_path / "fit", capsys)
    assert "as a stream, as means of 30 samples" in said
    assert record["block_means"] == {"means": 999, "rows_per_mean": 30, "rows": 30_000}
    assert code in (0, 3) and math.isfinite(record["posterior"]["w1"]["mean"])

    bad = dict(columns)
    bad["temperature_C"] = bad["temperature_C"].copy()
    bad["temperature_C"][23_456] = np.nan
    _write(tmp_path / "bad.parquet", bad)
    assert main(["fit", str(tmp_path / "bad.parquet"), "--terms", "bias,temperature",
                 "--axes", "y", "--out", str(tmp_path / "no")]) == 2
    assert "row 23457 of bad.parquet" in capsys.readouterr().err
    unsorted = dict(columns)
    unsorted["time_s"] = unsorted["time_s"].copy()
    unsorted["time_s"][5_000] = 0.0  # the first row of the second row group
    with pytest.raises(GyroidInputError, match="row 5001 of unsorted.parquet"):
        stream_block_means(_write(tmp_path / "unsorted.parquet", unsorted), "bias",
                           ("x",), (), 30, batch_rows=5_000)
    assert not (tmp_path / "no").exists()


def test_a_streamed_simulation_does_not_depend_on_its_chunks(tmp_path):
    """One random stream per noise source and the Gauss-Markov filter's state carried over:
    the log written in chunks of 97 rows is the log written in one (bit for bit)."""
    from gyroid.simulation import ThermalProtocol
    from gyroid.simulation._noise import GyroNoise
    from gyroid.simulation._stream import stream_thermal_bench

    protocol = ThermalProtocol().stretched(hours=0.5)
    noise = GyroNoise(bias_instability_deg_h=0.05, correlation_time_s=60.0)
    whole = stream_thermal_bench(tmp_path / "whole.parquet", protocol=protocol, noise=noise,
                                 seed=3, chunk_rows=10**6)
    chunked = stream_thermal_bench(tmp_path / "chunked.csv", protocol=protocol, noise=noise,
                                   seed=3, chunk_rows=97)
    a = pq.read_table(whole.path)
    b = load_bench_log(chunked.path)
    assert a.num_rows == b.n == whole.n_rows == 1800
    for name in a.column_names:
        np.testing.assert_array_equal(a[name].to_numpy(), np.asarray(b.columns[name]))
    assert chunked.truth == whole.truth


@pytest.mark.slow
def test_simulate_streams_a_long_thermal_log_that_fits_back_to_its_truth(tmp_path,
                                                                        monkeypatch):
    """Over STREAM_ROWS rows `gyroid simulate` writes the log chunk by chunk (as Parquet
    here), and `gyroid fit` streams it back: the truth within 4 posterior sds. Effects
    that need the whole history, and --average, are refused with one message."""
    import gyroid.io._stream as stream
    import gyroid.pipeline._fit_file as fit_file
    import gyroid.simulation._stream as simulated

    monkeypatch.setattr(stream, "STREAM_ROWS", 20_000)
    monkeypatch.setattr(fit_file, "STREAM_ROWS", 20_000)
    monkeypatch.setattr(simulated, "CHUNK_ROWS", 7_000)
    out = tmp_path / "sim"
    assert main(["simulate", "thermal", "--out", str(out), "--rate-hz", "1.5",
                 "--format", "parquet", "--seed", "4"]) == 0
    truth = json.loads((out / "truth.json").read_text())["parameters"]
    assert pq.read_metadata(out / "bench.parquet").num_rows == 55_800
    assert (out / "bench.png").exists() and not (out / "bench.csv").exists()
    fit = tmp_path / "fit"
    code = main(["fit", str(out / "bench.parquet"), "--terms", "thermal", "--noise", "white",
                 "--out", str(fit), "--no-progress"])
    record = json.loads((fit / "fit.json").read_text())
    assert code == 0 and record["block_means"]["rows"] == 55_800
    for name, value in truth.items():
        posterior = record["posterior"][name]
        assert abs(posterior["mean"] - value) < 4.0 * posterior["sd"], name

    lagged = main(["simulate", "thermal", "--out", str(tmp_path / "lag"), "--rate-hz", "1.5",
                   "--effect", "thermal_lag:tau_lag_min=5"])
    averaged = main(["simulate", "thermal", "--out", str(tmp_path / "avg"), "--rate-hz", "1.5",
                     "--average", "60"])
    assert lagged == averaged == 2
    assert not (tmp_path / "lag").exists() and not (tmp_path / "avg").exists()


@pytest.mark.parametrize("name", ["long.csv", "long.csv.gz"])
def test_a_csv_log_streams_as_the_parquet_one_does(tmp_path, name):
    """The same log as CSV (plain or gzip) streams in batches of lines to the means and
    samples of the whole CSV log, its rows named by their file line."""
    from gyroid.io import write_bench_log

    columns = _ramp(np.random.default_rng(0))
    path = write_bench_log(tmp_path / name, columns, ["a ramp, two axes"])
    streamed = stream_block_means(path, "bias,temperature", ("x", "y"), (), 60,
                                  batch_rows=7_777)
    for axis in ("x", "y"):
        whole = MeansOfBlocks.of(load_bench_log(path, "bias,temperature", axis=axis), 60)
        got = streamed[axis]
        assert got.log.n == whole.log.n
        for column, values in whole.log.columns.items():
            np.testing.assert_allclose(got.log.columns[column], values, rtol=1e-13,
                                       atol=1e-12)
        for k in (0, 400, got.log.n - 1):
            assert got.log.where(k) == whole.log.where(k)
        assert got.samples.n == whole.samples.n == 60_000
        assert got.samples.z_sum_sq == pytest.approx(whole.samples.z_sum_sq, rel=1e-9)
    assert "(line 4 of" in streamed["x"].log.where(0)  # two comment lines, the header


@pytest.mark.slow
def test_fit_streams_a_long_csv_log_and_names_its_bad_lines(tmp_path, monkeypatch, capsys):
    """Over STREAM_ROWS (estimated from the file's size) a CSV log is fitted as a stream;
    a bad cell is named by its line; comment lines among the rows are refused, with what
    to do."""
    import gyroid.pipeline._fit_file as fit_file
    from gyroid.io import write_bench_log

    monkeypatch.setattr(fit_file, "STREAM_ROWS", 10_000)
    columns = _ramp(np.random.default_rng(2), n=30_000)
    path = write_bench_log(tmp_path / "long.csv", columns)
    code, said, record = _fit_axis_y(path, tmp_path / "fit", capsys)
    assert "as a stream" in said and "at most about" in said
    assert record["block_means"]["rows"] == 30_000 and record["block_means"]["means"] <= 1000
    assert code in (0, 3) and math.isfinite(record["posterior"]["w1"]["mean"])

    text = path.read_text().splitlines()
    bad = list(text)
    row = 23_456  # data row 23 457 is on line 23 457 + 2 (the units line, the header)
    bad[row + 2] = bad[row + 2].replace(bad[row + 2].split(",")[2], "nan", 1)
    (tmp_path / "bad.csv").write_text("\n".join(bad) + "\n")
    assert main(["fit", str(tmp_path / "bad.csv"), "--terms", "bias,temperature",
                 "--axes", "y", "--out", str(tmp_path / "no")]) == 2
    assert "row 23457 (line 23459 of bad.csv)" in capsys.readouterr().err
    inner = text[:20_000] + ["# the bench was opened here"] + text[20_000:]
    (tmp_path / "inner.csv").write_text("\n".join(inner) + "\n")
    assert main(["fit", str(tmp_path / "inner.csv"), "--terms", "bias,temperature",
                 "--axes", "y", "--out", str(tmp_path / "no")]) == 2
    assert "comment lines sit among its rows" in capsys.readouterr().err
    assert main(["fit", str(path), "--terms", "bias,temperature", "--instance", "1",
                 "--out", str(tmp_path / "no")]) == 2
    assert "--instance is for flight-controller" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_a_csv_column_of_whole_numbers_at_first_takes_decimals_later(tmp_path):
    """The streaming reader takes its column types from the first block: whole numbers
    there (a thermometer reading 21 degC) are read as floats, so that 21.5 later is too."""
    from gyroid.io import write_bench_log

    columns = _ramp(np.random.default_rng(3), n=30_000)
    columns["temperature_C"] = columns["temperature_C"].copy()
    columns["temperature_C"][:5_000] = np.round(columns["temperature_C"][:5_000])
    path = tmp_path / "whole_first.csv"
    text = write_bench_log(path, columns).read_text()
    path.write_text(text.replace(".0,", ",").replace(".0\n", "\n"))  # "21" rather than "21.0"
    streamed = stream_block_means(path, "bias,temperature", ("x",), (), 30, batch_rows=1_000)
    whole = MeansOfBlocks.of(load_bench_log(path, "bias,temperature", axis="x"), 30)
    np.testing.assert_allclose(streamed["x"].log.columns["temperature_C"],
                               whole.log.columns["temperature_C"], rtol=1e-13)
