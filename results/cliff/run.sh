#!/bin/bash
# The narrow valley of J(ζ) at κ = 0.85 that the exact oracle finds and Algorithm 1 cannot
# hold: start Algorithm 1 *at* the same-start oracle's design (seed 1), then score the optimal
# policy's J along the segment from that design to where Algorithm 1 ends.
# Measured with σ = 0.3 and no ζ polish (the defaults then), pinned below.
# Run from the repository root after `envpg table` has filled results/table:
#   bash results/cliff/run.sh        (about 30 s)
set -euo pipefail
out=results/cliff
oracle=results/table/runs/oracle-same-start_k0.85_s1.json
zeta() { python3 -c "import json,sys; print(','.join(map(str, json.load(open(sys.argv[1]))['$2'])))" "$1"; }
cargo build --release --quiet --bin envpg --bin envpg-launch
./target/release/envpg-launch --in-process --kappa 0.85 --seed 1 --quiet --sigma 0.3 --polish-iterations 0 \
  --zeta0 "$(zeta "$oracle" zeta)" --out "$out/from-oracle.json"
a=$(zeta "$oracle" zeta)
b=$(zeta "$out/from-oracle.json" zeta)
{
  echo "# J along the segment from the oracle's design (t = 0) to Algorithm 1's (t = 1), κ = 0.85"
  echo
  echo "Optimal policy at each design (\`envpg evaluate --kappa 0.85 --zeta …\`); the segment's"
  echo "length is the distance between the two designs."
  echo
  echo "| t | distance from the oracle's design | J |"
  echo "|---|---|---|"
  for t in 0 0.002 0.005 0.01 0.02 0.05 0.1 0.2 0.5 1; do
    z=$(python3 -c "
a=[float(x) for x in '$a'.split(',')]; b=[float(x) for x in '$b'.split(',')]
print(','.join(str(x + $t * (y - x)) for x, y in zip(a, b)))")
    d=$(python3 -c "
a=[float(x) for x in '$a'.split(',')]; b=[float(x) for x in '$b'.split(',')]
print('%.3f' % ($t * sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5))")
    j=$(./target/release/envpg evaluate --kappa 0.85 --zeta "$z" | awk '{print $3}')
    echo "| $t | $d | $j |"
  done
  echo
  echo "Algorithm 1 started at the oracle's design ends at J = $(python3 -c "import json; print(json.load(open('$out/from-oracle.json'))['J'])") (its greedy policy;"
  echo "\`$out/from-oracle.json\`); the oracle's design scores the J at t = 0."
} > "$out/profile.md"
cat "$out/profile.md"
