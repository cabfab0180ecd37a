#!/usr/bin/env bash
# ccache for clang (CMakeLists.txt, the sanitizer build): the paths that follow -Xclang (the
# precompiled header CMake passes as "-Xclang -include-pch -Xclang FILE") made relative to the
# working directory, as ccache itself makes every other path below its base dir. ccache leaves
# what follows -Xclang as it is, and an absolute path there would make every compile that uses
# the header a miss in another clone's workspace.
# Usage: ccache_clang.sh CCACHE COMPILER ARGS...
ccache=$1
shift
args=()
prev=
for a in "$@"; do
  if [[ $prev == -Xclang && -n ${CCACHE_BASEDIR:-} && $a == "$CCACHE_BASEDIR"/* ]]; then
    args+=("$(realpath -s --relative-to=. "$a")")
  else
    args+=("$a")
  fi
  prev=$a
done
exec "$ccache" "${args[@]}"
