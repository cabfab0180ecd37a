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
    "semi_implicit_euler": ("tab:orange", "s"),
    "symplectic_euler": ("tab:orange", "s"),
    "rkmk4": ("tab:blue", "^"),
    "rkmk45": ("tab:purple", "D"),
    "variational": ("tab:green", "v"),
    "rk4_euler_angles": ("tab:brown", "x"),
    "rk4_quaternion": ("tab:gray", "+"),
    # The peers' own integrators (issue 16): dashed.
    "mujoco_euler": ("tab:pink", "P"),
    "mujoco_rk4": ("tab:cyan", "*"),
    "mujoco_implicit": ("tab:olive", "X"),
    "dart_euler": ("black", "d"),
    "contact_semi_implicit": ("tab:orange", "s"),
}
# symplectic_euler is symplectic only for a constant mass matrix: it is the semi-implicit Euler
# step (MuJoCo's name), under either registry name.
LABELS = {
    "semi_implicit_euler": "semi-implicit Euler (ours)",
    "symplectic_euler": "semi-implicit Euler (ours)",
    "euler": "explicit Euler (ours)",
    "rkmk4": "rkmk4 (ours)",
    "rkmk45": "rkmk45 (ours)",
    "variational": "variational (ours)",
    "rk4_euler_angles": "RK4 on Euler angles (ours)",
    "rk4_quaternion": "RK4 on a quaternion (ours)",
    "mujoco_euler": "MuJoCo 2.2 Euler",
    "mujoco_rk4": "MuJoCo 2.2 RK4",
    "mujoco_implicit": "MuJoCo 2.2 implicit",
    "dart_euler": "DART 6.12 semi-implicit Euler",
    "contact_semi_implicit": "se3_sim contact semi-implicit (active set)",
}


def label_of(name):
    return LABELS.get(name, name)


def line_style(name):
    return "--" if name.startswith(("mujoco_", "dart_")) else "-"
TITLES = {
    "free_body": "torque-free axisymmetric body, 10 s (exact solution)",
    "satellite_arm": "7-dof satellite arm, zero gravity, 4 s",
    "chain20_gravity": "20-link chain, fixed base, gravity, 1 s",
    "free_body_tossed": "axisymmetric link tossed under gravity, 4 s (exact solution)",
    "satellite_limits": "satellite arm driven into its joint limits (plastic impacts), 2 s; "
                        "MuJoCo with its own soft limits",
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
        label = label_of(name) + (" (tol 1e-3..1e-11)" if name == "rkmk45" else "")
        if scene == "satellite_limits" and name in ("semi_implicit_euler", "rkmk4", "variational"):
            label += (", velocity-level limits" if name == "semi_implicit_euler"
                      else ", located impacts")
        for ax, key in zip(axes, ("cpu_s", "evals")):
            xs = [num(p[key]) for p in pts]
            ys = [max(num(p["err"]), 1e-16) for p in pts]
            ax.loglog(xs, ys, color=color, marker=marker, label=label, lw=1.3, ms=5,
                      ls=line_style(name))
    axes[0].set_xlabel("CPU time per run [s]")
    axes[1].set_xlabel("dynamics evaluations (ABA calls; mass-matrix solves for variational; "
                       "MuJoCo: forward passes)", fontsize=8)
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
            ax.loglog(xs, ys, color=color, label=label_of(name), lw=1.5)
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


STUDY_TITLES = {
    "planar_chain20": "20-link planar chain (2 m), fixed base, released from rest, gravity, 0.5 s",
    "romeo_free": "Romeo (37 dof) free-floating, zero gravity, random joint rates, 1 s",
}


def speed_curves(ax, rows, names, key):
    """One curve per engine of the study's rows: `key` against speed, each point's step beside it."""
    for name in names:
        pts = [r for r in rows if r["engine"] == name and r["ok"] == "1"
               and math.isfinite(num(r[key]))]
        if not pts:
            continue
        color, marker = STYLE.get(name, ("black", "."))
        ax.loglog([num(p["rtf"]) for p in pts], [max(num(p[key]), 1e-17) for p in pts],
                  color=color, marker=marker, ls=line_style(name), label=label_of(name),
                  lw=1.3, ms=5)
        for p in pts:
            ax.annotate("%g" % num(p["dt"]), (num(p["rtf"]), max(num(p[key]), 1e-17)),
                        fontsize=5, alpha=0.6, xytext=(2, 2), textcoords="offset points")


def study(data_dir, out_dir):
    """The Erez-Tassa-Todorov measures: one chart per measure, speed on the x axis."""
    rows = read(os.path.join(data_dir, "study.csv"))
    models = []
    for r in rows:
        if r["model"] not in models:
            models.append(r["model"])
    measures = [
        ("consistency", "study_consistency.png",
         "consistency: |x(T) - x_ref(T)|, x_ref the same engine at a 16x smaller step",
         "final position difference |log(f_ref^-1 f)| + |q - q_ref|"),
        ("energy_err", "study_energy.png", "energy conservation (no damping, no contact)",
         "max |E(t) - E(0)| / E_scale (T(0); from rest m |g| reach)"),
        ("momentum_err", "study_momentum.png",
         "angular-momentum conservation (free-floating, zero gravity)",
         "max |L(t) - L(0)| / |L(0)|, about the world origin"),
    ]
    for key, fname, title, ylabel in measures:
        panels = [m for m in models if any(math.isfinite(num(r[key])) for r in rows
                                           if r["model"] == m)]
        if not panels:
            continue
        fig, axes = plt.subplots(1, len(panels), figsize=(7.5 * len(panels), 5.6), squeeze=False)
        for ax, model in zip(axes[0], panels):
            names = []
            for r in rows:
                if r["model"] == model and r["engine"] not in names:
                    names.append(r["engine"])
            speed_curves(ax, [r for r in rows if r["model"] == model], names, key)
            ax.set_title(STUDY_TITLES.get(model, model), fontsize=10)
            ax.set_xlabel("speed: simulated seconds per CPU second (steps of 1e-4 .. 1e-2 s)")
            ax.set_ylabel(ylabel)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle("Speed against " + title + "\n(the measures of Erez, Tassa, Todorov, ICRA "
                     "2015; se3_sim, MuJoCo 2.2 and DART 6.12 in one run)", fontsize=11)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, fname), dpi=90)
        plt.close(fig)


def study_contact(data_dir, out_dir):
    """The study's contact scene (bench_contact --study): consistency and penetration, speed on x."""
    rows = read(os.path.join(data_dir, "study_contact.csv"))
    names = []
    for r in rows:
        if r["engine"] not in names:
            names.append(r["engine"])
    panels = [("consistency", "consistency: max |p(T) - p_ref(T)| of a box (m)\n"
               "p_ref: the same engine, 16x smaller step"),
              ("penetration", "deepest penetration over the run (m)")]
    fig, axes = plt.subplots(1, 2, figsize=(15, 5.6), squeeze=False)
    for ax, (key, ylabel) in zip(axes[0], panels):
        speed_curves(ax, rows, names, key)
        ax.set_xlabel("speed: simulated seconds per CPU second (steps of 2.5e-4 .. 4e-3 s)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Contact: a pile of three boxes, the top one thrown (2 m/s, 5 rad/s), 1 s\n"
                 "(the measures of Erez, Tassa, Todorov, ICRA 2015; se3_sim and MuJoCo 2.2 in "
                 "one run)", fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "study_contact.png"), dpi=90)
    plt.close(fig)


def stability(data_dir, out_dir):
    rows = read(os.path.join(data_dir, "stability_panda.csv"))
    path_minv = os.path.join(data_dir, "stability_minv.csv")
    minv = read(path_minv) if os.path.exists(path_minv) else []
    fig, axes = plt.subplots(1, 2 if minv else 1, figsize=(15 if minv else 8, 5.6), squeeze=False)
    ax = axes[0][0]
    names = []
    for r in rows:
        if r["engine"] not in names:
            names.append(r["engine"])
    for name in names:
        pts = [r for r in rows if r["engine"] == name and r["t"]]
        fail = [num(r["failed_at"]) for r in rows if r["engine"] == name and not r["t"]]
        fail = fail[0] if fail and math.isfinite(fail[0]) else None
        color, _ = STYLE.get(name, ("black", "."))
        label = label_of(name) + (" — FAILS at t = %.1f s" % fail if fail else "")
        xs = [num(p["t"]) for p in pts]
        ys = [max(num(p["energy_err"]), 1e-12) for p in pts]
        ax.semilogy(xs, ys, color=color, ls=line_style(name), label=label, lw=1.3)
        if fail:
            ax.plot([fail], [ys[-1] if ys else 1], "x", color=color, ms=12, mew=3)
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("|E(t) - E(0)| [J]")
    ax.set_title("undamped Panda (fingers locked) at 1 kHz, released from its ready pose",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    if minv:
        ax = axes[0][1]
        labels = [r["robot"] + " (%s)" % r["welded"] for r in minv]
        x = range(len(minv))
        ax.bar([i - 0.2 for i in x], [max(num(r["dart_self"]), 1e-17) for r in minv], 0.4,
               color="black", label="DART 6.12: getInvMassMatrix vs getMassMatrix^-1")
        ax.bar([i + 0.2 for i in x], [max(num(r["ours_self"]), 1e-17) for r in minv], 0.4,
               color="tab:blue", label="ours: minv (eqs. 55-63) vs crba^-1")
        ax.set_yscale("log")
        ax.set_xticks(list(x))
        ax.set_xticklabels(labels, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("max |M^-1 - inv(M)| / max |inv(M)| (5 random states)")
        ax.set_title("inverse mass matrix; in brackets: DART bodies welded between moving joints",
                     fontsize=10)
        ax.grid(True, which="both", axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Where methods fail: semi-implicit Euler (MuJoCo's, DART's and ours) blows up; "
                 "DART's inverse mass matrix on welded links")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "stability.png"), dpi=90)
    plt.close(fig)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_charts.py DATA_DIR OUT_DIR")
    data_dir, out_dir = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    for scene in ("free_body", "free_body_tossed", "satellite_arm", "satellite_limits",
                  "chain20_gravity"):
        if os.path.exists(os.path.join(data_dir, "wp_%s.csv" % scene)):
            work_precision(data_dir, out_dir, scene)
    if os.path.exists(os.path.join(data_dir, "energy.csv")):
        energy(data_dir, out_dir)
    if os.path.exists(os.path.join(data_dir, "dyn_scaling.csv")):
        dynamics(data_dir, out_dir)
    if os.path.exists(os.path.join(data_dir, "study.csv")):
        study(data_dir, out_dir)
    if os.path.exists(os.path.join(data_dir, "study_contact.csv")):
        study_contact(data_dir, out_dir)
    if os.path.exists(os.path.join(data_dir, "stability_panda.csv")):
        stability(data_dir, out_dir)


if __name__ == "__main__":
    main()
