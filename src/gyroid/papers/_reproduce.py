"""Both papers' tables recomputed with gyroid's own models, and an audit of where a paper
disagrees with its own formulas or data."""

from __future__ import annotations

from gyroid.io._paper_tables import (
    paper_a_magnetic_coefficients,
    paper_a_thermal_coefficients,
    paper_a_thermal_table,
)
from gyroid.models import _paper_b as pb
from gyroid.models._inputs import T0_C
from gyroid.papers._classic import chi2_of, setpoint_table_fit
from gyroid.papers._repeatability import magnetic_repeatability, repeatability_json


def paper_a() -> dict:
    """Paper A: printed and refitted w0, w1, w2 with their chi^2 on the six-point table."""
    table = paper_a_thermal_table()
    printed = paper_a_thermal_coefficients()
    t_rel = table.setpoint_C - T0_C
    refit = setpoint_table_fit(table.setpoint_C, table.dw_deg_h, table.sigma_deg_h)
    published = {k: printed[k] for k in ("w0", "w1", "w2")}
    model_printed = published["w0"] + published["w1"] * t_rel + published["w2"] * t_rel**2
    model_refit = (refit.coefficients["w0"] + refit.coefficients["w1"] * t_rel
                   + refit.coefficients["w2"] * t_rel**2)
    return {
        "published": published | {"chi2": chi2_of(published, t_rel, table.dw_deg_h,
                                                   table.sigma_deg_h)},
        "refit": refit.coefficients | {"chi2": refit.chi2, "dof": refit.dof,
                                       "sd": refit.sd},
        "table": {
            f"{s:g}": {"dw_deg_h": float(d), "sigma_deg_h": float(g),
                       "model_published_deg_h": float(mp), "model_refit_deg_h": float(mr)}
            for s, d, g, mp, mr in zip(table.setpoint_C, table.dw_deg_h, table.sigma_deg_h,
                                       model_printed, model_refit, strict=True)
        },
        "wD_printed": printed["wD"],
        "magnetic_coefficients": {f"device {d} test {t}": v
                                  for (d, t), v in paper_a_magnetic_coefficients().items()},
    }


def paper_b() -> dict:
    return {"table2": pb.table2(), "table_gs": pb.table_gs(), "dK_worked": pb.dk_worked()}


def audit(a: dict, b: dict) -> list[dict]:
    """Every disagreement found, with the paper, the item, both numbers and a sentence."""
    return _audit_paper_a(a) + _audit_paper_b(b)


def _audit_paper_a(a: dict) -> list[dict]:
    items = []
    row55 = a["table"]["55"]
    off55 = row55["model_published_deg_h"] - row55["dw_deg_h"]
    items.append({
        "paper": "A", "item": "thermal coefficients vs the setpoint table",
        "printed": a["published"]["chi2"], "recomputed": a["refit"]["chi2"],
        "quantity": "chi2 on the 6 points (printed w0, w1, w2 vs weighted refit)",
        "note": (f"The printed w0 = {a['published']['w0']}, w1 = {a['published']['w1']}, "
                 f"w2 = {a['published']['w2']} reproduce the table with chi2 = "
                 f"{a['published']['chi2']:.0f}; a weighted refit of the same model gives "
                 f"w0 = {a['refit']['w0']:.3f}, w1 = {a['refit']['w1']:.4f}, w2 = "
                 f"{a['refit']['w2']:.5f} with chi2 = {a['refit']['chi2']:.1f} (3 dof)."),
    })
    items.append({
        "paper": "A", "item": "drift at the 55 degC setpoint",
        "printed": row55["dw_deg_h"], "recomputed": row55["model_published_deg_h"],
        "quantity": "deg/h (table vs printed model)",
        "note": (f"At 55 degC the printed model gives {row55['model_published_deg_h']:.3f} "
                 f"deg/h against the table's {row55['dw_deg_h']} deg/h "
                 f"({off55:.2f} deg/h off, {off55 / row55['sigma_deg_h']:.0f} sigma); w2 is "
                 "printed to one significant digit."),
    })
    items.append({
        "paper": "A", "item": "w0 of a table of deviations from the t0 reading",
        "printed": a["published"]["w0"], "recomputed": 0.0,
        "quantity": "deg/h at t = 0 (printed w0 vs the table's definition)",
        "note": ("The table holds deviations from the output at t0 = 21 degC, which are 0 at "
                 "t = 0 by definition, yet the fitted constant is w0 = 1.197 deg/h (the refit "
                 f"gives {a['refit']['w0']:.2f}): the quadratic does not pass through its own "
                 "reference point, so w0 cannot be the gyro's bias."),
    })
    k = a["magnetic_coefficients"]
    negative = [(name, axis, v) for name, row in k.items() for axis, v in row.items() if v < 0]
    name, axis, value = negative[0]
    items.append({
        "paper": "A", "item": "sign of the magnetic coefficients",
        "printed": value, "recomputed": abs(value),
        "quantity": f"{axis}, {name}, deg/h per 100 uT",
        "note": (f"K is defined as |dw(+300) - dw(-300)| / 6, which cannot be negative, yet "
                 f"{len(negative)} of 12 printed coefficients are (e.g. {axis} = {value} for "
                 f"{name}): the signs must come from dw(+300) - dw(-300) without the modulus."),
    })
    return items


def _audit_paper_b(b: dict) -> list[dict]:
    items = []
    t2 = b["table2"]
    items.append({
        "paper": "B", "item": "Table 2 lateral error at 10 s",
        "printed": t2["10"]["dr_z_printed"], "recomputed": t2["10"]["dr_z_m_eq8"],
        "quantity": "dr_z (printed, unit printed km) vs eq. 8 in SI (m)",
        "note": (f"Eq. 8 in SI (w_x in rad/s, with the 1/6) gives {t2['10']['dr_z_m_eq8']:.1f} "
                 f"m at 10 s; the printed {t2['10']['dr_z_printed']} is g D1 w_x t^3 with w_x "
                 f"in deg/s and no 1/6, in metres divided by 1000 "
                 f"({t2['10']['dr_z_printed_reconstruction']:.2f}), labelled km."),
    })
    for t in ("60", "120"):
        row = t2[t]
        times_bound = row["dr_z_printed"] * 1000 / row["dr_z_bound_m"]
        items.append({
            "paper": "B", "item": f"Table 2 lateral error at {t} s",
            "printed": row["dr_z_printed"], "recomputed": row["dr_z_m_exact"],
            "quantity": "dr_z printed (km) vs g sin(dpsi) integrated twice (m)",
            "note": (f"At {t} s the roll error is {row['dpsi_deg']:.1f} deg, far from small: the "
                     f"exact lateral error is {row['dr_z_m_exact'] / 1000:.2f} km, eq. 8 gives "
                     f"{row['dr_z_m_eq8'] / 1000:.2f} km, and no lateral error can exceed "
                     f"g t^2 / 2 = {row['dr_z_bound_m'] / 1000:.2f} km; the printed "
                     f"{row['dr_z_printed']:g} km is {times_bound:.0f} times that bound."),
        })
    worked = b["dK_worked"]
    items.append({
        "paper": "B", "item": "worked dK (non-ideal stabiliser)",
        "printed": worked["printed"], "recomputed": worked["recomputed"],
        "quantity": "relative error of the correction coefficient",
        "note": (f"Eq. 7 with the paper's numbers gives {worked['rate_term']:.2e} + "
                 f"{worked['encoder_term']:.2e} = {worked['recomputed']:.2e} "
                 f"({worked['fraction_of_D1']:.2f} of D1 = 600 ppm, i.e. the correction removes"
                 f" {100 * (1 - worked['fraction_of_D1']):.0f} % of the SF error, not 90 %); "
                 f"the printed 0.093 is matched by D0gs + D1gs w_H + Denc in radians "
                 f"({worked['printed_reconstruction']:.4f}), the divisions by w_x dropped."),
    })
    gs = b["table_gs"]["120"]
    items.append({
        "paper": "B", "item": "stabiliser bias D0gs in the angle table",
        "printed": gs["dpsi_gs_printed_deg"], "recomputed": gs["dpsi_gs_unrounded_deg"],
        "quantity": "dpsi_GS at 120 s, deg",
        "note": (f"D0gs = sqrt(10^2 + 7^2) = {pb.mems_bias_deg_s() * 3600:.2f} deg/h = "
                 f"{pb.mems_bias_deg_s():.2e} deg/s, which the tables round to 3.3e-3 deg/s "
                 f"(3 % low): {gs['dpsi_gs_unrounded_deg']:.3f} deg at 120 s instead of "
                 f"{gs['dpsi_gs_printed_deg']}."),
    })
    return items


def confirmed(b: dict) -> list[dict]:
    """Printed numbers that do follow from the paper's formulas."""
    t2 = b["table2"]
    return [
        {"paper": "B", "item": f"Table 2 roll error at {t} s", "printed": row["dpsi_printed_deg"],
         "recomputed": row["dpsi_deg"], "note": "dpsi_B = D1 w_x t with D1 = 600 ppm"}
        for t, row in t2.items()
    ] + [
        {"paper": "B", "item": f"stabiliser table at {t} s", "printed": row["dpsi_gs_printed_deg"],
         "recomputed": row["dpsi_gs_deg"], "note": "eq. 9 with D0gs = 3.3e-3 deg/s, Denc 0.33"}
        for t, row in b["table_gs"].items()
    ]


def reproduce(pools: dict | None = None) -> dict:
    """The content of ``reproduce.json``; ``pools``: paper A's magnetic table pooled per
    device (:func:`gyroid.papers._repeatability.magnetic_repeatability`, run when None)."""
    a, b = paper_a(), paper_b()
    a["magnetic_repeatability"] = repeatability_json(
        magnetic_repeatability() if pools is None else pools)
    return {"paper_a": a, "paper_b": b, "audit": audit(a, b), "confirmed": confirmed(b),
            "constants": {"g_m_s2": pb.G, "t0_C": T0_C}}




def tables_markdown(result: dict) -> str:
    """The recomputed tables and the audit as Markdown."""
    a, b = result["paper_a"], result["paper_b"]
    lines = ["# Both papers' tables, recomputed by gyroid", "", "## Paper A: setpoint table",
             "", "| setpoint, degC | dw, deg/h | sigma | printed model | refit model |",
             "|---|---|---|---|---|"]
    for s, row in a["table"].items():
        lines.append(f"| {s} | {row['dw_deg_h']} | {row['sigma_deg_h']} | "
                     f"{row['model_published_deg_h']:.3f} | {row['model_refit_deg_h']:.3f} |")
    lines += ["", "| coefficients | w0 | w1 | w2 | chi2 |", "|---|---|---|---|---|"]
    for key in ("published", "refit"):
        c = a[key]
        lines.append(f"| {key} | {c['w0']:.4g} | {c['w1']:.4g} | {c['w2']:.4g} | "
                     f"{c['chi2']:.4g} |")
    lines += ["", "## Paper B: Table 2 (w_x = 3600 deg/s, D1 = 600 ppm)", "",
              "| t, s | dpsi_B, deg | dr_z eq. 8 SI, m | dr_z exact, m | bound g t^2/2, m | "
              "printed (km) |", "|---|---|---|---|---|---|"]
    for t, row in b["table2"].items():
        lines.append(f"| {t} | {row['dpsi_deg']:.1f} | {row['dr_z_m_eq8']:.1f} | "
                     f"{row['dr_z_m_exact']:.1f} | {row['dr_z_bound_m']:.1f} | "
                     f"{row['dr_z_printed']:g} |")
    lines += ["", "## Paper B: ideal stabiliser (eq. 9)", "",
              "| t, s | D0gs t, deg | dpsi_GS, deg | printed | unrounded D0gs |",
              "|---|---|---|---|---|"]
    for t, row in b["table_gs"].items():
        lines.append(f"| {t} | {row['d0gs_t_deg']:.3f} | {row['dpsi_gs_deg']:.3f} | "
                     f"{row['dpsi_gs_printed_deg']} | {row['dpsi_gs_unrounded_deg']:.3f} |")
    rep = a["magnetic_repeatability"]
    lines += ["", "## Paper A: magnetic coefficients, test to test", "",
              f"Assumed within-test sd {rep['assumed_within_test_sd']:.4f} deg/h per 100 uT "
              f"({rep['assumption']}).", "",
              "| device | axis | test 1 | test 2 | Q p-value | s_star | between-test sd "
              "(95 %) | new test |", "|---|---|---|---|---|---|---|---|"]
    for device, entry in rep["devices"].items():
        for axis, row in entry["axes"].items():
            sd = row["between_test_sd"]
            new = row["new_test_predictive"]
            lines.append(f"| {device} | {axis} | {row['tests'][0]:g} | {row['tests'][1]:g} | "
                         f"{row['p_value']:.2g} | {row['s_star']:.3g} | {sd['mean']:.3g} "
                         f"({sd['ci95'][0]:.2g} ... {sd['ci95'][1]:.2g}) | "
                         f"{new['mean']:.3g} +/- {new['sd']:.2g} |")
    w = b["dK_worked"]
    lines += ["", "## Paper B: worked dK", "",
              f"printed {w['printed']}, recomputed by eq. 7 {w['recomputed']:.3e} "
              f"({w['fraction_of_D1']:.2f} of D1).", "", "## Audit", ""]
    for item in result["audit"]:
        lines.append(f"- **Paper {item['paper']}, {item['item']}** (printed {item['printed']:.4g}"
                     f", recomputed {item['recomputed']:.4g}): {item['note']}")
    return "\n".join(lines) + "\n"
