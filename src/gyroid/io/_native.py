"""Flight-controller, robot and MATLAB logs read with their ecosystems' own libraries, each
picking the gyro and temperature streams of one IMU (``instance``; the first by default)
and naming what it picked (docs/formats.md section 5):

* PX4 ULog (``.ulg``, pyulog): topic ``sensor_gyro`` (x, y, z in rad/s, its temperature
  in degC on the same samples, ``timestamp_sample`` or ``timestamp`` in us), one
  ``multi_id`` per IMU; the same instance's ``sensor_accel`` (m/s^2) put on the gyro's clock;
* ArduPilot DataFlash (``.bin``, pymavlink): ``IMU`` messages (GyrX, GyrY, GyrZ in rad/s,
  AccX, AccY, AccZ in m/s^2, ``T`` in degC, ``TimeUS``), the IMU by the field ``I`` (or the
  older IMU2, IMU3 names);
* ROS 1 bags (``.bag``), ROS 2 bag folders and ``.mcap`` files (rosbags, no ROS install):
  ``sensor_msgs/Imu`` (``angular_velocity`` in rad/s, ``linear_acceleration`` in m/s^2,
  ``header.stamp``), one topic per IMU in name order, and a ``sensor_msgs/Temperature``
  topic interpolated to the gyro's clock;
* MATLAB ``.mat`` (h5py for v7.3, SciPy for older): every numeric vector a column, a
  matrix's columns ``NAME_1``, ``NAME_2``, ... (MATLAB's order); the units are not in the
  file, so ``--map`` names them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, cast

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._imu_table import ImuStreams, imu_table
from gyroid.io._log_table import LogTable

#: File suffixes read here (a ROS 2 bag folder is recognised by its metadata.yaml).
NATIVE_SUFFIXES = (".ulg", ".bin", ".bag", ".mcap", ".db3", ".mat")


def is_native(path: Path) -> bool:
    return path.suffix.lower() in NATIVE_SUFFIXES or (path / "metadata.yaml").is_file()


def read_native(path: Path, instance: int | None = None) -> LogTable:
    """The log table of a native log (see the module docstring)."""
    if not path.exists():
        raise GyroidInputError(f"{path}: no such file or folder; check the path")
    suffix = path.suffix.lower()
    if suffix == ".mat":
        if instance is not None:
            raise GyroidInputError("--instance is for flight-controller and ROS logs; a .mat "
                                   "file's columns are chosen with --map")
        return _read_mat(path)
    if suffix == ".ulg":
        streams = _ulog_streams(path, instance or 0)
    elif suffix == ".bin":
        streams = _dataflash_streams(path, instance or 0)
    else:
        streams = _ros_streams(path, instance or 0)
    return imu_table(path, streams)


def _choose(available: list, instance: int, what: str, path: Path):
    if not available:
        raise GyroidInputError(f"{path.name}: no {what} in the log; is it an IMU log?")
    if not 0 <= instance < len(available):
        raise GyroidInputError(f"{path.name}: --instance {instance}: the log has "
                               f"{len(available)} {what} (0 to {len(available) - 1})")
    return available[instance]


def _ulog_streams(path: Path, instance: int) -> ImuStreams:
    from pyulog import ULog

    try:
        ulog = ULog(str(path), ["sensor_gyro", "sensor_accel"])
    except Exception as error:  # noqa: BLE001 - pyulog raises many kinds on a bad file
        raise GyroidInputError(f"{path.name}: not a readable ULog file ({error})") from None
    gyros = sorted((d for d in ulog.data_list if d.name == "sensor_gyro"),
                   key=lambda d: d.multi_id)
    data = _choose(gyros, instance, "sensor_gyro topics", path)
    fields = data.data
    clock = "timestamp_sample" if "timestamp_sample" in fields else "timestamp"
    time_s = np.asarray(fields[clock], dtype=float) * 1e-6
    temperature = fields.get("temperature")
    picked = {"format": "PX4 ULog", "stream": "sensor_gyro", "instance": data.multi_id,
              "instances": len(gyros), "clock": clock,
              "device_id": int(np.median(fields["device_id"])) if "device_id" in fields
              else None}
    accels = {d.multi_id: d for d in ulog.data_list if d.name == "sensor_accel"}
    accel = accels.get(data.multi_id)
    accel_time = accel_values = None
    if accel is not None and all(a in accel.data for a in "xyz"):
        own = accel.data
        accel_clock = "timestamp_sample" if "timestamp_sample" in own else "timestamp"
        accel_time = np.asarray(own[accel_clock], dtype=float) * 1e-6
        accel_values = np.column_stack([own[a] for a in "xyz"])
        picked["accelerometer_stream"] = "sensor_accel"
    return ImuStreams(time_s, np.column_stack([fields[a] for a in "xyz"]),
                      None if temperature is None else time_s, temperature, picked,
                      accel=accel_values, accel_time_s=accel_time)


def _dataflash_streams(path: Path, instance: int) -> ImuStreams:
    from pymavlink import DFReader

    try:
        reader = DFReader.DFReader_binary(str(path), zero_time_base=False)
    except Exception as error:  # noqa: BLE001 - pymavlink raises many kinds on a bad file
        raise GyroidInputError(f"{path.name}: not a readable DataFlash log ({error})") from None
    rows: dict[int, list] = {}
    names = ["IMU", "IMU2", "IMU3"]
    while True:
        message = reader.recv_match(type=names)
        if message is None:
            break
        kind = message.get_type()
        which = int(getattr(message, "I", 0)) if kind == "IMU" else names.index(kind)
        rows.setdefault(which, []).append(
            (message.TimeUS, message.GyrX, message.GyrY, message.GyrZ,
             getattr(message, "T", np.nan), getattr(message, "AccX", np.nan),
             getattr(message, "AccY", np.nan), getattr(message, "AccZ", np.nan)))
    ids = sorted(rows)
    chosen = _choose(ids, instance, "IMU instances", path)
    values = np.asarray(rows[chosen], dtype=float)
    time_s = values[:, 0] * 1e-6
    picked = {"format": "ArduPilot DataFlash", "stream": "IMU", "instance": chosen,
              "instances": len(ids), "clock": "TimeUS"}
    accel = values[:, 5:8] if np.isfinite(values[:, 5:8]).all() else None
    return ImuStreams(time_s, values[:, 1:4], time_s, values[:, 4], picked, accel=accel)


class _Stamp(Protocol):
    sec: int
    nanosec: int


class _Header(Protocol):
    stamp: _Stamp


class _Vector(Protocol):
    x: float
    y: float
    z: float


class _ImuMessage(Protocol):
    """The fields of ``sensor_msgs/Imu`` read here (rosbags deserialises to ``object``)."""

    header: _Header
    angular_velocity: _Vector
    linear_acceleration: _Vector
    linear_acceleration_covariance: Sequence[float]


class _TemperatureMessage(Protocol):
    """The fields of ``sensor_msgs/Temperature`` read here."""

    header: _Header
    temperature: float


def _ros_streams(path: Path, instance: int) -> ImuStreams:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    try:
        with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            imus = sorted((c for c in reader.connections
                           if c.msgtype == "sensor_msgs/msg/Imu"), key=lambda c: c.topic)
            imu = _choose(imus, instance, "sensor_msgs/Imu topics", path)
            temps = sorted((c for c in reader.connections
                            if c.msgtype == "sensor_msgs/msg/Temperature"),
                           key=lambda c: c.topic)
            gyro, accel, time_s, no_accel = [], [], [], False
            for connection, _, raw in reader.messages(connections=[imu]):
                msg = cast(_ImuMessage, reader.deserialize(raw, connection.msgtype))
                time_s.append(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)
                w, a = msg.angular_velocity, msg.linear_acceleration
                gyro.append((w.x, w.y, w.z))
                accel.append((a.x, a.y, a.z))
                # REP 145: a covariance's first element -1 means "not provided"
                no_accel = no_accel or msg.linear_acceleration_covariance[0] == -1
            t_temp, temperature = [], []
            if temps:
                for connection, _, raw in reader.messages(connections=[temps[0]]):
                    reading = cast(_TemperatureMessage,
                                   reader.deserialize(raw, connection.msgtype))
                    t_temp.append(reading.header.stamp.sec + 1e-9 * reading.header.stamp.nanosec)
                    temperature.append(reading.temperature)
    except GyroidInputError:
        raise
    except Exception as error:  # noqa: BLE001 - rosbags raises many kinds on a bad bag
        raise GyroidInputError(f"{path.name}: not a readable ROS bag ({error})") from None
    picked = {"format": "ROS bag", "stream": imu.topic, "instance": instance,
              "instances": len(imus), "clock": "header.stamp",
              "temperature": temps[0].topic if temps else None}
    accel_values = np.asarray(accel, dtype=float).reshape(-1, 3)
    # a driver without an accelerometer leaves linear_acceleration all zeros
    logged = bool(np.any(accel_values != 0.0)) and not no_accel
    return ImuStreams(np.asarray(time_s), np.asarray(gyro, dtype=float).reshape(-1, 3),
                      np.asarray(t_temp) if temps else None,
                      np.asarray(temperature) if temps else None, picked,
                      accel=accel_values if logged else None)


def _read_mat(path: Path) -> LogTable:
    """Every numeric vector of a .mat file as a column, a matrix's columns as ``NAME_k``
    (1-based, along its long dimension's rows); all must have one length."""
    variables = _mat_variables(path)
    columns: dict[str, np.ndarray] = {}
    for name, value in variables.items():
        value = np.squeeze(np.asarray(value))
        if value.dtype.kind not in "fiub" or value.ndim == 0:
            continue
        if value.ndim == 1:
            columns[name] = value.astype(float)
        elif value.ndim == 2:
            long_axis = int(np.argmax(value.shape))
            matrix = value if long_axis == 0 else value.T
            for k in range(matrix.shape[1]):
                columns[f"{name}_{k + 1}"] = matrix[:, k].astype(float)
    if not columns:
        raise GyroidInputError(f"{path.name}: no numeric vectors or matrices in the file")
    lengths = {c.size for c in columns.values()}
    if len(lengths) > 1:
        longest = max(lengths)
        dropped = sorted(n for n, c in columns.items() if c.size != longest)
        columns = {n: c for n, c in columns.items() if c.size == longest}
    else:
        dropped = []
    picked = {"format": "MATLAB .mat", "variables": sorted(variables),
              "columns_of_another_length_left_out": dropped}
    n = next(iter(columns.values())).size
    return LogTable(path, tuple(columns), columns, n, None, None, picked=picked)


def _mat_variables(path: Path) -> dict[str, np.ndarray]:
    import h5py

    if h5py.is_hdf5(str(path)):  # MATLAB v7.3: HDF5 stores the transpose
        with h5py.File(path, "r") as handle:
            return {name: np.asarray(item).T for name, item in handle.items()
                    if isinstance(item, h5py.Dataset) and not name.startswith("#")}
    from scipy.io import loadmat

    try:
        return {k: v for k, v in loadmat(str(path)).items() if not k.startswith("__")}
    except Exception as error:  # noqa: BLE001 - SciPy raises many kinds on a bad file
        raise GyroidInputError(f"{path.name}: not a readable MATLAB file ({error})") from None
