#!/usr/bin/env bash
# The sanitizer build of the test suite (docs/robustness.md): the library, se3_dyn, the
# GoogleTest binaries and the fuzz targets built with clang, AddressSanitizer (leaks included) and
# UndefinedBehaviorSanitizer in a workspace of their own (.build/san); then the gtests run, the
# fuzz corpus is replayed and each fuzz target runs for a few seconds. Results are JUnit files
# under RESULTS (default .build/san/test_results), counted by scripts/test_summary.py: a
# sanitizer report, a crash or a fuzz finding is a failure.
#
# Usage: scripts/sanitize.sh [--results DIR] [--fuzz-seconds N] [--no-gtests] [--no-fuzz]
#                            [--build-only | --no-build]
# --build-only builds and stops (scripts/test.sh runs it beside the normal build's tests, at the
# lowest priority); --no-build runs what an earlier --build-only built. The gtests and the fuzz
# targets run two at a time (nproc at most).
# Environment: SE3_SANITIZE_GTEST_FILTER (default below) selects the gtest cases.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
results="$repo/.build/san/test_results"
fuzz_seconds=10
run_gtests=1
run_fuzz=1
do_build=1
do_run=1
while (($#)); do
  case "$1" in
    --results) results=$2; shift 2 ;;
    --fuzz-seconds) fuzz_seconds=$2; shift 2 ;;
    --no-gtests) run_gtests=0; shift ;;
    --no-fuzz) run_fuzz=0; shift ;;
    --build-only) do_run=0; shift ;;
    --no-build) do_build=0; shift ;;
    *) echo "usage: scripts/sanitize.sh [--results DIR] [--fuzz-seconds N] [--no-gtests] [--no-fuzz] [--build-only | --no-build]" >&2; exit 2 ;;
  esac
done
# What the Release half of scripts/test.sh runs instead (test/release_gtests.txt): whole binaries
# that cannot run under ASan (the allocation counters replace malloc), and the long runs (tens to
# hundreds of simulated seconds: 10 s to 4 min each under ASan + UBSan; docs/robustness.md).
slow=""
release_only=()
while read -r name cases; do
  [[ -z $name || $name == \#* ]] && continue
  if [[ -n $cases ]]; then slow+="${slow:+:}$cases"; else release_only+=("$name"); fi
done < "$repo/test/release_gtests.txt"
filter=${SE3_SANITIZE_GTEST_FILTER:-"-$slow"}

# The sanitizer workspace lives beside the clone, as the main one does (scripts/env.sh): inside,
# its link back to the package would be a loop for rosrun's search of the package folder.
ws="${SE3_SIM_SAN_WS:-$(dirname "$repo")/$(basename "$repo")_san_ws}"
mkdir -p "$ws/src" "$results" "$repo/.build/san"
# Earlier versions kept it in .build/san/ws, linked back to the clone: the loop goes.
[[ -L "$repo/.build/san/ws/src/se3_sim" ]] && rm -rf "$repo/.build/san/ws"
[[ -L "$ws/src/se3_sim" ]] || ln -sfn "$repo" "$ws/src/se3_sim"
log="$repo/.build/san/build.log"
san="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"

gtests=()
for f in "$repo"/test/gtest_*.cpp; do
  t=$(basename "$f" .cpp)
  [[ " ${release_only[*]} " == *" $t "* ]] && continue
  gtests+=("$t")
done
fuzzers=()
for f in "$repo"/fuzz/fuzz_*.cpp; do fuzzers+=("$(basename "$f" .cpp)"); done
# Seed corpora: fuzz/corpus/NAME (small inputs and every crasher found), and the project's own
# files of that kind.
declare -A seeds=([urdf]="data/robots config/robots" [scene]="config/scenes"
  [controllers]="config/controllers")

t0=$(date +%s)
ok_mark="$repo/.build/san/build.ok"
if ((do_build)); then
rm -f "$ok_mark"
echo "se3_sim: sanitizer build (clang, ASan + UBSan) in $ws (log: .build/san/build.log)"
cd "$ws"
# RelWithDebInfo at -O1 with line tables and assertions on (Eigen's index checks included):
# fast enough to run the suite, slow enough to keep stack traces exact. SE3_SIM_NO_FORCED_INLINE:
# the dynamics kernels are inlined where the compiler chooses (forced, aba.cpp alone takes 80 s
# to compile under the sanitizers; the checks see the same code either way).
catkin_make -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DSE3_SIM_NO_FORCED_INLINE" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DCMAKE_CXX_FLAGS="$san" -DCMAKE_C_FLAGS="$san" \
  -DCMAKE_EXE_LINKER_FLAGS="$san" -DCMAKE_SHARED_LINKER_FLAGS="$san" \
  -DSE3_SIM_FUZZ=ON -DCATKIN_ENABLE_TESTING=ON -DSE3_SIM_UNITY=ON \
  -DCMAKE_CXX_COMPILER_LAUNCHER= -DCMAKE_C_COMPILER_LAUNCHER= \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  -j"$(nproc)" se3_sanitize_all > "$log" 2>&1 || {
  tail -n 40 "$log"
  echo "se3_sim: sanitizer build failed (log: .build/san/build.log)"
  mkdir -p "$results"
  echo '<testsuites><testsuite name="sanitize"><testcase classname="sanitize" name="build"><failure message="the sanitizer build failed: .build/san/build.log"/></testcase></testsuite></testsuites>' > "$results/gtest-sanitize_build.xml"
  exit 1
}
touch "$ok_mark"
fi
# --no-build after a failed --build-only: the failure is reported already.
[[ -f $ok_mark ]] || { echo "se3_sim: no sanitizer build to run (see .build/san/build.log)"; exit 1; }
t1=$(date +%s)
((do_build)) && echo "se3_sim: sanitizer build took $((t1 - t0)) s"
((do_run)) || exit 0
bin="$ws/devel/lib/se3_sim"
# The sanitized libraries, not those of the main build that env.sh put on LD_LIBRARY_PATH (which
# wins over the binaries' RUNPATH): uninstrumented libraries give the fuzzers no coverage and the
# gtests unchecked code.
export LD_LIBRARY_PATH="$ws/devel/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"

# A JUnit file of one failing case (for test_summary.py).
fail_xml() {  # file suite case message
  local msg=${4//&/&amp;}
  msg=${msg//</&lt;}
  msg=${msg//>/&gt;}
  msg=${msg//\"/&quot;}
  printf '<testsuites><testsuite name="%s"><testcase classname="%s" name="%s"><failure message="%s"/></testcase></testsuite></testsuites>\n' \
    "$1" "$1" "$2" "$msg" > "$3"
}
pass_xml() {  # file suite case
  printf '<testsuites><testsuite name="%s"><testcase classname="%s" name="%s"/></testsuite></testsuites>\n' "$1" "$1" "$2" > "$3"
}

export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$repo/fuzz/lsan.supp:print_suppressions=0"
out="$results/sanitize"
mkdir -p "$out"
rm -f "$out"/*.xml "$out"/*.log

# Runs at most $par of the jobs started with throttle at once.
par=$(( $(nproc) < 2 ? $(nproc) : 2 ))
throttle() {
  while (($(jobs -rp | wc -l) >= par)); do wait -n || true; done
}

san_gtest() {  # name
  local t=$1 xml="$out/gtest-sanitize_$1.xml" code=0 reason
  (cd "$repo" && "$bin/$t" --gtest_filter="$filter" --gtest_output="xml:$xml") \
    > "$out/$t.log" 2>&1 || code=$?
  if ((code != 0)); then
    reason=$(grep -m1 -E "ERROR: (Address|Leak)Sanitizer|runtime error:|FAILED" "$out/$t.log" || true)
    fail_xml "sanitize_$t" "exit_code" "$out/gtest-sanitize_${t}_exit.xml" \
      "$t exited $code under the sanitizers: ${reason:-see $out/$t.log}"
    echo "  $t: exit $code ${reason}"
  fi
}

san_fuzz() {  # fuzz_NAME
  local f=$1 name=${1#fuzz_} code=0 runs
  local dirs=("$repo/fuzz/corpus/$name") extra
  for extra in ${seeds[$name]:-}; do dirs+=("$repo/$extra"); done
  local art="$repo/.build/san/fuzz-artifacts/$name"
  local scratch="$repo/.build/san/fuzz-scratch/$name"
  rm -rf "$scratch"
  mkdir -p "$art" "$scratch"
  # 30 s an input counts as a hang: the suite runs this at nice 19 beside other work, where an
  # input of 4.4 s under ASan on an idle core (a 102 kB OBJ fan through assimp) passed 10 s.
  local opts=(-timeout=30 -rss_limit_mb=2048 -artifact_prefix="$art/" -print_final_stats=1)
  [[ -f "$repo/fuzz/$name.dict" ]] && opts+=(-dict="$repo/fuzz/$name.dict")
  "$bin/$f" "${opts[@]}" -runs=0 "${dirs[@]}" > "$out/$f.replay.log" 2>&1 || code=$?
  if ((code != 0)); then
    fail_xml "fuzz_$name" "corpus_replay" "$out/gtest-fuzz_${name}_replay.xml" \
      "$f on its corpus exited $code: $(grep -m1 -E 'ERROR|runtime error|deadly' "$out/$f.replay.log")"
    echo "  $f corpus replay: exit $code"
  else
    pass_xml "fuzz_$name" "corpus_replay" "$out/gtest-fuzz_${name}_replay.xml"
  fi
  ((fuzz_seconds > 0)) || return 0
  code=0
  "$bin/$f" "${opts[@]}" -seed=1 -max_total_time="$fuzz_seconds" "$scratch" "${dirs[@]}" \
    > "$out/$f.run.log" 2>&1 || code=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$out/$f.run.log")
  if ((code != 0)); then
    fail_xml "fuzz_$name" "bounded_run" "$out/gtest-fuzz_${name}_run.xml" \
      "$f found an input (exit $code, artifact in $art): $(grep -m1 -E 'ERROR|runtime error|deadly|timeout' "$out/$f.run.log")"
    echo "  $f: exit $code after ${runs:-?} runs"
  else
    pass_xml "fuzz_$name" "bounded_run" "$out/gtest-fuzz_${name}_run.xml"
    echo "  $f: ${runs:-?} runs in ${fuzz_seconds} s, nothing found"
  fi
}

if ((run_gtests)); then
  echo "se3_sim: gtests under ASan + UBSan, $par at a time (filter '$filter')"
  for t in "${gtests[@]}"; do
    throttle
    san_gtest "$t" &
  done
  wait
  t2=$(date +%s)
  echo "se3_sim: sanitizer gtests took $((t2 - t1)) s"
else
  t2=$t1
fi

if ((run_fuzz)); then
  echo "se3_sim: fuzz corpus replay and ${fuzz_seconds} s per fuzz target, $par at a time"
  for f in "${fuzzers[@]}"; do
    throttle
    san_fuzz "$f" &
  done
  wait
fi
t3=$(date +%s)
echo "se3_sim: sanitizer stage: build $((t1 - t0)) s, gtests $((t2 - t1)) s, fuzz $((t3 - t2)) s"
