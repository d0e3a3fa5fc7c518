#!/bin/bash
# Autonomy-aware clustering (aac1800) against the authors' published settings.
# 1. The oracle, 16 restarts, seed 1, at every published setting (deviation 0.1–0.5, T 0.01 and
#    100, w_point 0): oracle/d<dev>_t<T>.json.
# 2. ground_truth.md: the authors' ground-truth solver, reimplemented independently, at the same
#    settings, with each oracle result's J recomputed from its file (needs numpy).
# 3. table/: Algorithm 1 (the `aac` preset), seeds 1–6, at deviation 0.4 and T ∈ {100, 0.01},
#    against the oracle.
# All three took 4 min 45 s on a 2-core machine.
# Run from the repository root: bash results/aac/run.sh
set -euo pipefail
out=results/aac
cargo build --release --quiet --bin envpg
mkdir -p "$out/oracle"
for dev in 0.1 0.2 0.3 0.4 0.5; do
  for t in 0.01 100; do
    ./target/release/envpg oracle --instance aac1800 --env-param deviation=$dev --env-param temperature=$t \
      --restarts 16 --seed 1 --out "$out/oracle/d${dev}_t${t}.json"
  done
done
python3 "$out/ground_truth.py" "$out/oracle" > "$out/ground_truth.md"
./target/release/envpg table --instance aac1800 --env-param deviation=0.4 --vary temperature=100,0.01 \
  --seeds 1..6 --quiet --out "$out/table"
