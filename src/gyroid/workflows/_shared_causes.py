"""Causes shared by a log's gyro axes: the per-axis discrepancy searches compared.

A bias step, a start-up transient or an excursion that shows on several axes at once is more
likely one cause outside the gyros (the unit handled or knocked, a power or thermal event)
than each gyro's own, and says so. Each axis's search may find a step on its own; a step
found on one axis is also looked for on the others at that time: added to each other axis's
final model as a step at the given time (one parameter: the time is not searched), scored as
the search scores candidates (dBIC above the same threshold), so a step too small for an
axis's own search to find among all times is seen where another axis says when to look.
"""

from __future__ import annotations

from collections.abc import Mapping

from gyroid.io._logs import BenchLog
from gyroid.models._effects import STEP_EDGE_FRACTION
from gyroid.models._inputs import T0_C
from gyroid.workflows._discrepancy import ADD_THRESHOLD, step_at_time
from gyroid.workflows._discrepancy_report import DiscrepancyReport

#: Two steps within this many step edges (the bias step's logistic edge, 1/200 of the
#: log's span: its time's resolution) or a minute are one time.
SAME_TIME_EDGES = 3.0
#: |z| of an excursion window (the searches' largest-residual windows) seen on two axes.
EXCURSION_Z = 4.0


def shared_causes(reports: Mapping[str, DiscrepancyReport], logs: Mapping[str, BenchLog],
                  *, t0_C: float = T0_C) -> list[dict]:
    """What several axes show at once: ``{"cause", "axes", "time_h" | "start_s", "end_s",
    "sizes_deg_h", "dbic" | "z", "evidence"}`` per shared cause (empty for one axis);
    ``logs`` are the axes' logs the searches read."""
    reports = {a: r for a, r in reports.items() if r.log_kind == "bench" and a is not None}
    if len(reports) < 2:
        return []
    return [*_shared_steps(reports, logs, t0_C), *_shared_warmups(reports),
            *_shared_excursions(reports)]


def _span_h(report: DiscrepancyReport) -> float:
    return float(report.time_s[-1] - report.time_s[0]) / 3600.0


def _shared_steps(reports: Mapping[str, DiscrepancyReport], logs: Mapping[str, BenchLog],
                  t0_C: float) -> list[dict]:
    found = [(axis, step.values["t_step_h"], step.values["w_step"])
             for axis, report in reports.items() for step in report.steps
             if step.effect == "bias_step"]
    out: list[dict] = []
    for axis, time_h, size in sorted(found, key=lambda f: f[1]):
        if any(abs(time_h - item["time_h"]) <= _same_time_h(reports[axis]) for item in out):
            continue
        sizes = {axis: size}
        scores: dict[str, float] = {}
        for other, report in reports.items():
            if other == axis:
                continue
            own = [w for a, t, w in found if a == other
                   and abs(t - time_h) <= _same_time_h(report)]
            if own:
                sizes[other] = own[0]
                continue
            dbic, step = step_at_time(logs[other], report.final_terms, time_h, t0_C=t0_C)
            if dbic > ADD_THRESHOLD:
                sizes[other], scores[other] = step, dbic
        if len(sizes) > 1:
            axes = sorted(sizes)
            listed = ", ".join(f"{a} {sizes[a]:+.3g} deg/h" + (
                f" (dBIC = {scores[a]:.0f} at that time)" if a in scores else "")
                for a in axes)
            out.append({"cause": "bias_step", "axes": axes, "time_h": time_h,
                        "sizes_deg_h": sizes, "dbic": scores,
                        "evidence": f"a bias step at {time_h:.3g} h on axes "
                                    f"{', '.join(axes)} ({listed}): one cause outside the "
                                    "gyros (the unit handled or knocked, a power or thermal "
                                    "event) is likelier than each gyro's own"})
    return out


def _same_time_h(report: DiscrepancyReport) -> float:
    return max(SAME_TIME_EDGES * STEP_EDGE_FRACTION * _span_h(report), 1.0 / 60.0)


def _shared_warmups(reports: Mapping[str, DiscrepancyReport]) -> list[dict]:
    axes = sorted(a for a, r in reports.items() if "warmup" in r.added)
    if len(axes) < 2:
        return []
    return [{"cause": "warmup", "axes": axes,
             "evidence": f"a start-up transient on axes {', '.join(axes)}: the unit's own "
                         "warm-up (power, heating) rather than each gyro's"}]


def _shared_excursions(reports: Mapping[str, DiscrepancyReport]) -> list[dict]:
    windows = [(axis, w) for axis, r in reports.items() for w in r.where
               if abs(w["z"]) >= EXCURSION_Z]
    out: list[dict] = []
    for _, window in windows:
        overlapping = {a: w for a, w in windows
                       if w["start_s"] <= window["end_s"] and window["start_s"] <= w["end_s"]}
        if len(overlapping) < 2 or any(set(overlapping) == set(o["axes"])
                                       and o["start_s"] <= window["end_s"]
                                       and window["start_s"] <= o["end_s"] for o in out):
            continue
        axes = sorted(overlapping)
        start = min(w["start_s"] for w in overlapping.values())
        end = max(w["end_s"] for w in overlapping.values())
        z = {a: float(overlapping[a]["z"]) for a in axes}
        out.append({"cause": "excursion", "axes": axes, "start_s": start, "end_s": end, "z": z,
                    "evidence": f"the residuals leave their noise together on axes "
                                f"{', '.join(axes)} between {start:.6g} and {end:.6g} s ("
                                + ", ".join(f"{a} z = {z[a]:.1f}" for a in axes)
                                + "): a shared cause"})
    return out
