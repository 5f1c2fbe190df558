"""Paper B's worked dK: printed, recomputed by eq. 7, its two terms, and the reconstruction
that matches the printed number."""

import json

import matplotlib.pyplot as plt
import numpy as np
import paths

from gyroid.plotting import STYLE, save

worked = json.loads(paths.data("reproduce", "reproduce.json").read_text())["paper_b"]["dK_worked"]
labels = ["printed", "eq. 7", "rate term", "encoder term", "D0gs + D1gs w_H + Denc[rad]"]
values = [worked["printed"], worked["recomputed"], worked["rate_term"], worked["encoder_term"],
          worked["printed_reconstruction"]]
with plt.rc_context(STYLE):
    fig, ax = plt.subplots(figsize=(5.5, 3.2))
    y = np.arange(len(labels))
    ax.barh(y, values, color=["0.2", "0.6", "0.8", "0.8", "white"], edgecolor="0.0")
    ax.set_yticks(y, labels)
    ax.set_xscale("log")
    ax.set_xlabel("relative error of the correction coefficient dK, dimensionless")
save(fig, paths.figure("paper_b_worked_dk"), pdf=True)
