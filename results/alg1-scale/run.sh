#!/bin/bash
# Algorithm 1 (model-free, `envpg-launch --workers 2`) with the default preset `uav` and with
# `uav-large`, each from a random ζ₀ (the default) and from `--zeta0 clustered` (the users'
# k-means centres drawn from the run seed), on the generated UAV instances with 2,000 users and
# 10 UAVs of results/oracle-scale (instance seeds 1–8), run seeds 1–3, against the best design
# known there. Writes alg1-*.json (`uav`), alg1-large-*.json (`uav-large`) and
# alg1-clustered-*.json, alg1-large-clustered-*.json (clustered ζ₀): result files whose J
# `envpg evaluate FILE` recomputes; and table.md; result files already there are kept. Run from
# the repository root, after results/oracle-scale/run.sh: bash results/alg1-scale/run.sh
# (≈ 12 min per preset and ζ₀ on 2 cores).
set -euo pipefail
out=results/alg1-scale
cargo build --release --quiet --bin envpg --bin envpg-launch
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for seed in 1 2 3 4 5 6 7 8; do
    name="u2000-m10-s$seed"
    ./target/release/envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    for run in 1 2 3; do
        for variant in alg1:uav:random alg1-large:uav-large:random alg1-clustered:uav:clustered \
            alg1-large-clustered:uav-large:clustered; do
            IFS=: read -r prefix preset zeta0 <<<"$variant"
            file="$out/$prefix-$name-seed$run.json"
            [ -f "$file" ] && continue
            ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$name.json" --workers 2 \
                --preset "$preset" --zeta0 "$zeta0" --seed "$run" --quiet --out "$file"
        done
    done
done
python3 - "$out" <<'PY'
import glob, json, os, statistics, sys
out = sys.argv[1]
def known(name):
    files = glob.glob(f"results/oracle-scale/*-{name}.json")
    return min(json.load(open(f))["J"] for f in files)
variants = (("uav", "random", "alg1"), ("uav-large", "random", "alg1-large"),
            ("uav", "clustered", "alg1-clustered"), ("uav-large", "clustered", "alg1-large-clustered"))
rows, gaps = [], {v: [] for v in variants}
for seed in range(1, 9):
    name = f"u2000-m10-s{seed}"
    best = known(name)
    for run in (1, 2, 3):
        for v in variants:
            r = json.load(open(f"{out}/{v[2]}-{name}-seed{run}.json"))
            pol = (r.get("details") or {}).get("polish") or {}
            before = pol.get("J_before")
            alone = f"{100 * (before / best - 1):+.2f}%" if before else "—"
            tr = (r.get("details") or {}).get("transitions", "—")
            gap = r["J"] / best - 1
            gaps[v].append(gap)
            rows.append(f"| {name} | {best:.6f} | {run} | `{v[0]}` | {v[1]} | {r['J']:.6f} | {100 * gap:+.2f}% | "
                        f"{alone} | {r['seconds']:.0f} s | {tr} |\n")
with open(f"{out}/table.md", "w") as f:
    f.write("# Algorithm 1 at 2,000 users against the best design known\n\n")
    f.write("Generated instances (`envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed S`, S = 1–8), "
            "`envpg-launch --instance FILE --workers 2 --preset P --zeta0 Z --seed R` (model-free, with the ζ polish), "
            "P = `uav` (the default: a one-hot input column per user) and `uav-large` (users share one column; "
            "the hop features tell them apart), Z = `random` (the default) and `clustered` (the users' k-means "
            "centres, drawn from the run seed); *best known* from [oracle-scale](../oracle-scale/table.md). "
            "*alone*: Algorithm 1 before the polish (— where its greedy policy loops). Result files already "
            "there are kept, so wall times may come from different commits ([results](../README.md) lists them) or a busy machine. "
            "Command: `bash results/alg1-scale/run.sh`.\n\n")
    f.write("| preset | ζ₀ | runs within 1% of the best design known | vs best known: median, worst |\n|---|---|---|---|\n")
    for v in variants:
        g = gaps[v]
        f.write(f"| `{v[0]}` | {v[1]} | {sum(x <= 0.01 for x in g)}/{len(g)} | "
                f"{100 * statistics.median(g):+.2f}%, {100 * max(g):+.2f}% |\n")
    f.write("\n| instance | best known | run seed | preset | ζ₀ | J | vs best known | alone vs best known | wall | transitions |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|\n")
    f.writelines(rows)
print(open(f"{out}/table.md").read())
PY
# Committed result files keep what recomputing J needs: history, policy_soft dropped, compact JSON.
python3 results/alg1-scale/compact.py "$out"/*.json
