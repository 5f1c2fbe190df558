"""Shared problems for the tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gyroid.io import bench_log_text
from gyroid.simulation import GyroNoise, MagneticProtocol, ThermalProtocol

QUIET = GyroNoise(arw_deg_rt_h=0.0, temperature_noise_C=0.0, field_noise_uT=0.0)
#: A short thermal schedule (3 setpoints, 10 s samples) for fast tests.
SHORT_THERMAL = ThermalProtocol(
    setpoints_C=(31.0, 40.0, 55.0),
    initial_min=20.0,
    transition_min=60.0,
    soak_min=30.0,
    sample_s=10.0,
)
SHORT_MAGNETIC = MagneticProtocol(dwell_s=60.0, sample_s=5.0, turn_gap_s=100.0)
#: Tests of the pipeline fit white noise: the default (IEEE 952 noise) is tested on its own
#: (tests/test_ieee_noise.py, the README tour) and costs up to a minute per fit.
WHITE = ("--noise", "white")


def require_dataset(name: str) -> Path:
    """The folder gyroid's dataset registry (:mod:`gyroid.io._datasets`) reads a public real
    log's files from, or a skip that names the log and how to get it: the project ships
    none, and a test fetches none (a clone may have no network, and a test writes only in
    its temporary folder)."""
    import pytest

    from gyroid.io import data_home, missing

    absent = missing(name)
    if absent:
        pytest.skip(f"real log {name!r}: {len(absent)} file(s) not in {data_home()} (such as "
                    f"{absent[0]}); `gyroid datasets {name} --out DIR` fetches them there, or "
                    "set GYROID_DATA to a folder that has them")
    return data_home()


def random_blocks(rng: np.random.Generator, n: int, *, span_s: tuple[float, float],
                  longest_gap_s: float) -> tuple[np.ndarray, ...]:
    """``n`` blocks of spans drawn from ``span_s`` (s), a fifth of them after a pause of up
    to ``longest_gap_s``: spans, gaps, starts and ends (s), the first block at 0."""
    span = rng.uniform(*span_s, n)
    gap = np.where(rng.random(n) < 0.2, rng.uniform(0.0, longest_gap_s, n), 0.0)
    gap[0] = 0.0
    start = np.cumsum(np.concatenate([[0.0], span[:-1]]) + gap)
    return span, gap, start, start + span


def write_log(path: Path, columns: dict[str, np.ndarray]) -> Path:
    path.write_text(bench_log_text(columns))
    return path


# ----- stress logs: other gyro grades and shapes than paper A's bench ------------------------


def mems_burst_log(seed: int, *, hours: float = 3.0, wander_deg_h: float = 0.0
                   ) -> tuple[dict[str, np.ndarray], dict]:
    """A consumer MEMS gyro in a thermal-vacuum test: bias of -1500 deg/h, 30 deg/h/degC,
    the temperature falling steadily from 40 to 0 degC, 5 s bursts at 50 Hz every 5 min,
    white noise of 200 deg/h (like the real log in issue 13); ``wander_deg_h``: the sd of
    an independent bias offset per burst (the real log's wander between bursts)."""
    rng = np.random.default_rng(seed)
    starts = np.arange(0.0, hours * 3600.0, 300.0)
    time_s = (starts[:, None] + np.arange(250)[None, :] / 50.0).ravel()
    temperature = 40.0 - 40.0 * time_s / (hours * 3600.0)
    truth = {"w0": -1500.0, "w1": 30.0, "w2": 0.5}
    t = temperature - 21.0
    drift = truth["w0"] + truth["w1"] * t + truth["w2"] * t**2
    drift = drift + np.repeat(wander_deg_h * rng.standard_normal(starts.size), 250)
    columns = {"time_s": time_s, "drift_deg_h": drift + 200.0 * rng.standard_normal(time_s.size),
               "temperature_C": temperature + 0.05 * rng.standard_normal(time_s.size)}
    return columns, truth


def fast_ramp_log(seed: int, *, ramp_min: float = 15.0, hours: float = 8.0
                  ) -> tuple[dict[str, np.ndarray], dict]:
    """A FOG on 15-minute ramps of 10 degC between holds of the same length, 1 Hz, white
    noise of 0.05 deg/h given as sigma_deg_h (issue 13's second case)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(0.0, hours * 3600.0)
    period = 4 * ramp_min * 60.0
    phase = (time_s % period) / (ramp_min * 60.0)  # 0-1 up, 1-2 hold, 2-3 down, 3-4 hold
    shape = np.clip(phase, 0, 1) - np.clip(phase - 2.0, 0, 1)
    temperature = 25.0 + 10.0 * shape
    rate = np.where(phase < 1, 1.0, np.where((phase >= 2) & (phase < 3), -1.0, 0.0))
    rate_C_h = rate * 10.0 / (ramp_min / 60.0)
    truth = {"w0": 1.2, "w1": -0.1, "w2": 0.004, "wD": 2.0}
    t = temperature - 21.0
    drift = truth["w0"] + truth["w1"] * t + truth["w2"] * t**2 + truth["wD"] * rate_C_h
    columns = {"time_s": time_s, "drift_deg_h": drift + 0.05 * rng.standard_normal(time_s.size),
               "temperature_C": temperature + 0.01 * rng.standard_normal(time_s.size),
               "sigma_deg_h": np.full(time_s.size, 0.05)}
    return columns, truth


def weak_field_log(seed: int, *, hours: float = 4.0) -> tuple[dict[str, np.ndarray], dict]:
    """Magnetic terms on a log whose field hardly varies (+/-2 uT, slowly), with correlated
    (Gauss-Markov, 0.3 deg/h, 1800 s) and white noise (issue 13's fourth case)."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(0.0, hours * 3600.0, 2.0)
    phi = np.exp(-2.0 / 1800.0)
    gm = np.empty(time_s.size)
    gm[0] = 0.3 * rng.standard_normal()
    shocks = 0.3 * np.sqrt(1 - phi**2) * rng.standard_normal(time_s.size)
    for i in range(1, time_s.size):
        gm[i] = phi * gm[i - 1] + shocks[i]
    span = hours * 3600.0
    field = {f"H{a}_uT": 2.0 * np.sin(2 * np.pi * time_s / span * k + k)
             for k, a in enumerate("xyz", start=1)}
    drift = 1.0 + gm + 0.3 * rng.standard_normal(time_s.size)
    return {"time_s": time_s, "drift_deg_h": drift, **field}, {"w0": 1.0}


# ----- native logs written with each format's published layout or its library's writer -------
def write_ulog(path: Path, instances: list[dict[str, np.ndarray]]) -> Path:
    """A PX4 ULog of ``sensor_gyro`` instances (each: timestamp_sample in us, x, y, z in
    rad/s, temperature in degC; with ``accel_time_us`` and ``accel`` (m, 3) m/s^2 also that
    instance's ``sensor_accel`` on its own clock), written byte by byte from the published
    format: the 16-byte header, the flag bits, the formats, a subscription per instance and
    topic, data messages."""
    import struct

    def message(kind: bytes, payload: bytes) -> bytes:
        return struct.pack("<HB", len(payload), kind[0]) + payload

    fields = ("uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;"
              "float y;float z;float temperature;")
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += message(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    out += message(b"F", ("sensor_gyro:" + fields).encode())
    out += message(b"F", ("sensor_accel:" + fields).encode())
    for k in range(len(instances)):
        out += message(b"A", struct.pack("<BH", k, k) + b"sensor_gyro")
    with_accel = [k for k, inst in enumerate(instances) if "accel_time_us" in inst]
    for j, k in enumerate(with_accel):  # msg ids after the gyros', multi_id the IMU's
        out += message(b"A", struct.pack("<BH", k, len(instances) + j) + b"sensor_accel")
    rows = sorted([(int(t), 0, k, i) for k, inst in enumerate(instances)
                   for i, t in enumerate(inst["timestamp_sample"])]
                  + [(int(t), 1, k, i) for k in with_accel
                     for i, t in enumerate(instances[k]["accel_time_us"])])
    for t, kind, k, i in rows:
        inst = instances[k]
        if kind == 0:
            out += message(b"D", struct.pack("<HQQIffff", k, t, t, 1000 + k, inst["x"][i],
                                             inst["y"][i], inst["z"][i],
                                             inst["temperature"][i]))
        else:
            a = inst["accel"][i]
            out += message(b"D", struct.pack("<HQQIffff", len(instances) + with_accel.index(k),
                                             t, t, 1000 + k, a[0], a[1], a[2],
                                             inst["temperature"][0]))
    path.write_bytes(bytes(out))
    return path


def write_dataflash(path: Path, instances: list[dict[str, np.ndarray]]) -> Path:
    """An ArduPilot DataFlash log of IMU messages (TimeUS, I, GyrX..Z in rad/s, AccX..Z in
    m/s^2 from ``accel`` (n, 3) or 0, 0, -9.80665, T in degC), each message packed by
    pymavlink's own DFFormat and message builder."""
    from pymavlink import DFReader

    fmt_fmt = DFReader.DFFormat(0x80, "FMT", 89, "BBnNZ", "Type,Length,Name,Format,Columns")
    imu = DFReader.DFFormat(0x40, "IMU", 0, "QBfffffff",
                            "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,T")

    class Writer:  # what make_format_msgbuf and make_msgbuf read from a reader
        formats = {0x80: fmt_fmt}

    writer = Writer()
    out = bytearray(DFReader.DFReader_binary.make_format_msgbuf(writer, fmt_fmt))
    out += DFReader.DFReader_binary.make_format_msgbuf(writer, imu)
    rows = sorted((int(t), k, i) for k, inst in enumerate(instances)
                  for i, t in enumerate(inst["timestamp_sample"]))
    for t, k, i in rows:
        inst = instances[k]
        a = inst["accel"][i] if "accel" in inst else (0.0, 0.0, -9.80665)
        out += DFReader.DFReader_binary.make_msgbuf(writer, imu, [
            t, k, inst["x"][i], inst["y"][i], inst["z"][i], *a, inst["temperature"][i]])
    path.write_bytes(bytes(out))
    return path


def write_rosbag(path: Path, imu: dict[str, np.ndarray], *, ros1: bool = False,
                 temperature_every: int = 10, with_accel: bool = True) -> Path:
    """A ROS 2 bag (MCAP storage when ``path`` ends .mcap... a folder otherwise) or a ROS 1
    bag of ``sensor_msgs/Imu`` on /imu and ``sensor_msgs/Temperature`` on /imu/temperature
    (every ``temperature_every``-th sample), written with rosbags' writers."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    Imu, Temperature = store.types["sensor_msgs/msg/Imu"], store.types[
        "sensor_msgs/msg/Temperature"]
    Header, Time = store.types["std_msgs/msg/Header"], store.types[
        "builtin_interfaces/msg/Time"]
    Vector3, Quaternion = store.types["geometry_msgs/msg/Vector3"], store.types[
        "geometry_msgs/msg/Quaternion"]
    zeros = np.zeros(9)
    # REP 145: -1 first marks "not provided"
    accel_covariance = zeros if with_accel else np.r_[-1.0, np.zeros(8)]

    def header(ns: int, k: int):
        stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return Header(seq=k, stamp=stamp, frame_id="imu") if ros1 else Header(
            stamp=stamp, frame_id="imu")

    messages = []
    for k, t_us in enumerate(imu["timestamp_sample"]):
        ns = int(t_us) * 1000
        messages.append(("/imu", "sensor_msgs/msg/Imu", ns, Imu(
            header=header(ns, k), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=zeros, angular_velocity=Vector3(
                x=float(imu["x"][k]), y=float(imu["y"][k]), z=float(imu["z"][k])),
            angular_velocity_covariance=zeros, linear_acceleration=Vector3(
                x=0.0, y=0.0, z=9.81), linear_acceleration_covariance=accel_covariance)))
        if k % temperature_every == 0:
            messages.append(("/imu/temperature", "sensor_msgs/msg/Temperature", ns,
                             Temperature(header=header(ns, k), temperature=float(
                                 imu["temperature"][k]), variance=0.0)))
    if ros1:
        from rosbags.rosbag1 import Writer

        with Writer(path) as writer:
            connections = {topic: writer.add_connection(topic, kind, typestore=store)
                           for topic, kind in (("/imu", "sensor_msgs/msg/Imu"), (
                               "/imu/temperature", "sensor_msgs/msg/Temperature"))}
            for topic, kind, ns, msg in messages:
                writer.write(connections[topic], ns, store.serialize_ros1(msg, kind))
        return path
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if path.suffix == ".mcap" else StoragePlugin.SQLITE3
    folder = path.with_suffix("") if path.suffix == ".mcap" else path
    with Writer(folder, version=9, storage_plugin=plugin) as writer:
        connections = {topic: writer.add_connection(topic, kind, typestore=store)
                       for topic, kind in (("/imu", "sensor_msgs/msg/Imu"), (
                           "/imu/temperature", "sensor_msgs/msg/Temperature"))}
        for topic, kind, ns, msg in messages:
            writer.write(connections[topic], ns, store.serialize_cdr(msg, kind))
    if path.suffix == ".mcap":  # the bag's one storage file, on its own
        stored = next(folder.glob("*.mcap"))
        stored.rename(path)
    return path


def check_report(report, expected):
    """A discrepancy report that added exactly ``expected``, left nothing unexplained, and
    whose every step beat the threshold and cut the RMS."""
    assert report.added == expected, [s.evidence for s in report.steps]
    assert report.unexplained is None, report.unexplained
    assert report.rms_final <= report.rms_baseline
    for step in report.steps:
        assert step.score > 10 and step.rms_after <= step.rms_before
