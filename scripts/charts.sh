#!/usr/bin/env bash
# Regenerates every chart of docs/charts/ from scratch (issue 6): runs charts_data (CSV data and
# printed fits: orders, slopes, scaling exponents) and plots it with Debian's python3-matplotlib.
# Assumes the package is built (scripts/build.sh); CHARTS_BIN overrides where charts_data is.
# Usage: scripts/charts.sh [--quick]    (--quick: shorter runs, for a smoke test)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
bin=${CHARTS_BIN:-$repo/.build/ws/devel/lib/se3_sim/charts_data}
[[ -x "$bin" ]] || { echo "charts: $bin not found; build first (bash scripts/build.sh)"; exit 1; }
/usr/bin/python3 -c 'import matplotlib' 2>/dev/null ||
  { echo "charts: python3-matplotlib missing (apt-get install python3-matplotlib)"; exit 1; }
data="$repo/.build/charts"
rm -rf "$data"
mkdir -p "$data" "$repo/docs/charts"
start=$(date +%s)
"$bin" "$data" --root "$repo" "$@" | tee "$data/summary.txt"
/usr/bin/python3 "$repo/scripts/plot_charts.py" "$data" "$repo/docs/charts"
echo "charts: docs/charts/*.png written in $(( $(date +%s) - start )) s (data and summary in $data)"
