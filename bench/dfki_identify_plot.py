#!/usr/bin/python3
"""Draws docs/results/double-pendulum-errors.png from bench/dfki_identify's CSV: the median and
90th percentile of the open-loop angle errors against the horizon, per model.

Usage: /usr/bin/python3 bench/dfki_identify_plot.py docs/results/double-pendulum.csv OUT.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

if len(sys.argv) != 3:
    sys.exit(__doc__)
rows = list(csv.DictReader(open(sys.argv[1])))
models = list(dict.fromkeys(r["model"] for r in rows))
style = {"urdf": ("k", ":"), "lab-1.0": ("0.6", "--"), "lab-2.0": ("0.3", "-"),
         "lab-2.1": ("0.6", "-."), "ls": ("tab:brown", "-"), "gp": ("tab:blue", "--"),
         "gp_prior": ("tab:cyan", "-"), "mi": ("tab:orange", "-"), "gp_mi": ("tab:red", "-")}
fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
for col, dim in enumerate((0, 1)):
    for row, stat in enumerate(("median", "p90")):
        ax = axes[row][col]
        for m in models:
            pts = sorted((float(r["horizon"]), float(r[stat])) for r in rows
                         if r["model"] == m and int(r["dim"]) == dim)
            c, ls = style.get(m, (None, "-"))
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color=c, linestyle=ls, marker="o",
                    markersize=3, label=m, linewidth=2.2 if m == "gp_mi" else 1.3)
        ax.set_yscale("log")
        ax.set_title(f"q{dim + 1}: {stat} open-loop error")
        ax.set_ylabel("rad")
        ax.grid(True, which="both", alpha=0.3)
        if row == 1:
            ax.set_xlabel("horizon (s)")
axes[0][0].legend(fontsize=8, ncol=2)
fig.suptitle("DFKI double pendulum: validation recordings 03 and 05 (fit on 00, 01, 02, 04)")
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=90)
