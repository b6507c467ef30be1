#!/usr/bin/env bash
# Communication on real junctions (SPEC 6.4): 8 cars with the 1-bit message at LiDAR noise 0,
# 0.25, 0.5 and 0.75, MINUTES of training each (entropy 1e-4 without noise, 1e-2 with, as the
# paper), then 200-episode deterministic evaluations, a markdown table and a plot of speaker
# consistency and the heading-change / bit correlations against noise. Resumable: finished runs
# and evaluations are skipped. Each run starts from INIT (default: the shipped 8-car real-junction
# policy, widened to the 26 communication actions and the received-bit input so that it starts as
# that policy with a coin-flip bit; "none" trains from scratch) and draws minibatches by env step.
# FALLBACK (default zero) is what a car hearing no other car receives: zero (SPEC) or own (its own
# last bit, the ablation of docs/real_junctions.md). SEED (default 0) seeds training; evaluations
# always use the same 200 episode seeds, so runs with different SEEDs are directly comparable.
#   bash training/experiments/communication_noise.sh [MINUTES] [OUT] [INIT] [FALLBACK] [SEED]
set -euo pipefail
MINUTES=${1:-30}
OUT=${2:-runs/communication}
INIT=${3:-assets/policies/real_junction_8cars}
FALLBACK=${4:-zero}
SEED=${5:-0}
INIT_ARGS=()
if [ "$INIT" != "none" ]; then INIT_ARGS=(--init-from "$INIT"); fi
cd "$(dirname "$0")/../.."
mkdir -p "$OUT"
run() {  # name, noise, entropy
  local name=$1 noise=$2 ent=$3
  if [ ! -f "$OUT/$name/model.safetensors" ]; then
    python training/real_junction.py --communication --num-cars 8 --lidar-noise "$noise" --ent-coef "$ent" \
      --out "$OUT/$name" --timesteps 100000000 --max-minutes "$MINUTES" --minibatch-by-step --comm-fallback "$FALLBACK" --seed "$SEED" "${INIT_ARGS[@]}" > "$OUT/$name.log" 2>&1
  fi
  if [ ! -f "$OUT/$name/eval/metrics.json" ]; then
    python training/evaluate.py --checkpoint "$OUT/$name" --episodes 200 --out "$OUT/$name/eval" >> "$OUT/$name.log" 2>&1
  fi
}
run noise0 0.0 0.0001
run noise025 0.25 0.01
run noise05 0.5 0.01
run noise075 0.75 0.01
python training/experiments/communication_table.py --out "$OUT/communication.png" \
  0=$OUT/noise0/eval 0.25=$OUT/noise025/eval 0.5=$OUT/noise05/eval 0.75=$OUT/noise075/eval > "$OUT/table.md"
cat "$OUT/table.md"
