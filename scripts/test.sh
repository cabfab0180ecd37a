#!/usr/bin/env bash
# The whole test suite: installs what is missing (with the DART and KDL oracles), builds, runs
# every GoogleTest and rostest, and ends with one line 'N passed, N failed'. Exit 1 on failure.
#
# Two streams share the two cores. In front, at normal priority: the Release build of what the
# tests run, its tests' build, then the rostests one at a time with the Release gtests
# (test/release_gtests.txt) one at a time beside them and then the rest of the Release build
# (nice 10: the rostests wait on their nodes and keep the priority). Behind, at
# nice 19 from the start: the sanitizer build (scripts/sanitize.sh), every other gtest case and
# the fuzz targets as soon as it is built, then the arm64 cross-compile. Each gtest case runs
# once, in one of the two builds. The front's single-threaded stretches (configuring,
# message generation, links, the rostests' waits) are the back's CPU. Stage times go to the
# output and to .build/test_times.txt.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
t0=$(date +%s)
times="$repo/.build/test_times.txt"
stage() {  # name start: one line of stage times
  local line
  line=$(printf '%-44s %5d s (at %5d s)' "$1" $(($(date +%s) - $2)) $(($(date +%s) - t0)))
  echo "se3_sim: $line"
  echo "$line" >> "$times"
}
bash "$repo/scripts/deps.sh" --test
mkdir -p "$repo/.build"
: > "$times"
stage "deps.sh" "$t0"
ws=${SE3_SIM_WS:-$(dirname "$repo")/$(basename "$repo")_ws}
results="$ws/build/test_results"
built="$repo/.build/release-built"  # written once the Release build is there
rm -rf "$results" "$built" "$repo/.build/check-cross_compile_arm64.xml" "$repo/.build/check-deps.xml" \
  "$repo/.build/check-test_env.xml" "$repo/.build/check-build_all.xml"
mkdir -p "$results"

# Behind: the sanitizer build (ASan + UBSan) of the library, its gtests and the fuzz targets,
# then their run (the gtests, the fuzz corpora replayed and each fuzz target for a few seconds;
# scripts/fuzz.sh runs the long campaigns), then the arm64 cross-compile of the library, a check
# of its own (check-*.xml). Everything at the lowest priority.
set -m  # the stream is a process group of its own, to be stopped whole if the front fails
(
  s=$(date +%s)
  if nice -n 19 bash "$repo/scripts/sanitize.sh" --build-only --results "$results" \
      > "$repo/.build/san-build.out" 2>&1; then
    stage "sanitizer build (nice 19)" "$s"
    # The run needs the environment of the Release build (scripts/env.sh: ROS_PACKAGE_PATH, the
    # meshes' package path): it waits for that build.
    while [[ ! -f $built ]]; do sleep 2; done
    source "$repo/scripts/env.sh"
    s=$(date +%s)
    nice -n 19 bash "$repo/scripts/sanitize.sh" --no-build --fuzz-seconds 3 --results "$results" \
      > "$repo/.build/san-run.out" 2>&1 || true
    stage "sanitizer gtests and fuzzing (nice 19)" "$s"
  else
    stage "sanitizer build (nice 19): failed" "$s"
  fi
  s=$(date +%s)
  nice -n 19 bash "$repo/scripts/cross_compile_arm64.sh" \
    "$repo/.build/check-cross_compile_arm64.xml" > "$repo/.build/cross.log" 2>&1 || true
  stage "arm64 cross-compile (nice 19)" "$s"
) &
background=$!
set +m
# Interrupted: the stream goes too (it is not in the terminal's process group).
trap 'kill -- -"$background" 2> /dev/null; exit 130' INT TERM

# A check of its own (check-deps.xml): every program and python3 module that the scripts, tests
# and launch files call is declared in scripts/deps.txt, and what deps.sh installed is there.
s=$(date +%s)
python3 "$repo/scripts/check_deps.py" --junit "$repo/.build/check-deps.xml" || true
stage "check_deps.py" "$s"
s=$(date +%s)
# First what the tests run (target se3_runtime: the nodes, se3_dyn, the messages); the rest of the
# build (benchmarks, peers, charts) beside the rostests.
bash "$repo/scripts/build.sh" se3_runtime || { kill -- -"$background" 2> /dev/null || true; echo "0 passed, 1 failed"; exit 1; }
stage "build.sh se3_runtime (Release)" "$s"
touch "$built"
source "$repo/scripts/env.sh"
cd "$ws"
echo "se3_sim: building and running the tests (log: .build/test.log)"
# The arguments of scripts/build.sh, so that catkin_make does not configure again.
s=$(date +%s)
catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  -j"$(nproc)" se3_release_tests > "$repo/.build/test.log" 2>&1 || {
  tail -n 40 "$repo/.build/test.log"
  echo "se3_sim: test build failed"
  kill -- -"$background" 2> /dev/null || true
  echo "0 passed, 1 failed"
  exit 1
}
stage "tests build (Release)" "$s"
# A check of its own (check-test_env.xml): the rostests' environment imports the messages.
python3 "$repo/scripts/check_deps.py" --test-env "$ws" --junit "$repo/.build/check-test_env.xml" || true
# catkin's test wrappers (run_tests.py through ctest: each writes its JUnit file, or a
# MISSING-*.xml when the test wrote none). The rostests one at a time; beside them, niced, the
# gtests of test/release_gtests.txt one at a time (each with its filter: GoogleTest reads
# GTEST_FILTER), while every other gtest case runs in the sanitizer stream.
s=$(date +%s)
cd "$ws/build"
(
  : > "$repo/.build/gtest.log"
  while read -r name cases; do
    [[ -z $name || $name == \#* ]] && continue
    GTEST_FILTER=${cases:-*} nice -n 10 ctest --output-on-failure -R "^_ctest_se3_sim_gtest_${name}\$" \
      >> "$repo/.build/gtest.log" 2>&1 || true
  done < "$repo/test/release_gtests.txt"
  stage "gtests (Release, nice 10)" "$s"
  # A check of its own (check-build_all.xml): the rest of the Release build compiles.
  b=$(date +%s)
  if nice -n 10 catkin_make -C "$ws" -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      -DPython3_EXECUTABLE=/usr/bin/python3 -j"$(nproc)" > "$repo/.build/build_all.log" 2>&1; then
    echo '<testsuites><testsuite name="Build"><testcase classname="Build" name="EverythingElseCompiles"/></testsuite></testsuites>' \
      > "$repo/.build/check-build_all.xml"
  else
    echo '<testsuites><testsuite name="Build"><testcase classname="Build" name="EverythingElseCompiles"><failure message="the Release build of the benchmarks, peers and charts failed: .build/build_all.log"/></testcase></testsuite></testsuites>' \
      > "$repo/.build/check-build_all.xml"
  fi
  stage "the rest of the build (Release, nice 10)" "$b"
) &
gtests=$!
ctest --output-on-failure -R '^_ctest_se3_sim_rostest_' >> "$repo/.build/test.log" 2>&1 || true
stage "rostests" "$s"
wait "$gtests" || true
s=$(date +%s)
wait "$background" || true
stage "waiting for the sanitizer stream" "$s"
mv -f "$repo/.build/check-cross_compile_arm64.xml" "$repo/.build/check-deps.xml" \
  "$repo/.build/check-test_env.xml" "$repo/.build/check-build_all.xml" \
  "$results/se3_sim/" 2> /dev/null || true
cat "$repo/.build/san-build.out" "$repo/.build/san-run.out" 2> /dev/null || true
stage "total" "$t0"
python3 "$repo/scripts/test_summary.py" "$results"
