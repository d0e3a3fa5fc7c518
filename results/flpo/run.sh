#!/bin/bash
# Facility location with path optimization (flpo-n10m4, the LearningFLPO benchmark instance).
# 1. oracle.json: the oracle, 16 restarts, seed 1, at κ = 1 (the benchmark), to compare with the
#    published MIP solver's incumbent.
# 2. table/: Algorithm 1 (the `default` preset), seeds 1–6, at κ ∈ {1, 0.9}, against the oracle
#    (44 s for both on a 2-core machine).
# Run from the repository root: bash results/flpo/run.sh
set -euo pipefail
out=results/flpo
cargo build --release --quiet --bin envpg
mkdir -p "$out"
./target/release/envpg oracle --instance flpo-n10m4 --restarts 16 --seed 1 --out "$out/oracle.json"
./target/release/envpg table --instance flpo-n10m4 --kappas 1,0.9 --seeds 1..6 --quiet --out "$out/table"
