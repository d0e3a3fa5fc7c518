#!/bin/bash
# Algorithm 1 (model-free, default settings, `envpg-launch --workers 2`) on the generated UAV
# instances with 2,000 users and 10 UAVs of results/oracle-scale (instance seeds 1–5), run
# seeds 1–3, against the best design known there. Writes alg1-*.json (result files: `envpg
# evaluate FILE` recomputes each J) and table.md. Run from the repository root, after
# results/oracle-scale/run.sh: bash results/alg1-scale/run.sh (≈ 12 min on 2 cores).
set -euo pipefail
out=results/alg1-scale
cargo build --release --quiet --bin envpg --bin envpg-launch
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for seed in 1 2 3 4 5; do
    name="u2000-m10-s$seed"
    ./target/release/envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    for run in 1 2 3; do
        ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$name.json" --workers 2 \
            --seed "$run" --quiet --out "$out/alg1-$name-seed$run.json"
    done
done
python3 - "$out" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
def known(name):
    files = glob.glob(f"results/oracle-scale/*-{name}.json")
    return min(json.load(open(f))["J"] for f in files)
with open(f"{out}/table.md", "w") as f:
    f.write("# Algorithm 1 at 2,000 users against the best design known\n\n")
    f.write("Generated instances (`envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed S`), "
            "`envpg-launch --instance FILE --workers 2 --seed R` (default settings, model-free, with the ζ polish); "
            "*best known* from [oracle-scale](../oracle-scale/table.md). Command: `bash results/alg1-scale/run.sh`.\n\n")
    f.write("| instance | best known | run seed | J | vs best known | Algorithm 1 alone (before the polish) | wall | transitions |\n")
    f.write("|---|---|---|---|---|---|---|---|\n")
    for seed in range(1, 6):
        name = f"u2000-m10-s{seed}"
        best = known(name)
        for run in (1, 2, 3):
            r = json.load(open(f"{out}/alg1-{name}-seed{run}.json"))
            pol = (r.get("details") or {}).get("polish") or {}
            before = pol.get("J_before")
            alone = f"{100 * (before / best - 1):+.2f}%" if before else "—"
            tr = (r.get("details") or {}).get("transitions", "—")
            f.write(f"| {name} | {best:.6f} | {run} | {r['J']:.6f} | {100 * (r['J'] / best - 1):+.2f}% | {alone} | "
                    f"{r['seconds']:.0f} s | {tr} |\n")
print(open(f"{out}/table.md").read())
PY
# Committed result files keep what recomputing J needs: history, policy_soft dropped, compact JSON.
python3 - "$out" <<'PY'
import glob, json, sys
for path in glob.glob(f"{sys.argv[1]}/*.json"):
    r = json.load(open(path))
    for key in ("history", "policy_soft"):
        r.pop(key, None)
    json.dump(r, open(path, "w"), separators=(",", ":"))
PY
