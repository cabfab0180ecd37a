#!/usr/bin/env bash
# Installs, from Debian 12's own packages, whatever se3_sim needs that is missing.
# Usage: scripts/deps.sh [--test]   (--test adds the oracles and peers DART, KDL and MuJoCo, and
# valgrind for the instruction counts of bench_peers --callgrind and scripts/callgrind_step.py)
set -euo pipefail
pkgs=(g++ cmake make catkin python3-catkin-pkg libroscpp-dev rosbash
  libstd-msgs-dev ros-std-msgs libstd-srvs-dev ros-std-srvs
  libsensor-msgs-dev ros-sensor-msgs libgeometry-msgs-dev ros-geometry-msgs
  libvisualization-msgs-dev ros-visualization-msgs libros-rosgraph-msgs-dev ros-rosgraph-msgs
  libtf2-ros-dev libtf2-msgs-dev ros-tf2-msgs ros-message-generation
  libtrajectory-msgs-dev ros-trajectory-msgs python3-trajectory-msgs
  liburdfdom-dev libeigen3-dev libcairo2-dev libbenchmark-dev libyaml-cpp-dev
  libassimp-dev libmeshoptimizer-dev libfcl-dev libqhull-dev libtinyxml2-dev libimage-transport-dev libroslib-dev libosmesa6-dev
  python3-rostest librostest-dev libgtest-dev python3-rostopic python3-tf2-msgs python3-sensor-msgs python3-visualization-msgs python3-std-msgs python3-rospy
  python3-rosservice python3-roslaunch python3-std-srvs)
if [[ "${1:-}" == "--test" ]]; then
  pkgs+=(liborocos-kdl-dev libkdl-parser-dev libdart-dev libdart-utils-urdf-dev
    ros-robot-state-publisher libmujoco-dev valgrind
    g++-aarch64-linux-gnu)
  # the sanitizer build and the fuzz targets (scripts/sanitize.sh)
  pkgs+=(clang libclang-rt-14-dev llvm libtinyxml-dev)
fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "se3_sim: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
