"""gyroid: the discrepancy gap shrinking as the named effect is added (demo's log)."""

import json

import matplotlib.pyplot as plt
import paths

from gyroid.plotting import STYLE, save

report = json.loads(paths.data("discrepancy", "discrepancy.json").read_text())
labels = ["baseline", *report["added"]]
rms = [report["rms_baseline_deg_h"], *[s["rms_after_deg_h"] for s in report["steps"]]]
with plt.rc_context(STYLE):
    fig, ax = plt.subplots(figsize=(4.5, 3.2))
    ax.plot(range(len(rms)), rms, "o-", color="0.0")
    ax.set_xticks(range(len(rms)), labels)
    ax.set_xlabel("model")
    ax.set_ylabel("RMS residual, deg/h")
    for i, step in enumerate(report["steps"], start=1):
        ax.annotate(f"dBIC {step['score']:.0f}", (i, rms[i]), textcoords="offset points",
                    xytext=(5, 8), fontsize=8)
save(fig, paths.figure("gyroid_discrepancy_gap"), pdf=True)
