#!/usr/bin/env bash
# Builds se3_sim (Release) in a catkin workspace kept in the ignored .build/ folder (a dot
# folder, so that roslaunch's search of the package folder does not loop through its link).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
ws="$repo/.build/ws"
mkdir -p "$ws/src"
[[ -L "$ws/src/se3_sim" ]] || ln -sfn "$repo" "$ws/src/se3_sim"
cd "$ws"
catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  -j"$(nproc)" "$@" > "$repo/.build/build.log" 2>&1 || { tail -n 60 "$repo/.build/build.log"; echo "se3_sim: build failed (full log: .build/build.log)"; exit 1; }
echo "se3_sim: built in $ws"
