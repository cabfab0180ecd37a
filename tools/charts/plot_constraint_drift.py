#!/usr/bin/env python3
"""Plots docs/charts/constraint_drift.csv (written by bench_constraints --drift_csv=...) into
docs/charts/constraint_drift.png: the four-bar's loop-closure error over 20 s with no
stabilization, Baumgarte only, and Baumgarte + projection (log scale).

usage: /usr/bin/python3 tools/charts/plot_constraint_drift.py [CSV] [PNG]
(needs python3-matplotlib from Debian)"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

src = sys.argv[1] if len(sys.argv) > 1 else "docs/charts/constraint_drift.csv"
dst = sys.argv[2] if len(sys.argv) > 2 else "docs/charts/constraint_drift.png"
with open(src) as f:
    rows = list(csv.DictReader(f))
t = [float(r["t"]) for r in rows]
labels = {
    "err_none": "no stabilization",
    "err_baumgarte": "Baumgarte (omega = 20/s, zeta = 1)",
    "err_baumgarte_projection": "Baumgarte + projection",
}
fig, ax = plt.subplots(figsize=(8, 4.5))
for key, label in labels.items():
    floor = 1e-17  # zeros on a log axis
    ax.semilogy(t, [max(float(r[key]), floor) for r in rows], label=label, lw=1)
ax.axhline(1e-6, color="k", ls="--", lw=0.8, label="test bound 1e-6 m")
ax.set_xlabel("simulated time (s)")
ax.set_ylabel("loop-closure error max |phi| (m)")
ax.set_title("Four-bar linkage under gravity, rkmk4, dt = 1 ms: constraint drift")
ax.grid(True, which="both", alpha=0.3)
ax.legend(loc="center right", fontsize=8)
fig.tight_layout()
fig.savefig(dst, dpi=100)
print("wrote", dst)
