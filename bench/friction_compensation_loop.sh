#!/usr/bin/env bash
# The friction compensation's loop (docs/friction_compensation.md): run a
# protocol, identify its friction with tribo-fit, compensate with the result,
# run again, and report before and after. Run from the repository's root after
# scripts/build (tribod, tribo, tribo-fit, friction_compensation_figures).
#
#   bench/friction_compensation_loop.sh [OUT_DIR] [--config FILE]
#
# OUT_DIR (default runs/compensation-loop, refused if it exists) receives:
# identification/ (the run identified), model.json (tribo-fit's report),
# before/ and after/ (breakaway_velocities.textproto without and with
# --friction-model model.json), figures.txt (before and after from those
# records), friction_compensation.png (the plot).
set -euo pipefail
cd "$(dirname "$0")/.."
out=runs/compensation-loop
config=config/tribod.textproto
while [ $# -gt 0 ]; do
  case "$1" in
    --config) config=$2; shift 2 ;;
    *) out=$1; shift ;;
  esac
done
if [ -e "$out" ]; then echo "$out exists; give another OUT_DIR" >&2; exit 2; fi
mkdir -p "$out"

build/daemon/tribod --config "$config" --port 0 --data-dir "$out/daemon" >"$out/tribod.out" 2>"$out/tribod.log" &
tribod=$!
trap 'kill $tribod 2>/dev/null; wait $tribod 2>/dev/null || true' EXIT
for _ in $(seq 100); do grep -q listening "$out/tribod.out" && break; sleep 0.1; done
export TRIBO_ADDRESS=$(sed -n 's/.* listening on \([^;]*\).*/\1/p' "$out/tribod.out" | head -1)
tribo=build/client/tribo

# 1. A run to identify the friction from. The identification protocol needs
#    P on the setpoint (its description says why); the gains go back after.
$tribo set-gains --loop lateral-displacement --setpoint-weight-p 1 >/dev/null
$tribo run config/protocols/identification.textproto --out "$out/identification" --no-progress >/dev/null
$tribo set-gains --loop lateral-displacement --setpoint-weight-p 0 >/dev/null

# 2. The identified model: tribo-fit's report, the contact law chosen on held-out data.
build/analysis/tribo-fit diagnose "$out/identification" --base-model choose --json >"$out/model.json"

# 3. The break-away protocol without and with the compensation.
$tribo run config/protocols/breakaway_velocities.textproto --out "$out/before" --no-progress >"$out/before.txt"
$tribo run config/protocols/breakaway_velocities.textproto --friction-model "$out/model.json" \
  --out "$out/after" --no-progress >"$out/after.txt"

# 4. Before and after, from the two records; the plot.
build/bench/friction_compensation_figures --before "$out/before" --after "$out/after" | tee "$out/figures.txt"
/usr/bin/python3 docs/figures/make_friction_compensation_figure.py "$out/before" "$out/after" \
  "$out/friction_compensation.png"
echo "plot: $out/friction_compensation.png"
