#!/usr/bin/env bash
# Compiles the library's lie, model, dynamics and integrate layers for arm64 with Debian's
# cross compiler (g++-aarch64-linux-gnu; compile only, -O1), once as they are (GCC's vector
# extensions on NEON, no x86 intrinsics) and the SIMD-paired files once more with their scalar
# fallback (SE3_SIM_SCALAR_PAIRS). A check of scripts/test.sh: with a file argument it writes one
# JUnit test case there (check-*.xml, counted by scripts/test_summary.py).
#   scripts/cross_compile_arm64.sh [RESULT.xml]
set -uo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
result=${1:-}
cxx=aarch64-linux-gnu-g++
start=$(date +%s)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
log="$tmp/log"
: > "$log"

# urdfdom and console_bridge headers are the same for every architecture; /usr/include itself
# holds x86-64 C library headers, so only these directories are given to the cross compiler
# (in a folder of the clone, whose path ccache hashes relative to the clone's parent).
inc="$repo/.build/arm64-include"
mkdir -p "$inc"
for h in urdf_parser urdf_model urdf_world urdf_sensor urdf_exception urdf_model_state \
  console_bridge console_bridge_export.h; do
  [[ -e /usr/include/$h ]] && ln -sfn "/usr/include/$h" "$inc/$h"
done
# ccache, when installed, serves what an earlier run (of any clone beside this one) compiled.
launcher=""
command -v ccache > /dev/null &&
  launcher="env CCACHE_BASEDIR=$(dirname "$repo") CCACHE_NOHASHDIR=1 ccache"

status=0
if ! command -v "$cxx" > /dev/null; then
  echo "$cxx is not installed (scripts/deps.sh --test installs g++-aarch64-linux-gnu)" >> "$log"
  status=1
elif ! command -v file > /dev/null; then
  echo "file is not installed (scripts/deps.sh --test installs file)" >> "$log"
  status=1
else
  cd "$repo"
  jobs=()
  for f in src/lie/*.cpp src/model/*.cpp src/dynamics/*.cpp src/integrate/*.cpp; do
    jobs+=("$f|")
  done
  # The files with SIMD-paired kernels (lie/simd.h's v2d), once more on scalar pairs.
  for f in src/dynamics/sincos.cpp src/dynamics/crba.cpp; do
    jobs+=("$f|-DSE3_SIM_SCALAR_PAIRS")
  done
  printf '%s\n' "${jobs[@]}" | xargs -P "$(nproc)" -I{} bash -c '
    f=${1%%|*}; def=${1#*|}
    o="$2/$(echo "$f$def" | tr "/=" "__").o"
    if ! out=$('"$launcher $cxx"' -std=gnu++17 -O1 -Wall -Wextra -Wno-psabi $def -Iinclude -Isrc \
        -isystem /usr/include/eigen3 -isystem '"$inc"' -c "$f" -o "$o" 2>&1); then
      printf "FAILED %s %s\n%s\n" "$f" "$def" "$out" >> "$2/log"
    else
      printf "ok %s %s\n" "$f" "$def" >> "$2/ok"
      [[ -n $out ]] && printf "warnings %s %s\n%s\n" "$f" "$def" "$out" >> "$2/log"
    fi' _ {} "$tmp"
  grep -q "^FAILED" "$log" && status=1
  if ((status == 0)); then
    # The objects are arm64 code.
    obj=$(ls "$tmp"/*.o | head -1)
    file "$obj" | grep -q "aarch64" || { echo "not arm64 objects: $(file "$obj")" >> "$log"; status=1; }
  fi
fi
elapsed=$(($(date +%s) - start))
ok=$(cat "$tmp/ok" 2> /dev/null | wc -l)
cat "$log"
echo "arm64 cross-compile: $ok files compiled, $( ((status)) && echo failed || echo passed) in ${elapsed} s"
if [[ -n $result ]]; then
  mkdir -p "$(dirname "$result")"
  {
    echo '<?xml version="1.0" encoding="UTF-8"?>'
    echo "<testsuite name=\"cross_compile_arm64\" tests=\"1\" failures=\"$status\">"
    echo "  <testcase classname=\"CrossCompile\" name=\"Arm64LieModelDynamicsIntegrate\" time=\"$elapsed\">"
    if ((status)); then
      msg=$(grep -m1 -v "^ok" "$log" | sed 's/&/\&amp;/g; s/</\&lt;/g; s/>/\&gt;/g; s/"/\&quot;/g')
      echo "    <failure message=\"$msg\"><![CDATA["
      sed 's/]]>/]] >/g' "$log"
      echo "]]></failure>"
    fi
    echo "  </testcase>"
    echo "</testsuite>"
  } > "$result"
fi
exit $status
