#!/usr/bin/env python3
"""Instructions per call of fk, rnea, aba, crba and minv, exact and repeatable (valgrind's
callgrind), per robot:

    python3 scripts/callgrind_dynamics.py [--subjects ur5,panda7,...] [--algos fk,rnea,...]

Subjects: ur5, panda7, iiwa, pendulum, solo12, solo12_free, romeo_free, chainN, chainN_free (N links).
Algorithms: fk, rnea, aba, crba, minv (the model's route), minv_factor, minv_recursive.

Runs the driver bench/callgrind_dynamics.cpp (built by scripts/build.sh) twice per case, with
8 and 40 calls cycling over the same 16 random states, and prints the difference of the
algorithm's inclusive instruction count divided by 32: what one call costs, with everything done
once (model loading, first-call effects) cancelled out.
"""
import argparse
import os
import re
import subprocess
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The catkin workspace of scripts/build.sh (scripts/env.sh): $SE3_SIM_WS, else beside the clone.
WS = os.environ.get("SE3_SIM_WS") or os.path.join(os.path.dirname(REPO), os.path.basename(REPO) + "_ws")
DRIVER = os.path.join(WS, "devel/lib/se3_sim/callgrind_dynamics")
SUBJECTS = ["ur5", "panda7", "solo12_free", "chain200", "chain200_free"]
ALGOS = ["fk", "rnea", "aba", "crba", "minv"]
FUNCTION = {"fk": r"^se3::forward_kinematics\(", "rnea": r"^se3::rnea\(",
            "aba": r"^se3::aba\(", "crba": r"^se3::crba\(", "minv": r"^se3::minv\(",
            "minv_factor": r"^se3::minv\(", "minv_recursive": r"^se3::minv\("}


def inclusive(out_file, pattern):
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", out_file],
                          check=True, capture_output=True, text=True).stdout
    total = 0
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+) \([^)]*\)\s+\S*?:(.*) \[", line)
        if m and re.search(pattern, m.group(2)):
            total += int(m.group(1).replace(",", ""))
    return total


def count(subject, algo, calls):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cg.out")
        subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out,
                        DRIVER, subject, algo, str(calls)], check=True, capture_output=True)
        return inclusive(out, FUNCTION[algo])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--subjects", default=",".join(SUBJECTS))
    ap.add_argument("--algos", default=",".join(ALGOS))
    a = ap.parse_args()
    algos = a.algos.split(",")
    print(f"{'subject':15}" + "".join(f"{x:>10}" for x in algos))
    for s in a.subjects.split(","):
        row = [(count(s, x, 40) - count(s, x, 8)) / 32 for x in algos]
        print(f"{s:15}" + "".join(f"{r:10.0f}" for r in row), flush=True)


if __name__ == "__main__":
    main()
