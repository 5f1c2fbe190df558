"""Loading bench logs: every bad input of the contract ends with one clear message."""

import numpy as np
import pytest
from helpers import SHORT_MAGNETIC, SHORT_THERMAL, write_log

from gyroid import BenchLog, BenchProblem, GyroidInputError, load_bench_log
from gyroid.bench import BenchOptions
from gyroid.io import bench_log_text
from gyroid.models._derived import RATE_WINDOW_S
from gyroid.simulation import simulate_magnetic_bench, simulate_thermal_bench


@pytest.fixture(scope="module")
def thermal_columns():
    return dict(simulate_thermal_bench(seed=1, protocol=SHORT_THERMAL).log.columns)


@pytest.fixture(scope="module")
def magnetic_columns():
    return dict(simulate_magnetic_bench(seed=1, protocol=SHORT_MAGNETIC).log.columns)


def _text_with(tmp_path, columns, edit):
    lines = bench_log_text(columns).splitlines()
    lines = edit(lines)
    path = tmp_path / "bench.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def _set_cell(lines, row, column, value):
    header_index = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header_index].split(",")
    cells = lines[header_index + row].split(",")
    cells[names.index(column)] = value
    lines[header_index + row] = ",".join(cells)
    return lines


def test_a_clean_log_round_trips(tmp_path, thermal_columns):
    path = write_log(tmp_path / "bench.csv", thermal_columns)
    log = load_bench_log(path, "thermal")
    assert log.n == thermal_columns["time_s"].size
    np.testing.assert_allclose(log.drift_deg_h, thermal_columns["drift_deg_h"], rtol=1e-9)


def test_comments_and_extra_columns_are_allowed(tmp_path, thermal_columns):
    columns = dict(thermal_columns)
    columns["operator_note"] = np.zeros(columns["time_s"].size)
    text = "# free metadata, any text\n" + bench_log_text(columns)
    path = tmp_path / "bench.csv"
    path.write_text(text.replace("operator_note\n", "operator_note\n", 1))
    assert load_bench_log(path, "thermal").n == columns["time_s"].size


@pytest.mark.parametrize(
    ("row", "column", "value", "expected"),
    [
        (
            3,
            "drift_deg_h",
            "abc",
            r"row 3 \(line \d+ of bench.csv\), column drift_deg_h: the "
            r"value is 'abc', not a number",
        ),
        (5, "temperature_C", "", r"row 5 .*column temperature_C: the value is empty"),
        (7, "drift_deg_h", "nan", r"row 7 .*column drift_deg_h: the value is nan"),
        (2, "temperature_C", "inf", r"row 2 .*column temperature_C: the value is inf"),
        (4, "time_s", "0", r"time_s does not increase at row 4"),
    ],
)
def test_bad_cells_are_named(tmp_path, thermal_columns, row, column, value, expected):
    path = _text_with(tmp_path, thermal_columns, lambda ls: _set_cell(ls, row, column, value))
    with pytest.raises(GyroidInputError, match=expected):
        load_bench_log(path, "thermal")


def test_unused_bad_columns_do_not_matter(tmp_path, thermal_columns):
    path = _text_with(tmp_path, thermal_columns, lambda ls: _set_cell(ls, 3, "Hx_uT", "n/a"))
    assert load_bench_log(path, "thermal").n > 0
    with pytest.raises(GyroidInputError, match="column Hx_uT"):
        load_bench_log(path, "full")


def test_repeated_time_is_refused(tmp_path, thermal_columns):
    columns = dict(thermal_columns)
    columns["time_s"] = columns["time_s"].copy()
    columns["time_s"][10] = columns["time_s"][9]
    with pytest.raises(GyroidInputError, match=r"time_s does not increase at row 11 .* follows"):
        load_bench_log(write_log(tmp_path / "b.csv", columns), "thermal")


def test_missing_columns_are_named(tmp_path, thermal_columns):
    columns = {k: v for k, v in thermal_columns.items() if k != "temperature_C"}
    path = write_log(tmp_path / "bench.csv", columns)
    with pytest.raises(GyroidInputError, match="column 'temperature_C' is missing"):
        load_bench_log(path, "thermal")
    assert load_bench_log(path, "bias").n > 0
    no_drift = {k: v for k, v in thermal_columns.items() if k != "drift_deg_h"}
    with pytest.raises(GyroidInputError, match="column 'drift_deg_h' is missing"):
        load_bench_log(write_log(tmp_path / "b2.csv", no_drift), "bias")


@pytest.mark.parametrize(("drop", "terms", "units"), [
    ("drift_deg_h", "bias", ("deg/h", "mdps", "rad/s", "mrad/s", "rad/h")),
    ("time_s", "bias", ("ms", "ns", "min", "datetime")),
    ("temperature_C", "thermal", ("degC", "K", "degF")),
])
def test_a_missing_column_message_lists_every_unit_map_reads(tmp_path, thermal_columns, drop,
                                                             terms, units):
    """Issue 43: the messages had left out mrad/s and datetime, both accepted."""
    columns = {k: v for k, v in thermal_columns.items() if k != drop}
    with pytest.raises(GyroidInputError) as error:
        load_bench_log(write_log(tmp_path / "b.csv", columns), terms)
    assert all(f"{unit}," in str(error.value) or f"{unit})" in str(error.value)
               for unit in units), str(error.value)


def test_constant_columns_that_leave_a_coefficient_unidentifiable(
    tmp_path, thermal_columns, magnetic_columns
):
    # The thermal bench's field is the lab's: constant apart from noise -> it is fine for
    # 'bias' but the coils never moved it, so a magnetic term is refused when it is exact.
    columns = dict(magnetic_columns)
    columns["Hy_uT"] = np.zeros_like(columns["Hy_uT"])
    path = write_log(tmp_path / "bench.csv", columns)
    with pytest.raises(GyroidInputError, match="column Hy_uT does not vary enough to identify wy"):
        BenchProblem.from_log(load_bench_log(path, "magnetic"), "magnetic",
                              BenchOptions(noise="white"))
    columns = dict(thermal_columns)
    columns["temperature_C"] = np.full_like(columns["temperature_C"], 25.0)
    path = write_log(tmp_path / "bench2.csv", columns)
    with pytest.raises(GyroidInputError, match="column temperature_C does not vary enough"):
        BenchProblem.from_log(load_bench_log(path, "thermal"), "thermal",
                              BenchOptions(noise="white", rate_window_s=RATE_WINDOW_S))


def test_collinear_terms_are_refused(tmp_path, thermal_columns):
    columns = dict(thermal_columns)
    columns["Hx_uT"] = (columns["temperature_C"] - 21.0) * 3.0
    path = write_log(tmp_path / "bench.csv", columns)
    with pytest.raises(GyroidInputError, match=r"cannot be told apart .*temperature"):
        BenchProblem.from_log(load_bench_log(path), "bias,temperature,magnetic_x",
                              BenchOptions(noise="white"))


def test_kelvin_temperatures_are_refused(tmp_path, thermal_columns):
    columns = dict(thermal_columns)
    columns["temperature_C"] = columns["temperature_C"] + 273.15
    path = write_log(tmp_path / "bench.csv", columns)
    with pytest.raises(GyroidInputError, match="looks like kelvin"):
        load_bench_log(path, "thermal")


def test_bad_sigma_is_refused(tmp_path, thermal_columns):
    columns = dict(thermal_columns)
    columns["sigma_deg_h"] = np.full(columns["time_s"].size, 0.3)
    columns["sigma_deg_h"][6] = -0.1
    path = write_log(tmp_path / "bench.csv", columns)
    with pytest.raises(GyroidInputError, match=r"row 7 .*sigma_deg_h: -0.1 is not a positive"):
        load_bench_log(path, "thermal")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "no header row"),
        ("# only a comment\n", "no header row"),
        ("time_s,drift_deg_h\n", "no data rows"),
        ("time_s,drift_deg_h\n1,2\n2,3,4\n", r"row 2 \(line 3\) has 3 fields"),
        ("time_s,time_s,drift_deg_h\n1,2,3\n", "names column 'time_s' twice"),
        ("time_s,drift_deg_h\n1,0.5\n", "1 rows cannot identify 1 coefficients"),
    ],
)
def test_malformed_files(tmp_path, text, expected):
    path = tmp_path / "bench.csv"
    path.write_text(text)
    with pytest.raises(GyroidInputError, match=expected):
        load_bench_log(path, "bias")


def test_missing_file(tmp_path):
    with pytest.raises(GyroidInputError, match="no such file"):
        load_bench_log(tmp_path / "absent.csv", "bias")


def test_the_header_alone_is_read_the_same_as_by_the_full_reader(tmp_path):
    # gyroid discrepancy decides bench or roll from the header without parsing the log.
    import numpy as np

    from gyroid.io import log_kind, read_header, read_log_table, write_bench_log

    columns = {"time_s": np.arange(5.0), "drift_deg_h": np.ones(5), "temperature_C": np.ones(5)}
    paths = [write_bench_log(tmp_path / name, columns, ["a comment"])
             for name in ("a.csv", "b.csv.gz", "c.parquet")]
    semicolon = tmp_path / "d.csv"
    semicolon.write_text("# vendor\ntime_s;drift_deg_h\n0;1,5\n1;2,5\n")
    for path in (*paths, semicolon):
        assert read_header(path) == read_log_table(path).header
        assert log_kind(path) == "bench"
    roll = tmp_path / "roll.csv"
    roll.write_text("time_s,roll_rate_deg_s,gs_angle_deg\n0,1,0\n")
    assert log_kind(roll) == "roll"


def test_comment_and_blank_lines_among_rows_keep_line_numbers(tmp_path, thermal_columns):
    # A logger that marks a pause with a comment line and leaves blank lines: the rows are
    # read, the comment kept, and a bad cell after them is named by its line in the file.
    def edit(lines):
        header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
        lines.insert(header + 3, "# operator: door opened")
        lines.insert(header + 5, "")
        lines.insert(header + 6, "   ")
        return lines

    path = _text_with(tmp_path, thermal_columns, edit)
    log = load_bench_log(path, "thermal")
    assert log.n == thermal_columns["time_s"].size
    np.testing.assert_allclose(log.drift_deg_h, thermal_columns["drift_deg_h"], rtol=1e-9)
    assert "operator: door opened" in log.comments
    lines = path.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    bad_line = header + 8  # 0-based index of data row 5 (after the three inserted lines)
    lines[bad_line] = lines[bad_line].replace(lines[bad_line].split(",")[1], "oops", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(GyroidInputError, match=rf"row 5 \(line {bad_line + 1} of bench.csv\)"
                       r", column drift_deg_h: the value is 'oops'"):
        load_bench_log(path, "thermal")


def test_a_row_with_missing_fields_after_a_comment_line_is_named(tmp_path):
    path = tmp_path / "bench.csv"
    path.write_text("time_s,drift_deg_h\n0,1\n# pause\n1,2\n2\n3,4\n")
    with pytest.raises(GyroidInputError, match=r"row 3 \(line 5\) has 1 fields but the header "
                                               r"has 2"):
        load_bench_log(path, "bias")


def test_quoted_header_names_are_read(tmp_path, thermal_columns):
    # R's write.csv and pyarrow's CSV writer quote every column name.
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from gyroid.io import read_header, read_log_table

    path = tmp_path / "quoted.csv"
    pacsv.write_csv(pa.table({k: np.asarray(v) for k, v in thermal_columns.items()}), path)
    assert path.read_text().startswith('"time_s"')
    assert read_header(path) == tuple(thermal_columns)
    # read by pyarrow (row k is line k + 2), not by the slow all-text fallback
    assert read_log_table(path).first_line == 2
    log = load_bench_log(path, "thermal")
    np.testing.assert_allclose(log.drift_deg_h, thermal_columns["drift_deg_h"], rtol=1e-12)


@pytest.mark.parametrize(
    ("content", "name", "expected"),
    [
        (b"time_s,drift_deg_h\n0,1\n1,\xff\xfe\n", "latin.csv", "not a UTF-8 text file"),
        (b"\x00\x01\x02binary", "blob.csv", "not a text file"),
        (b"\x1f\x8b\x08\x00broken", "log.csv.gz", "a damaged gzip file"),
    ],
)
def test_files_that_are_not_csv_text_are_refused(tmp_path, content, name, expected):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(GyroidInputError, match=expected):
        load_bench_log(path, "bias")


def test_a_gzip_log_is_read_like_the_plain_one(tmp_path, thermal_columns):
    from gyroid.io import write_bench_log

    plain = load_bench_log(write_bench_log(tmp_path / "a.csv", thermal_columns), "thermal")
    packed = load_bench_log(write_bench_log(tmp_path / "a.csv.gz", thermal_columns), "thermal")
    for name in plain.columns:
        np.testing.assert_array_equal(plain.columns[name], packed.columns[name])


def test_a_bench_log_object_is_written_with_its_comments(tmp_path, thermal_columns):
    """A script writes the BenchLog it holds; the arguments swapped are one clear error."""
    from gyroid.io import write_bench_log

    log = BenchLog(columns=thermal_columns, comments=("chamber 3",))
    read = load_bench_log(write_bench_log(tmp_path / "a.csv", log), "thermal")
    assert "chamber 3" in read.comments
    np.testing.assert_allclose(read.drift_deg_h, log.drift_deg_h, rtol=1e-9)
    with pytest.raises(GyroidInputError, match="the path comes first"):
        write_bench_log(log, tmp_path / "b.csv")  # type: ignore[arg-type]


def test_a_jittered_clock_is_one_stretch_and_a_real_pause_still_splits_it():
    """Host time stamps in bursts (the MPU6050 runs: a steady ~99 Hz sensor whose samples
    arrive 1 ms to 0.5 s apart) once shattered a log into hundreds of 'segments' and crashed
    the discrepancy search; a pause of seconds is still a gap."""
    from gyroid.io import contiguous_segments

    rng = np.random.default_rng(0)
    true = np.arange(60_000) / 99.0
    arrival = np.maximum.accumulate(true + rng.exponential(0.03, true.size)
                                    * (rng.random(true.size) < 0.25))
    arrival += np.arange(arrival.size) * 1e-6  # strictly increasing
    assert np.mean(np.diff(arrival) > 3 * np.median(np.diff(arrival))) > 0.05
    assert len(contiguous_segments(arrival)) == 1
    paused = np.concatenate([arrival[:30_000], arrival[30_000:] + 5.0])
    assert len(contiguous_segments(paused)) == 2
    # a regular 10 s log with the odd missing sample is one stretch; a 10 min pause is not
    regular = np.delete(np.arange(0.0, 20_000.0, 10.0), [50, 51, 700])
    assert len(contiguous_segments(regular)) == 1
    assert len(contiguous_segments(np.concatenate([regular, regular[-1] + 600 + regular]))) == 2
