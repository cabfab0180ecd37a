#!/usr/bin/env python3
"""Instructions per time step, exact and repeatable (valgrind's callgrind), per scene and
integrator: the whole Simulator::step, the bare Stepper::step and the ABA calls inside them; the
overhead is what a step costs beyond its ABA calls.

    python3 scripts/callgrind_step.py [--steps 500] [scene[:integrator] ...]

Runs `se3_dyn simulate --scene config/scenes/SCENE.yaml --integrator I` under callgrind (built
by scripts/build.sh). Only the steps call ABA in that run, so per step
  sim      = Simulator::step inclusive / steps
  stepper  = <Stepper>::step inclusive / steps
  aba      = aba inclusive / steps (all the step's ABA calls)
and overhead = sim - aba (the stepper's share: stepper - aba).
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The catkin workspace of scripts/build.sh (scripts/env.sh): $SE3_SIM_WS, else beside the clone.
WS = os.environ.get("SE3_SIM_WS") or os.path.join(os.path.dirname(REPO), os.path.basename(REPO) + "_ws")
SE3_DYN = os.path.join(WS, "devel/lib/se3_sim/se3_dyn")
DEFAULT = ["fixed_panda:semi_implicit_euler", "fixed_panda:euler", "fixed_panda:rkmk4",
           "satellite_arm:semi_implicit_euler", "satellite_arm:rkmk4",
           "fixed_arm:semi_implicit_euler", "fixed_arm:rkmk4",
           "chain20:semi_implicit_euler", "chain20:rkmk4",
           "pendulum:semi_implicit_euler", "pendulum:rkmk4"]


def inclusive(out_file):
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", out_file],
                          check=True, capture_output=True, text=True).stdout
    counts = {}
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+) \([^)]*\)\s+\S*?:(.*) \[", line)
        if m:
            counts[m.group(2)] = counts.get(m.group(2), 0) + int(m.group(1).replace(",", ""))
    return counts


def pick(counts, pattern):
    return sum(v for k, v in counts.items() if re.search(pattern, k))


def measure(scene, integrator, steps):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cg.out")
        subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out,
                        SE3_DYN, "simulate", "--scene",
                        os.path.join(REPO, "config/scenes", scene + ".yaml"),
                        "--integrator", integrator, "--dt", "0.001",
                        "--duration", str(steps * 0.001)],
                       check=True, capture_output=True)
        c = inclusive(out)
    sim = pick(c, r"^se3::Simulator::step\(\)$")
    stepper = pick(c, r"Stepper::step\(se3::State&")
    aba = pick(c, r"^se3::aba\(")
    return sim / steps, stepper / steps, aba / steps


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("cases", nargs="*", default=DEFAULT)
    a = ap.parse_args()
    print(f"{'scene':15} {'integrator':17} {'sim':>8} {'stepper':>8} {'aba':>8} "
          f"{'overhead':>9} {'of which stepper':>17}")
    for case in a.cases:
        scene, _, integ = case.partition(":")
        sim, st, aba = measure(scene, integ or "semi_implicit_euler", a.steps)
        print(f"{scene:15} {integ:17} {sim:8.0f} {st:8.0f} {aba:8.0f} {sim - aba:9.0f} "
              f"{st - aba:17.0f}")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
