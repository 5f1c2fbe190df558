"""Roll logs (docs/formats.md section 4): the SINS roll rate, the stabiliser's encoder angle and,
optionally, the stabiliser's MEMS output, read and validated, with a wrapped encoder angle
unwrapped."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.io._tables import check_plausible, check_time_increasing, read_log_table


@dataclass(frozen=True)
class RollLog:
    time_s: np.ndarray
    roll_rate_deg_s: np.ndarray
    gs_angle_deg: np.ndarray
    gs_rate_deg_s: np.ndarray | None
    source: str = "<memory>"
    notes: tuple[str, ...] = ()  # what loading changed (e.g. an unwrapped encoder angle)

    @property
    def n(self) -> int:
        return int(self.time_s.size)

    @classmethod
    def from_columns(cls, columns, source: str = "<memory>") -> RollLog:
        """From contract-named arrays (e.g. a simulated flight's ``columns``), unchecked."""
        rate = columns.get("gs_rate_deg_s")
        return cls(np.asarray(columns["time_s"]), np.asarray(columns["roll_rate_deg_s"]),
                   np.asarray(columns["gs_angle_deg"]),
                   None if rate is None else np.asarray(rate), source)


def load_roll_log(path, column_map=()) -> RollLog:
    """Read and validate a roll log (docs/formats.md section 4; .csv, .csv.gz or .parquet).

    A stabiliser angle that wraps (to [0, 360) or by one whole turn somewhere) is unwrapped
    with a note when every jump is a whole number of turns away from what the SINS rate
    predicts; a jump that is not is refused, naming its row."""
    table = read_log_table(path, tuple(column_map))
    if table.has("drift_deg_h") and not table.has("roll_rate_deg_s"):
        raise GyroidInputError(f"{table.label} is a bench log (it has drift_deg_h, no "
                               "roll_rate_deg_s): use 'gyroid fit' or 'gyroid discrepancy' "
                               "with drift terms")
    time_s = table.number_column("time_s")
    columns = {name: table.number_column(name, "a roll log needs roll_rate_deg_s and "
                                               "gs_angle_deg (docs/formats.md section 4); map "
                                               f"yours with --map {name}=COLUMN[:UNIT]")
               for name in ("roll_rate_deg_s", "gs_angle_deg")}
    gs_rate = table.number_column("gs_rate_deg_s") if table.has("gs_rate_deg_s") else None
    for name, values in (("time_s", time_s), *columns.items(),
                         *((("gs_rate_deg_s", gs_rate),) if gs_rate is not None else ())):
        check_plausible(table, name, values)
    check_time_increasing(table, time_s)
    steps = np.diff(time_s)
    if steps.size and np.ptp(steps) > 1e-6 * np.median(steps):
        bad = int(np.argmax(np.abs(steps - np.median(steps)) > 1e-6 * np.median(steps))) + 1
        raise GyroidInputError(f"{table.label}: the roll log must be uniformly sampled; the "
                               f"step changes at {table.where(bad)}; resample the log")
    if table.n_rows < 50:
        raise GyroidInputError(f"{table.label}: {table.n_rows} rows are too few for a fit")
    angle, notes = unwrap_gs_angle(table, time_s, columns["roll_rate_deg_s"],
                                   columns["gs_angle_deg"])
    return RollLog(time_s, columns["roll_rate_deg_s"], angle, gs_rate, str(table.path),
                   tuple(notes))


#: A stabiliser-angle step further than this from the SINS-predicted step is a jump, deg.
JUMP_TOLERANCE_DEG = 45.0


def unwrap_gs_angle(table, time_s, roll_rate_deg_s, gs_angle_deg
                    ) -> tuple[np.ndarray, list[str]]:
    """Unwrap whole-turn jumps of the encoder angle (see :func:`load_roll_log`)."""
    dt = np.diff(time_s)
    predicted = 0.5 * (roll_rate_deg_s[1:] + roll_rate_deg_s[:-1]) * dt
    surprise = np.diff(gs_angle_deg) - predicted
    jumps = np.flatnonzero(np.abs(surprise) > JUMP_TOLERANCE_DEG)
    if not jumps.size:
        return gs_angle_deg, []
    turns = np.round(surprise[jumps] / 360.0)
    off = np.abs(surprise[jumps] - 360.0 * turns)
    bad = jumps[(turns == 0) | (off > JUMP_TOLERANCE_DEG)]
    if bad.size:
        i = int(bad[0]) + 1
        raise GyroidInputError(
            f"{table.label}: gs_angle_deg jumps by {np.diff(gs_angle_deg)[i - 1]:.6g} deg at "
            f"{table.where(i)} where the roll rate predicts {predicted[i - 1]:.6g} deg: not a "
            "whole turn, so it cannot be unwrapped; fix the encoder log (gyroid needs the "
            "unwrapped angle)")
    correction = np.zeros(gs_angle_deg.size)
    correction[jumps + 1] = -360.0 * turns
    unwrapped = gs_angle_deg + np.cumsum(correction)
    first = int(jumps[0]) + 1
    note = (f"gs_angle_deg was wrapped: {jumps.size} whole-turn jump(s), the first at "
            f"{table.where(first)}; unwrapped with the SINS rate as a guide")
    return unwrapped, [note]


