#!/bin/bash
# Where the polish ends against the unsmoothed local optimum, κ = 0.85, seeds 1–6: for each
# seed, the design Algorithm 1 ends with before the polish (results/table-no-polish), the model's
# local optimiser started there at α = 0.01 (exact gradients, for the report only), and the
# polished design of the default run (results/table). J is the exact objective of each run's
# greedy policy; the local optimiser's J is that of its own optimal policy.
# Run from the repository root after `envpg table --out results/table` and
# `envpg table --set polish_iterations=0 --out results/table-no-polish`:
#   bash results/polish/run.sh        (about 10 s)
set -euo pipefail
out=results/polish
cargo build --release --quiet --bin envpg
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
{
  echo "# The ζ polish against the model's local optimiser, κ = 0.85"
  echo
  echo "| seed | J before the polish | J, model's local optimum from there | largest UAV move to it | J after the polish | polish vs local optimum |"
  echo "|---|---|---|---|---|---|"
  for s in 1 2 3 4 5 6; do
    before=results/table-no-polish/runs/algorithm1_k0.85_s$s.json
    after=results/table/runs/algorithm1_k0.85_s$s.json
    z=$(python3 -c "import json,sys; print(','.join(map(str, json.load(open(sys.argv[1]))['zeta'])))" "$before")
    ./target/release/envpg oracle --kappa 0.85 --restarts 1 --init "$z" --warm-alpha0 0.01 \
      --out "$tmp/local_$s.json" > /dev/null
    python3 - "$before" "$tmp/local_$s.json" "$after" "$s" <<'PY'
import json, math, sys
b, l, a = (json.load(open(p)) for p in sys.argv[1:4])
move = max(math.hypot(b['zeta'][2*i] - l['zeta'][2*i], b['zeta'][2*i+1] - l['zeta'][2*i+1]) for i in range(len(b['zeta']) // 2))
print(f"| {sys.argv[4]} | {b['J']:.3f} | {l['J']:.3f} | {move:.2f} | {a['J']:.3f} | {100 * (a['J'] - l['J']) / l['J']:+.2f}% |")
PY
  done
} > "$out/compare.md"
cat "$out/compare.md"
