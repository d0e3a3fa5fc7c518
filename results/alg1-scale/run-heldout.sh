#!/bin/bash
# Held-out instances: generated UAV instances with 2,000 users and 10 UAVs never used while
# choosing settings (instance seeds 9–16), the oracle's default (oracle seeds 1 and 2) and
# `envpg-launch --preset uav-large --passes 2`, the second pass from a random ζ₀ of its own
# (`--pass-start fresh`) or from the first pass's design (`--pass-start best`); pass 1 is the
# one-pass run. Run seeds 1–3; the best design known is the best of these result files. Writes
# heldout/*.json (result files whose J `envpg evaluate FILE` recomputes) and table-heldout.md;
# result files already there are kept. Run from the repository root:
# bash results/alg1-scale/run-heldout.sh (≈ 60 min on 2 cores).
set -euo pipefail
out=results/alg1-scale/heldout
mkdir -p "$out"
cargo build --release --quiet --bin envpg --bin envpg-launch
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for seed in 9 10 11 12 13 14 15 16; do
    name="u2000-m10-s$seed"
    ./target/release/envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    for oseed in 1 2; do
        file="$out/oracle-$name-seed$oseed.json"
        [ -f "$file" ] || ./target/release/envpg oracle --instance "$tmp/$name.json" --seed "$oseed" \
            --out "$file" >/dev/null
    done
    for run in 1 2 3; do
        for start in fresh best; do
            file="$out/alg1-large-passes2-$name-seed$run.json"
            [ "$start" = fresh ] && file="$out/alg1-large-passes2-fresh-$name-seed$run.json"
            [ -f "$file" ] && continue
            ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$name.json" --workers 2 \
                --preset uav-large --passes 2 --pass-start "$start" --seed "$run" --quiet --out "$file" >/dev/null
        done
    done
done
# Committed result files keep what recomputing J needs: history, policy_soft dropped, compact JSON.
python3 results/alg1-scale/compact.py "$out"/*.json
python3 - "$out" <<'PY'
import json, statistics, sys
out = sys.argv[1]
gap = lambda j, best: f"{100 * (j / best - 1):+.2f}%"
rows, oracle, ranked, same = [], [], 0, 0
gaps = {"one": [], "fresh": [], "best": []}
for seed in range(9, 17):
    name = f"u2000-m10-s{seed}"
    o = [json.load(open(f"{out}/oracle-{name}-seed{s}.json")) for s in (1, 2)]
    a = {start: [json.load(open(f"{out}/alg1-large-{infix}-{name}-seed{r}.json")) for r in (1, 2, 3)]
         for start, infix in (("fresh", "passes2-fresh"), ("best", "passes2"))}
    best = min([r["J"] for r in o] + [r["J"] for runs in a.values() for r in runs])
    oracle += [r["J"] / best - 1 for r in o]
    for i in range(3):
        cells = []
        for start in ("fresh", "best"):
            r = a[start][i]
            p = r["details"]["passes"]
            first, second = p["runs"]
            gaps[start].append(r["J"] / best - 1)
            ranked += r["J"] == min(first["J"], second["J"])
            cells.append(f"{gap(second['J'], best)} | {p['kept']} | {gap(r['J'], best)} | {r['seconds']:.0f} s")
        first_f, first_b = a["fresh"][i]["details"]["passes"]["runs"][0], a["best"][i]["details"]["passes"]["runs"][0]
        same += first_f["J"] == first_b["J"] and first_f["zeta"] == first_b["zeta"]
        gaps["one"].append(first_f["J"] / best - 1)
        rows.append(f"| {name} | {best:.6f} | {gap(o[0]['J'], best)}, {gap(o[1]['J'], best)} | {i + 1} | "
                    f"{gap(first_f['J'], best)} | {' | '.join(cells)} |\n")
def summary(g):
    return (f"{sum(x <= 0.01 for x in g)}/{len(g)} (median {100 * statistics.median(g):+.2f}%, "
            f"worst {100 * max(g):+.2f}%)")
with open(f"{out}/../table-heldout.md", "w") as f:
    f.write("# Held-out instances at 2,000 users\n\n"
            "Generated instances never used to choose settings (`envpg instance generate --users 2000 --uavs 10 "
            "--clusters 10 --seed S`, S = 9–16): the oracle's default (`envpg oracle --seed O`, O = 1, 2) and "
            "`envpg-launch --instance FILE --workers 2 --preset uav-large --passes 2 --pass-start START --seed R` "
            "(model-free; the second pass from a random ζ₀ of its own (`fresh`) or from the first pass's design "
            "(`best`), the pass whose design and greedy policy cost less on common sampled episodes kept). "
            "*best known*: the lowest J among these result files. *pass 1* is the one-pass run with the same "
            "settings (the same in both modes); *pass 2* the second pass, its J scored for this table, not used "
            "to choose. Command: `bash results/alg1-scale/run-heldout.sh`.\n\n")
    f.write(f"Within 1% of the best design known: the oracle {summary(oracle)}; Algorithm 1, one pass "
            f"{summary(gaps['one'])}; two passes, `fresh` {summary(gaps['fresh'])}; two passes, `best` "
            f"{summary(gaps['best'])}. The ranking kept the pass with the lower J in {ranked} of "
            f"{2 * len(gaps['one'])} two-pass runs; pass 1 is the same in both modes in {same} of {len(gaps['one'])}.\n\n")
    f.write("| instance | best known | oracle seeds 1, 2 | run seed | pass 1 | `fresh`: pass 2 | kept | J | wall "
            "| `best`: pass 2 | kept | J | wall |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    f.writelines(rows)
print(open(f"{out}/../table-heldout.md").read())
PY
