#!/usr/bin/env bash
# The whole test suite: installs what is missing (with the DART and KDL oracles), builds, runs
# every GoogleTest and rostest, and ends with one line 'N passed, N failed'. Exit 1 on failure.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
bash "$repo/scripts/deps.sh" --test
# A check of its own (check-deps.xml): every program and python3 module that the scripts, tests
# and launch files call is declared in scripts/deps.txt, and what deps.sh installed is there.
mkdir -p "$repo/.build"
rm -f "$repo/.build/check-deps.xml"
python3 "$repo/scripts/check_deps.py" --junit "$repo/.build/check-deps.xml" || true
bash "$repo/scripts/build.sh"
source "$repo/scripts/env.sh"
ws=$SE3_SIM_WS
rm -rf "$ws/build/test_results" "$repo/.build/check-cross_compile_arm64.xml"
cd "$ws"
echo "se3_sim: building and running the tests (log: .build/test.log)"
# catkin_make run_tests exits 0 even when tests fail: the summary below decides.
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  -j"$(nproc)" tests > "$repo/.build/test.log" 2>&1 || { tail -n 40 "$repo/.build/test.log"; echo "se3_sim: test build failed"; echo "0 passed, 1 failed"; exit 1; }
# The sanitizer build (ASan + UBSan) of the library, its gtests and the fuzz targets, at the
# lowest priority beside the tests below: they leave a core idle much of the time (the rostests
# wait on their nodes), and it gets none while they need both. Then the arm64 cross-compile
# of the library, a check of its own (check-*.xml).
(
  nice -n 19 bash "$repo/scripts/sanitize.sh" --build-only --results "$ws/build/test_results" || true
  echo "se3_sim: arm64 cross-compile of the library (about a minute)"
  nice -n 19 bash "$repo/scripts/cross_compile_arm64.sh" \
    "$repo/.build/check-cross_compile_arm64.xml" > "$repo/.build/cross.log" 2>&1 || true
) &
background=$!
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  -j1 run_tests >> "$repo/.build/test.log" 2>&1 || true
wait "$background" || true
# (written aside: run_tests clears test_results/se3_sim when it starts)
mv -f "$repo/.build/check-cross_compile_arm64.xml" "$repo/.build/check-deps.xml" \
  "$ws/build/test_results/se3_sim/" 2>/dev/null || true
# The sanitizer gtests run, the fuzz corpus replayed and each fuzz target run for a few seconds;
# their results join the others (scripts/sanitize.sh).
bash "$repo/scripts/sanitize.sh" --no-build --results "$ws/build/test_results" || true
python3 "$repo/scripts/test_summary.py" "$ws/build/test_results"
