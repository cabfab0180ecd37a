#!/usr/bin/python3
"""Plots the CSV files written by charts_data into PNG charts (Debian's python3-matplotlib).

Usage: plot_charts.py DATA_DIR OUT_DIR
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "euler": ("tab:red", "o"),
    "symplectic_euler": ("tab:orange", "s"),
    "rkmk4": ("tab:blue", "^"),
    "rkmk45": ("tab:purple", "D"),
    "variational": ("tab:green", "v"),
    "rk4_euler_angles": ("tab:brown", "x"),
    "rk4_quaternion": ("tab:gray", "+"),
}
TITLES = {
    "free_body": "torque-free axisymmetric body, 10 s (exact solution)",
    "satellite_arm": "7-dof satellite arm, zero gravity, 4 s",
    "chain20_gravity": "20-link chain, fixed base, gravity, 1 s",
}


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(s):
    try:
        v = float(s)
    except (TypeError, ValueError):
        return math.nan
    return v


def work_precision(data_dir, out_dir, scene):
    rows = read(os.path.join(data_dir, "wp_%s.csv" % scene))
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    names = []
    for r in rows:
        if r["integrator"] not in names:
            names.append(r["integrator"])
    for name in names:
        pts = [r for r in rows if r["integrator"] == name and num(r["err"]) > 0]
        if not pts:
            continue
        color, marker = STYLE.get(name, ("black", "."))
        label = name + (" (tol 1e-3..1e-11)" if name == "rkmk45" else "")
        for ax, key in zip(axes, ("cpu_s", "evals")):
            xs = [num(p[key]) for p in pts]
            ys = [max(num(p["err"]), 1e-16) for p in pts]
            ax.loglog(xs, ys, color=color, marker=marker, label=label, lw=1.3, ms=5)
    axes[0].set_xlabel("CPU time per run [s]")
    axes[1].set_xlabel("dynamics evaluations (ABA calls; mass-matrix solves for variational)")
    for ax in axes:
        ax.set_ylabel("final error |log(f_ref^-1 f)| + |q - q_ref|")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("Work-precision: " + TITLES.get(scene, scene))
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "wp_%s.png" % scene), dpi=90)
    plt.close(fig)


def energy(data_dir, out_dir):
    rows = read(os.path.join(data_dir, "energy.csv"))
    panels = [
        ("pendulum", "energy_err", "double pendulum (gravity, no damping), dt = 0.002 s: max |E - E0| / T0"),
        ("free_body", "energy_err", "free asymmetric body, dt = 0.05 s: max |E - E0| / T0"),
        ("free_body", "momentum_err", "free asymmetric body, dt = 0.05 s: max |h - h0| / |h0|"),
    ]
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.2))
    for ax, (scene, key, title) in zip(axes, panels):
        names = []
        for r in rows:
            if r["scene"] == scene and r["integrator"] not in names:
                names.append(r["integrator"])
        for name in names:
            pts = [r for r in rows if r["scene"] == scene and r["integrator"] == name]
            xs = [num(p["t"]) for p in pts]
            ys = [max(num(p[key]), 1e-17) for p in pts]
            if not any(math.isfinite(y) for y in ys):
                continue
            color, _ = STYLE.get(name, ("black", "."))
            ax.loglog(xs, ys, color=color, label=name, lw=1.5)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("simulated time [s]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Long runs (1e4 s): bounded error for the symplectic/variational methods, drift for the others")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "energy.png"), dpi=90)
    plt.close(fig)


def dynamics(data_dir, out_dir):
    rows = read(os.path.join(data_dir, "dyn_scaling.csv"))
    mr = read(os.path.join(data_dir, "dyn_mass_ratio.csv"))
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.2))
    n = [num(r["n"]) for r in rows]
    algos = [("aba", "ABA", "tab:blue"), ("chol", "CRBA + Cholesky", "tab:red"),
             ("minv", "D^-1 (minv) * (tau - H)", "tab:green")]
    for key, label, color in algos:
        axes[0].loglog(n, [num(r[key + "_ns"]) * 1e-3 for r in rows], "o-", color=color, label=label)
        axes[1].loglog(n, [max(num(r[key + "_err"]), 1e-17) for r in rows], "o-", color=color,
                       label=label)
    axes[0].set_ylabel("time per call [us]")
    axes[0].set_title("time, free-floating chain of n bodies", fontsize=10)
    axes[1].set_ylabel("max relative error vs long-double ABA")
    axes[1].set_title("accuracy, unit masses", fontsize=10)
    for ax in axes[:2]:
        ax.set_xlabel("bodies n")
    for key, label, color in algos:
        for pattern, ls in (("alternating", "-"), ("ramp", "--")):
            pts = [r for r in mr if r["pattern"] == pattern]
            axes[2].loglog([num(p["span"]) for p in pts],
                           [max(num(p[key + "_err"]), 1e-17) for p in pts], ls, marker="o",
                           color=color, label="%s, %s" % (label, pattern))
    axes[2].set_xlabel("link mass span max/min (30-link free chain)")
    axes[2].set_ylabel("max relative error vs long-double ABA")
    axes[2].set_title("accuracy, masses spanning many orders of magnitude", fontsize=10)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Forward dynamics: ABA, mass matrix + Cholesky, O(n) D^-1")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "dynamics.png"), dpi=90)
    plt.close(fig)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_charts.py DATA_DIR OUT_DIR")
    data_dir, out_dir = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    for scene in ("free_body", "satellite_arm", "chain20_gravity"):
        if os.path.exists(os.path.join(data_dir, "wp_%s.csv" % scene)):
            work_precision(data_dir, out_dir, scene)
    if os.path.exists(os.path.join(data_dir, "energy.csv")):
        energy(data_dir, out_dir)
    if os.path.exists(os.path.join(data_dir, "dyn_scaling.csv")):
        dynamics(data_dir, out_dir)


if __name__ == "__main__":
    main()
