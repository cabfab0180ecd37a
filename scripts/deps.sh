#!/usr/bin/env bash
# Installs, from Debian 12's own packages, whatever se3_sim needs that is missing: the packages of
# scripts/deps.txt (one line per program, python3 module, ROS package or library, with its level).
# Usage: scripts/deps.sh [--test | --charts]
#   (no option: the build and scripts/main.sh; --test adds what scripts/test.sh and its tests
#   call: the oracles and peers DART, KDL and MuJoCo, valgrind, iproute2, file, the arm64 cross
#   compiler and clang for the sanitizer build; --charts adds python3-matplotlib to --test's)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
case "${1:-}" in
  "") levels=" base " ;;
  --test) levels=" base test " ;;
  --charts) levels=" base test charts " ;;
  *) echo "usage: scripts/deps.sh [--test | --charts]" >&2; exit 2 ;;
esac
pkgs=()
declare -A seen=()
while read -r level kind name pkg rest; do
  [[ -z $level || $level == \#* ]] && continue
  [[ -n $pkg && -z $rest ]] || { echo "scripts/deps.txt: bad line '$level $kind $name $pkg $rest'" >&2; exit 1; }
  [[ $levels == *" $level "* && -z ${seen[$pkg]:-} ]] || continue
  seen[$pkg]=1
  pkgs+=("$pkg")
done < "$repo/scripts/deps.txt"
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
