#!/usr/bin/env bash
# Continue the four communication runs (SPEC 6.4; see communication_noise.sh) of SRC until each has
# trained MINUTES wall-clock minutes in all, in copies under OUT (SRC is never written), then
# evaluate (200 episodes, deterministic as every report, and again sampling actions: the bit of
# an argmax over 26 joint actions may hide what the sampled policy says) and tabulate as
# communication_noise.sh does. Resumable: finished steps are skipped. SEED: the training seed SRC
# was started with (communication_noise.sh's SEED); the continuation's envs are seeded from it.
#   bash training/experiments/communication_extend.sh MINUTES [SRC] [OUT] [SEED]   (SRC: communication_noise.sh's OUT)
set -euo pipefail
MINUTES=${1:?total minutes per noise level}
SRC=${2:-runs/communication}
OUT=${3:-runs/communication_${MINUTES}min}
SEED=${4:-0}
cd "$(dirname "$0")/../.."
mkdir -p "$OUT"
run() {  # name, noise, entropy
  local name=$1 noise=$2 ent=$3
  if [ ! -d "$OUT/$name" ]; then
    mkdir -p "$OUT/$name"
    cp "$SRC/$name"/{config.json,model.safetensors,state.json} "$OUT/$name/"
    cp "$SRC/$name"/progress*.csv "$OUT/$name/"
  fi
  if [ ! -f "$OUT/$name/eval/metrics.json" ]; then
    python training/real_junction.py --communication --num-cars 8 --lidar-noise "$noise" --ent-coef "$ent" \
      --seed "$SEED" --resume --out "$OUT/$name" --timesteps 100000000 --max-minutes "$MINUTES" --minibatch-by-step >> "$OUT/$name.log" 2>&1
    python training/evaluate.py --checkpoint "$OUT/$name" --episodes 200 --out "$OUT/$name/eval" >> "$OUT/$name.log" 2>&1
  fi
  if [ ! -f "$OUT/$name/eval_stochastic/metrics.json" ]; then
    python training/evaluate.py --checkpoint "$OUT/$name" --episodes 200 --stochastic \
      --out "$OUT/$name/eval_stochastic" >> "$OUT/$name.log" 2>&1
  fi
}
run noise0 0.0 0.0001
run noise025 0.25 0.01
run noise05 0.5 0.01
run noise075 0.75 0.01
for kind in eval eval_stochastic; do
  python training/experiments/communication_table.py --out "$OUT/communication_$kind.png" \
    0=$OUT/noise0/$kind 0.25=$OUT/noise025/$kind 0.5=$OUT/noise05/$kind 0.75=$OUT/noise075/$kind > "$OUT/table_$kind.md"
  echo "## $kind"; cat "$OUT/table_$kind.md"
done
