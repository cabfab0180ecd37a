#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs the simulator with the renderer on
# the default scene (a free-floating Panda arm on a satellite in zero gravity), headless.
#   scripts/main.sh            run until Ctrl-C
#   scripts/main.sh 30         run for 30 s, then stop (and save the last rendered frame)
# Extra roslaunch arguments may follow the duration, e.g. scripts/main.sh 30 scene:=<yaml>.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
bash "$repo/scripts/deps.sh"
bash "$repo/scripts/build.sh"
source "$repo/scripts/env.sh"
duration=""
if [[ $# -gt 0 && "$1" =~ ^[0-9]+$ ]]; then duration=$1; shift; fi
echo "se3_sim: roslaunch se3_sim demo.launch $*"
echo "se3_sim: topics joint_states, /tf, chain_state, sim_stats, renderer/image (1280x1024 rgb8);"
echo "         view with: rosrun image_view image_view image:=/renderer/image"
if [[ -n "$duration" ]]; then
  roslaunch se3_sim demo.launch "$@" &
  pid=$!
  sleep "$duration"
  # std_srvs/Trigger: the message is the PNG written (a new file, never over an earlier one).
  saved=$(rosservice call /renderer/save_frame 2>/dev/null | sed -n 's/^message: *"\{0,1\}\([^"]*\)"\{0,1\}$/\1/p') || true
  [[ -n "${saved:-}" ]] && echo "se3_sim: last frame saved as $saved" || true
  kill -INT "$pid" 2>/dev/null || true
  wait "$pid" || true
else
  exec roslaunch se3_sim demo.launch "$@"
fi
