#!/usr/bin/env bash
# Regenerates every chart of docs/charts/ from scratch (issues 6 and 16): runs charts_data (CSV
# data and printed fits: orders, slopes, scaling exponents) and plots it with Debian's
# python3-matplotlib. The work-precision charts hold MuJoCo 2.2's and DART 6.12's integrators
# beside ours; study_*.png reproduce the measures of Erez, Tassa and Todorov (ICRA 2015) with
# se3_sim, MuJoCo and DART in one run; stability.png shows where methods fail (docs/peers.md).
# Installs what is missing (scripts/deps.sh --charts: the peers MuJoCo and DART, and
# python3-matplotlib) and builds
# first; CHARTS_BIN overrides where charts_data is (then nothing is built).
# Usage: scripts/charts.sh [--quick] [--only work|limits|energy|dynamics|study|stability]
#   (--quick: shorter runs, for a smoke test; --only: one part, the other charts are left as
#   they are)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
if [[ -z "${CHARTS_BIN:-}" ]]; then
  bash "$repo/scripts/deps.sh" --charts
  bash "$repo/scripts/build.sh"
fi
source "$repo/scripts/env.sh"  # SE3_SIM_WS, the workspace
bin=${CHARTS_BIN:-$SE3_SIM_WS/devel/lib/se3_sim/charts_data}
[[ -x "$bin" ]] || { echo "charts: $bin not found; build first (bash scripts/build.sh)"; exit 1; }
/usr/bin/python3 -c 'import matplotlib' 2>/dev/null ||
  { echo "charts: python3-matplotlib missing (apt-get install python3-matplotlib)"; exit 1; }
data="$repo/.build/charts"
rm -rf "$data"
mkdir -p "$data" "$repo/docs/charts"
start=$(date +%s)
"$bin" "$data" --root "$repo" "$@" | tee "$data/summary.txt"
# The study's contact scene comes from bench_contact (MuJoCo beside ours), with --only study or all.
contact_bin=$(dirname "$bin")/bench_contact
case " $* " in
  *" --only "*) [[ " $* " == *" --only study "* ]] && want_contact=1 || want_contact=0 ;;
  *) want_contact=1 ;;
esac
if ((want_contact)); then
  if [[ -x "$contact_bin" ]]; then
    "$contact_bin" --study "$data/study_contact.csv" | tee -a "$data/summary.txt"
  else
    echo "charts: $contact_bin not found; the contact study is left out"
  fi
fi
/usr/bin/python3 "$repo/scripts/plot_charts.py" "$data" "$repo/docs/charts"
echo "charts: docs/charts/*.png written in $(( $(date +%s) - start )) s (data and summary in $data)"
