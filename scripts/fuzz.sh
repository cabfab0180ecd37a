#!/usr/bin/env bash
# Long fuzzing campaigns (docs/robustness.md): builds the fuzz targets (scripts/sanitize.sh's
# build, ASan + UBSan), then runs each named target (default: all) for SECONDS, niced, on a
# corpus kept between campaigns in .build/san/fuzz-corpus/NAME and seeded from fuzz/corpus/NAME
# and the project's own files. Crashes, leaks, timeouts (> 10 s) and out-of-memory inputs land in
# .build/san/fuzz-artifacts/NAME/ (crash-*, leak-*, timeout-*, oom-*); a found input goes into
# fuzz/corpus/NAME once fixed, so the suite's replay keeps it fixed.
#
# Usage: scripts/fuzz.sh [--seconds N] [--no-build] [TARGET ...]   e.g. --seconds 3600 urdf scene
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
seconds=600
build=1
targets=()
while (($#)); do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) targets+=("$1"); shift ;;
  esac
done
if ((${#targets[@]} == 0)); then
  for f in "$repo"/fuzz/fuzz_*.cpp; do n=$(basename "$f" .cpp); targets+=("${n#fuzz_}"); done
fi
((build)) && bash "$repo/scripts/sanitize.sh" --no-gtests --no-fuzz
bin="${SE3_SIM_SAN_WS:-$(dirname "$repo")/$(basename "$repo")_san_ws}/devel/lib/se3_sim"
declare -A seeds=([urdf]="data/robots config/robots" [scene]="config/scenes"
  [controllers]="config/controllers")
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$repo/fuzz/lsan.supp:print_suppressions=0"
printf '%-8s %12s %8s %8s %8s %8s  %s\n' target runs crashes leaks timeouts ooms corpus
for name in "${targets[@]}"; do
  corpus="$repo/.build/san/fuzz-corpus/$name"
  art="$repo/.build/san/fuzz-artifacts/$name"
  mkdir -p "$corpus" "$art"
  dirs=("$corpus" "$repo/fuzz/corpus/$name")
  for extra in ${seeds[$name]:-}; do dirs+=("$repo/$extra"); done
  opts=(-timeout=10 -rss_limit_mb=2048 -artifact_prefix="$art/" -print_final_stats=1
        -max_total_time="$seconds")
  [[ -f "$repo/fuzz/$name.dict" ]] && opts+=(-dict="$repo/fuzz/$name.dict")
  log="$repo/.build/san/fuzz-$name.log"
  touch "$log.start"  # findings are the artifacts newer than this
  # -fork runs inputs in child processes and goes on after a finding (-ignore_crashes etc.),
  # so one campaign reports every distinct problem instead of stopping at the first.
  nice -n 10 "$bin/fuzz_$name" "${opts[@]}" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 \
    -ignore_ooms=1 "${dirs[@]}" > "$log" 2>&1 || true
  runs=$(grep -oE '#[0-9]+' "$log" | tail -1 | tr -d '#' || true)
  count() { find "$art" -name "$1-*" -newer "$log.start" | wc -l; }
  printf '%-8s %12s %8s %8s %8s %8s  %s\n' "$name" "${runs:-?}" "$(count crash)" "$(count leak)" \
    "$(count timeout)" "$(count oom)" "$(find "$corpus" -type f | wc -l) inputs"
done
