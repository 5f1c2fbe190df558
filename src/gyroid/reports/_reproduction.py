"""The files of `gyroid reproduce`: reproduce.json, tables.md and both papers' figures."""

from __future__ import annotations

from gyroid.papers._repeatability import magnetic_repeatability
from gyroid.papers._reproduce import reproduce, tables_markdown


def write_reproduction(folder) -> dict:
    """Write reproduce.json, tables.md and the papers' figures (PNG and PDF) into ``folder``."""
    from pathlib import Path

    from gyroid.io._outputs import json_text
    from gyroid.plotting import paper_a_table, paper_b_lateral, paper_b_stabiliser, save
    from gyroid.plotting._pool import forest_plot

    folder = Path(folder)
    pools = magnetic_repeatability()
    result = reproduce(pools)
    (folder / "reproduce.json").write_text(json_text(result))
    unit = {name: "deg/h per 100 uT" for name in ("wx", "wy", "wz")}
    for device, pool in pools.items():
        save(forest_plot(pool, units=unit, title=f"Paper A, device {device}: two tests "
                                                 "pooled"),
             folder / f"paper_a_magnetic_device{device}_pooled", pdf=True)
    (folder / "tables.md").write_text(tables_markdown(result))
    save(paper_a_table(result), folder / "paper_a_setpoint_table", pdf=True)
    save(paper_b_lateral(result), folder / "paper_b_table2", pdf=True)
    save(paper_b_stabiliser(result), folder / "paper_b_stabiliser_table", pdf=True)
    return result
