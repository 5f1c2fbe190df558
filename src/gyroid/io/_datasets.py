"""gyroid's registry of public real gyro logs: where each is published (a repository at a
fixed commit), its checksum and licence, and how its files become gyroid's bench logs
(docs/formats.md section 1, one ``drift_<axis>_deg_h`` column per gyro axis).

Files are fetched with pooch into :func:`data_home` (``GYROID_DATA``, else the user's cache
folder) and checked against their SHA-256; a file already there with the right checksum is
used as it is, so ``GYROID_DATA`` can point at a folder of the published files (how the
tests run without a network). gyroid ships none of these files.
"""

from __future__ import annotations

import csv
import io
import os
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from gyroid.errors import GyroidInputError

RAD_S_TO_DEG_H = 3600.0 * 180.0 / np.pi


@dataclass(frozen=True)
class Source:
    """One published file: its path in the data folder, its URL at a fixed commit, its
    SHA-256."""

    path: str
    url: str
    sha256: str


@dataclass(frozen=True)
class Dataset:
    """A public real log (or several runs) and how to read it."""

    name: str
    description: str
    repository: str
    commit: str
    licence: str
    sources: tuple[Source, ...]
    #: The fetched files (by their ``path``) -> gyroid bench logs: {log name: (columns,
    #: comments)}.
    convert: Callable[[dict[str, Path]], dict[str, tuple[dict[str, np.ndarray], list[str]]]]
    notes: str = ""

    def provenance(self) -> list[str]:
        return [f"{self.name}: {self.description}",
                f"source: {self.repository} @ {self.commit}",
                *(f"file: {s.path} ({s.url}, sha256 {s.sha256})" for s in self.sources),
                f"licence: {self.licence}", *([self.notes] if self.notes else [])]


def data_home() -> Path:
    """Where public logs are kept: ``GYROID_DATA``, else the user's cache folder
    (``XDG_CACHE_HOME`` or ``~/.cache``)/gyroid/data."""
    if os.environ.get("GYROID_DATA"):
        return Path(os.environ["GYROID_DATA"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "gyroid" / "data"


def fetch(name: str) -> dict[str, Path]:
    """The dataset's files in :func:`data_home`, fetched and checked if not already there."""
    import pooch

    dataset = dataset_named(name)
    home, files = data_home(), {}
    for source in dataset.sources:
        target = home / source.path
        try:
            files[source.path] = Path(pooch.retrieve(
                source.url, f"sha256:{source.sha256}", fname=target.name, path=target.parent,
                progressbar=False))
        except Exception as error:  # noqa: BLE001 - no network, a changed file: say so
            raise GyroidInputError(
                f"dataset {name}: {source.path} is not in {home} and could not be fetched "
                f"from {source.url} ({type(error).__name__}: {error}); put the published file "
                "there (or point GYROID_DATA at a folder that has it)") from None
    return files


def missing(name: str) -> list[str]:
    """The dataset's files that are not yet in :func:`data_home` with their published
    checksum (none: it can be read without a network)."""
    import pooch

    home = data_home()
    return [source.path for source in dataset_named(name).sources
            if not (home / source.path).is_file()
            or pooch.file_hash(str(home / source.path)) != source.sha256]


def dataset_logs(name: str) -> dict[str, tuple[dict[str, np.ndarray], list[str]]]:
    """The dataset's logs as gyroid bench-log columns (and comments), by log name."""
    dataset = dataset_named(name)
    logs = dataset.convert(fetch(name))
    return {key: (columns, [*dataset.provenance(), *comments])
            for key, (columns, comments) in logs.items()}


def dataset_named(name: str) -> Dataset:
    if name not in DATASETS:
        raise GyroidInputError(f"no dataset named {name!r}; gyroid knows "
                               f"{', '.join(DATASETS)}")
    return DATASETS[name]


# ----- the datasets ---------------------------------------------------------------------------
def _pan(files: dict[str, Path]):
    with open(files["pan_tvac/TVCtest3_7_20.csv"], newline="") as handle:
        rows = list(csv.reader(handle))
    data = np.array([[float(x) for x in row] for row in rows[1:]])
    counts = data[:, 7].astype(np.int64).astype(np.uint16).astype(np.int16)
    columns = {"time_s": data[:, 0] / 1000.0,
               # the authors' driver read the gyro at twice its scale (psim f5f9cf7)
               **{f"drift_{a}_deg_h": 0.5 * data[:, 4 + k] * RAD_S_TO_DEG_H
                  for k, a in enumerate("xyz")},
               "temperature_C": 25.0 + counts / 256.0,
               **{f"H{a}_uT": data[:, 1 + k] * 1e6 for k, a in enumerate("xyz")}}
    return {"pan_tvac": (columns, [
        "rates: the logged rad/s halved (the authors' driver bug) in deg/h; temperature: "
        "25 + int16(raw)/256 degC (LSM6DSM datasheet); field: T in uT"])}


def _astropi(files: dict[str, Path]):
    with zipfile.ZipFile(files["astropi_sensehat/astro_pi_data_20150824_085954.zip"]) as zipped:
        text = zipped.read(zipped.namelist()[0]).decode("utf-8")
    rows = list(csv.DictReader(io.StringIO(text)))
    stamps = np.array([datetime.fromisoformat(r["time_stamp"]).timestamp() for r in rows])

    def column(key: str) -> np.ndarray:
        return np.array([float(r[key]) for r in rows])

    columns = {"time_s": stamps - stamps[0],
               **{f"drift_{a}_deg_h": column(f"gyro_{a}") * RAD_S_TO_DEG_H for a in "xyz"},
               "temperature_C": column("temp_h"),
               **{f"H{a}_uT": column(f"mag_{a}") for a in "xyz"},
               "temp_p": column("temp_p"), "temp_cpu": column("temp_cpu"),
               "pressure_mbar": column("pressure"), "humidity": column("humidity"),
               **{f"accel_{a}_g": column(f"accel_{a}") for a in "xyz"}}
    return {"astropi_sensehat": (columns, [
        f"time_s from {rows[0]['time_stamp']} (the log's time_stamp); rates rad/s in deg/h "
        "(bias tracked and removed on line by RTIMULib); temperature_C: the humidity "
        "sensor's (temp_h)"])}


#: The seven static runs of one MPU6050 in sunsided/sensor-fusion (set, folder).
_MPU_RUNS = (
    ("1", "unmoved-x-pointing-forward"), ("1", "unmoved-x-pointing-up"),
    ("1", "unmoved-z-pointing-left"), ("2", "unmoved-with-x-pointing-forward"),
    ("2", "unmoved-with-x-pointing-forward-10min"),
    ("2", "unmoved-with-z-pointing-front-and-x-up"),
    ("2", "unmoved-with-z-pointing-front-and-y-down"),
)


def _mpu6050(files: dict[str, Path]):
    import h5py

    out = {}
    for group, folder in _MPU_RUNS:
        base = f"mpu6050_sunsided/raw/set{group}_{folder}"
        with h5py.File(files[f"{base}/mpu6050_gyroscope.mat"], "r") as handle:
            gyro = np.asarray(handle["gyroBuffer"], dtype=float)  # 4 x N: t, x, y, z (deg/s)
        with h5py.File(files[f"{base}/mpu6050_temperature.mat"], "r") as handle:
            temperature = np.asarray(handle["temperatureBuffer"], dtype=float)  # t, degC
        used = int(np.flatnonzero(gyro[0] > 0)[-1]) + 1  # a buffer may end in unused rows
        gyro, temperature = gyro[:, :used], temperature[:, : min(used, temperature.shape[1])]
        temperature = temperature[:, temperature[0] > 0]
        out[f"mpu6050_set{group}_{folder}"] = (
            {"time_s": gyro[0], **{f"drift_{a}_deg_h": gyro[1 + k] * 3600.0
                                    for k, a in enumerate("xyz")},
             "temperature_C": np.interp(gyro[0], temperature[0], temperature[1])},
            [f"run set-{group}/{folder}: rates deg/s in deg/h; the die temperature "
             "interpolated to the gyro's clock"])
    return out


_PAN_REPO = "pathfinder-for-autonomous-navigation/psim"
_PAN_COMMIT = "91d70adf87fe7d8d10d36dbec424fb48896fc45c"
_ASTRO_REPO = "raspberrypilearning/astro-pi-flight-data-analysis"
_ASTRO_COMMIT = "dbf74aff3a4844a4265e87c7ff397e9321d22cbd"
_MPU_REPO = "sunsided/sensor-fusion"
_MPU_COMMIT = "f16045a9d1d4f9037a183f436fe3c098a38ad99d"
_MPU_SHA256 = {
    ("1", "unmoved-x-pointing-forward"): (
        "a435342bf516c6ef693d5694c29bfa76cd1f28918b82902214c06f1daee23cc0",
        "840e49829fb3541682d63bd6e7a15a0768dcc7dd4bf20622aa675c2f6917d2c9"),
    ("1", "unmoved-x-pointing-up"): (
        "a2e248a32a49cb835f69f6b759c5bc5994a8f5abfc18ff1ae1deb8f03ed73f92",
        "8f2d7d7c8e7342912ee6381359d1a771832951d1f52f623d91d82d91fc33ff57"),
    ("1", "unmoved-z-pointing-left"): (
        "3f0ebcee3e8ed499626bf8c6f8a2d35a644b2ae2d18f93108e84f2edbc44b070",
        "d1c2b604405bfca37370fe3d53ee138839263f3b388b2f1f2176b24d6c357c70"),
    ("2", "unmoved-with-x-pointing-forward"): (
        "687d15421377a8a26bccfb906a5093be415ab10326108d5043bd2896cc40a383",
        "2fc1b5e94512b4f95945d2338af72e277f4c4400023ceaa25930c3c300efe68c"),
    ("2", "unmoved-with-x-pointing-forward-10min"): (
        "b8681bddb2b3b9153e42d818199a507c082b433bc25d592ecfc75696a10bad7a",
        "da7b6025c8c079f97a7a469eaf4225ad232d04ac66957628faa90ee9939fdc6a"),
    ("2", "unmoved-with-z-pointing-front-and-x-up"): (
        "6a9dbfc72bf1c097c40c615349ba04f81b0174ef4648e998077f1fb164443ea1",
        "2b0c886d1f4ad9a7148d419a368fa63ab45f7ba6ac69c6a8214132cbe51d57c3"),
    ("2", "unmoved-with-z-pointing-front-and-y-down"): (
        "97ac7e7f3309a90a45203aa0f827ea3227b0b71db2c46911c6107ceb6e84c1f5",
        "646735aa75d992ef45686c9c7d478a714b30695e248f236c070bc13294dfc000"),
}


#: The SMAC group's R data package: six static runs of one ADIS16405 and an MTi-G run with
#: outliers, as R objects (read with ``rdata``).
_SMAC_REPO = "SMAC-Group/imudata"
_SMAC_COMMIT = "eec6e5b627a31a4a1c286e0d1475c6556705b2a6"
_SMAC_SHA256 = {
    "adis_16405_imu1": "1eb09074beabd7cfc15b402cb8043b5302f6e4edfd9e4ebfbf8117436f8b9fa9",
    "adis_16405_imu2": "de95fc0bcf854b3bcbda77e176841dcd4ec389d2676ba814d4f54dcdbe460fc0",
    "adis_16405_imu3": "aaf972eb6ded35bad4ad2d46c44b0bfefd6665d485aabec4a417fc14259c18af",
    "adis_16405_imu4": "6f1dd1f5d3fd565ead7ad0d45e0d89d058dc3498cde0c7984702ef89333205d4",
    "adis_16405_imu5": "4967b52057106ebf0960f81f08fc47ac1bdd96ce842a802b8ee5fceecac8d8ee",
    "adis_16405_imu6": "58d35eae5c930fba9ae2110d90c14328c4ed29c71d943f757d1b941f412b3115",
    "cont.imu1": "0c177912a952df1142d847373e3fa7030129d6b42ef1ecad56f507ba3aaf01f6",
}
#: The package's sample rate (its objects' ``freq`` attribute), Hz.
_SMAC_RATE_HZ = 100.0


def _r_matrix(path: Path) -> np.ndarray:
    """The one matrix an R data file holds (rows x columns), as floats."""
    import warnings

    import rdata

    with warnings.catch_warnings():  # the package's "imu" class has no Python constructor
        warnings.simplefilter("ignore", UserWarning)
        objects = rdata.read_rda(str(path))
    (value,) = objects.values()
    matrix = np.asarray(value, dtype=float)
    return matrix.reshape(matrix.shape[0], -1)


def _smac(files: dict[str, Path]):
    out = {}
    for name in _SMAC_SHA256:
        matrix = _r_matrix(files[f"smac_adis16405/{name}.rda"])
        time_s = np.arange(matrix.shape[0]) / _SMAC_RATE_HZ
        if name.startswith("adis"):
            out[name] = ({"time_s": time_s, **{f"drift_{a}_deg_h": matrix[:, k] * 3600.0
                                               for k, a in enumerate("xyz")}},
                         [f"{name}: ADIS16405 gyro X/Y/Z, deg/s (quantised to 0.05 deg/s) "
                          "in deg/h; the package's 100 Hz clock"])
        else:
            out["mtig_cont_imu1"] = (
                {"time_s": time_s, "drift_x_deg_h": matrix[:, 0] * RAD_S_TO_DEG_H},
                ["cont.imu1: Xsens MTi-G x gyro, rad/s in deg/h; the package's 100 Hz "
                 "clock; contaminated by outliers (the robust wavelet-variance test case)"])
    return out


def _raw(repository: str, commit: str, path: str) -> str:
    return f"https://raw.githubusercontent.com/{repository}/{commit}/{path}"


DATASETS: dict[str, Dataset] = {d.name: d for d in (
    Dataset(
        "pan_tvac",
        "PAN CubeSat engineering unit (ST LSM6DSM MEMS gyro, magnetometer) in a cold "
        "thermal-vacuum test, 2020-03-07: 25 bursts of 5 s at 50 Hz every 5 min, "
        "23.9 -> 15.6 degC",
        _PAN_REPO, _PAN_COMMIT, "MIT (Copyright (c) 2020 Pathfinder for Autonomous Navigation)",
        (Source("pan_tvac/TVCtest3_7_20.csv",
                _raw(_PAN_REPO, _PAN_COMMIT, "MATLAB/sensor_models/TVCtest3_7_20.csv"),
                "8ad84a540e91a690b1711a00472e034d6b0a8fdafee635a724191f77eb7c3327"),),
        _pan, notes="two rows with gyrox <= -0.08 rad/s are spikes the authors removed by "
                    "hand; gyroid's outlier check finds them"),
    Dataset(
        "astropi_sensehat",
        "Raspberry Pi Sense HAT (ST LSM9DS1) ground log, 2015-08-20..24: a row every ~10 s "
        "for 81 h (an 11.9 h gap), static but for handling at 9-11 h and a 90 deg turn "
        "during the gap",
        _ASTRO_REPO, _ASTRO_COMMIT,
        "CC BY-SA 4.0 (\"Astro Pi Flight Data Analysis by the Raspberry Pi Foundation\")",
        (Source("astropi_sensehat/astro_pi_data_20150824_085954.zip",
                _raw(_ASTRO_REPO, _ASTRO_COMMIT, "data/astro_pi_data_20150824_085954.zip"),
                "339c05171c74205fa5d98f74e748ec67ceabd5e4db5d19af2105ff144d2e2b0e"),),
        _astropi, notes="the field changes only when the unit is turned: no excitation of a "
                        "magnetic sensitivity"),
    Dataset(
        "mpu6050_sunsided",
        "seven static runs of one InvenSense MPU6050, 63-655 s each at ~99 Hz (host time "
        "stamps in bursts); the temperature moves 0.3-0.5 degC per run",
        _MPU_REPO, _MPU_COMMIT, "EUPL-1.2",
        tuple(Source(f"mpu6050_sunsided/raw/set{g}_{f}/mpu6050_{kind}.mat",
                     _raw(_MPU_REPO, _MPU_COMMIT, f"data/set-{g}/{f}/mpu6050_{kind}.mat"),
                     _MPU_SHA256[(g, f)][k])
              for g, f in _MPU_RUNS for k, kind in enumerate(("gyroscope", "temperature"))),
        _mpu6050, notes="the temperature hardly moves: a temperature coefficient is not "
                        "identifiable from these runs"),
    Dataset(
        "smac_imudata",
        "six 2.78 h static runs at 100 Hz of an ADIS16405 MEMS IMU (probably one unit; gyro "
        "quantised to 0.05 deg/s, no thermometer) and a 1.4 h Xsens MTi-G x-gyro run at "
        "100 Hz contaminated by outliers",
        _SMAC_REPO, _SMAC_COMMIT, "CC BY-NC-SA 4.0 (research use; gyroid ships none of it)",
        tuple(Source(f"smac_adis16405/{name}.rda",
                     _raw(_SMAC_REPO, _SMAC_COMMIT, f"data/{name}.rda"), sha)
              for name, sha in _SMAC_SHA256.items()),
        _smac, notes="University of Calgary's ADIS16405 runs and the MTi-G run of the robust "
                     "GMWM papers (Guerrier et al.); the rates' units are the package's "
                     "(ADIS deg/s, MTi-G rad/s)"),
)}
