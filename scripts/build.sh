#!/usr/bin/env bash
# Builds se3_sim (Release) in its catkin workspace: $SE3_SIM_WS, else the folder beside the
# clone named after it with _ws (scripts/env.sh). Extra arguments go to catkin_make.
# Log: .build/build.log in the clone.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
source "$repo/scripts/env.sh"
ws=$SE3_SIM_WS
case "$ws/" in
  "$repo"/*) echo "se3_sim: the workspace $ws is inside the package folder $repo; rosrun and roslaunch would loop through its link back (set SE3_SIM_WS elsewhere)"; exit 1 ;;
esac
# The workspace of earlier versions lived in .build/ws, linked back to the clone: a loop for
# every search of the package folder. It is rebuilt outside; drop the old one.
if [[ -L "$repo/.build/ws/src/se3_sim" ]]; then
  echo "se3_sim: removing the old in-clone workspace .build/ws (now $ws)"
  rm -rf "$repo/.build/ws"
fi
mkdir -p "$ws/src" "$repo/.build"
if [[ "$(readlink "$ws/src/se3_sim" 2>/dev/null)" != "$repo" ]]; then
  [[ -e "$ws/src/se3_sim" && ! -L "$ws/src/se3_sim" ]] &&
    { echo "se3_sim: $ws/src/se3_sim exists and is not a link to $repo"; exit 1; }
  ln -sfn "$repo" "$ws/src/se3_sim"
fi
# catkin writes the tests' environment (build/catkin_generated/setup_cached.sh, which ctest's
# rostests run in) when it configures, with only the folders that exist then. The generated
# python messages' folder appears later, during the build, so a first configure would leave
# PYTHONPATH empty there and every rostest that imports se3_sim.msg fail with "No module named
# 'se3_sim'". Make it first; refresh a workspace configured without it.
py="$ws/devel/lib/python3/dist-packages"
mkdir -p "$py"
cached="$ws/build/catkin_generated/setup_cached.sh"
if [[ -f $cached ]] && ! grep -q "$py" "$cached"; then
  /usr/bin/python3 "$ws/build/catkin_generated/generate_cached_setup.py" > /dev/null
fi
cd "$ws"
catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  -j"$(nproc)" "$@" > "$repo/.build/build.log" 2>&1 || { tail -n 60 "$repo/.build/build.log"; echo "se3_sim: build failed (full log: .build/build.log)"; exit 1; }
echo "se3_sim: built in $ws (in a new shell: source scripts/env.sh)"
