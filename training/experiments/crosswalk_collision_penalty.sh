#!/usr/bin/env bash
# Crosswalk with a larger collision penalty (an option, not the paper's reward): fine-tune the
# shipped crosswalk policy (120 min at the paper's -1) at collision reward -3 for MINUTES, then
# at -6 for MINUTES2, evaluating each stage (200 deterministic episodes, seeds 10000-10199, with
# the invisible-pedestrian control). Resumable: finished stages are skipped.
#   bash training/experiments/crosswalk_collision_penalty.sh [MINUTES] [MINUTES2] [OUT]
set -euo pipefail
MINUTES=${1:-40}
MINUTES2=${2:-25}
OUT=${3:-runs/crosswalk_penalty}
cd "$(dirname "$0")/../.."
mkdir -p "$OUT"
stage() {  # name, collision reward, minutes, init
  local name=$1 reward=$2 minutes=$3 init=$4
  if [ ! -f "$OUT/$name/model.safetensors" ]; then
    python training/crosswalk.py --crosswalk-in-satnav --init-from "$init" --collision-reward "$reward" \
      --out "$OUT/$name" --timesteps 100000000 --max-minutes "$minutes" --ent-coef 0.001 \
      --minibatch-by-step > "$OUT/$name.log" 2>&1
  fi
  if [ ! -f "$OUT/$name/eval/metrics.json" ]; then
    python training/evaluate.py --checkpoint "$OUT/$name" --episodes 200 --out "$OUT/$name/eval" \
      --video 1 >> "$OUT/$name.log" 2>&1
  fi
}
stage collision3 -3 "$MINUTES" assets/policies/crosswalk_4cars_satnav
stage collision6 -6 "$MINUTES2" "$OUT/collision3"
python training/experiments/table.py "$OUT/collision3/eval" "$OUT/collision6/eval"
