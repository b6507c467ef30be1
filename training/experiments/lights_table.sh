#!/usr/bin/env bash
# Equal-budget comparison for the traffic-light rule: cars 1/4/8 at noise 0, 4 cars at noise
# 0.25/0.5, the own+mean critic, the decentralised 'own' critic and the paper's horizon 25;
# MINUTES of training each, then 200-episode deterministic evaluations and a markdown table.
#   bash training/experiments/lights_table.sh [MINUTES] [OUT]
set -euo pipefail
MINUTES=${1:-10}
OUT=${2:-runs/lights_table}
cd "$(dirname "$0")/../.."
mkdir -p "$OUT"
run() {  # name, extra args
  local name=$1; shift
  if [ ! -f "$OUT/$name/model.safetensors" ]; then
    python training/traffic_lights.py --out "$OUT/$name" --timesteps 100000000 --max-minutes "$MINUTES" "$@" \
      > "$OUT/$name.log" 2>&1
  fi
  if [ ! -f "$OUT/$name/eval/metrics.json" ]; then
    python training/evaluate.py --checkpoint "$OUT/$name" --episodes 200 --out "$OUT/$name/eval" >> "$OUT/$name.log" 2>&1
  fi
}
run cars1 --num-cars 1
run cars4 --num-cars 4
run cars8 --num-cars 8
run cars4_noise025 --num-cars 4 --lidar-noise 0.25
run cars4_noise05 --num-cars 4 --lidar-noise 0.5
run cars4_own_mean --num-cars 4 --critic own+mean
run cars4_own_critic --num-cars 4 --critic own
run cars4_horizon25 --num-cars 4 --horizon 25
run cars8_from4 --num-cars 8 --init-from assets/policies/traffic_lights_4cars
python training/experiments/table.py "$OUT"/*/eval/metrics.json > "$OUT/table.md"
cat "$OUT/table.md"
