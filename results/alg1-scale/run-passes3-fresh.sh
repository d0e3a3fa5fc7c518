#!/bin/bash
# Algorithm 1 with three independent passes (`envpg-launch --preset uav-large --passes 3
# --pass-start fresh`: each pass from a random ζ₀ of its own, the pass whose design and greedy
# policy cost less on common sampled episodes kept) on the generated UAV instances with 2,000
# users and 10 UAVs, instance seeds 1–16 (9–16 held out: never used to choose settings), run
# seeds 1–3, against the best design known: the best of the oracle's result files
# (results/oracle-scale, heldout/oracle-*) and of every Algorithm 1 result file for the instance.
# Beside the two-pass `fresh` runs of run-passes.sh and run-heldout.sh, whose result files must be
# there: passes 1 and 2 of a three-pass run are those runs' passes. Writes passes3-fresh/*.json
# (result files whose J `envpg evaluate FILE` recomputes) and table-passes3-fresh.md; result files
# already there are kept. Run from the repository root:
# bash results/alg1-scale/run-passes3-fresh.sh (≈ 60 min on 2 cores).
set -euo pipefail
base=results/alg1-scale
out=$base/passes3-fresh
mkdir -p "$out"
cargo build --release --quiet --bin envpg --bin envpg-launch
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for seed in $(seq 1 16); do
    name="u2000-m10-s$seed"
    ./target/release/envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    for run in 1 2 3; do
        file="$out/alg1-large-passes3-fresh-$name-seed$run.json"
        [ -f "$file" ] && continue
        ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$name.json" --workers 2 \
            --preset uav-large --passes 3 --pass-start fresh --seed "$run" --quiet --out "$file" >/dev/null
        python3 $base/compact.py "$file"
    done
done
python3 - <<'PY'
import glob, json, statistics
base = "results/alg1-scale"
load = lambda f: json.load(open(f))
gap = lambda j, best: f"{100 * (j / best - 1):+.2f}%"
rows, gaps, same, ranked, beat, oracle_gaps = [], {"one": [], "two": [], "three": []}, 0, 0, [], []
walls, trans = [], []
for seed in range(1, 17):
    name = f"u2000-m10-s{seed}"
    held = seed > 8
    two_dir = f"{base}/heldout" if held else base
    three = [load(f"{base}/passes3-fresh/alg1-large-passes3-fresh-{name}-seed{r}.json") for r in (1, 2, 3)]
    two = [load(f"{two_dir}/alg1-large-passes2-fresh-{name}-seed{r}.json") for r in (1, 2, 3)]
    oracle_files = (glob.glob(f"{base}/heldout/oracle-{name}-seed*.json") if held
                    else glob.glob(f"results/oracle-scale/*-{name}.json"))
    # The oracle's default (oracle seed 1): the file every table of the instance reports.
    oracle = load(f"{base}/heldout/oracle-{name}-seed1.json" if held else f"results/oracle-scale/oracle-{name}.json")
    others = [f for f in glob.glob(f"{base}/**/alg1-*-{name}-seed*.json", recursive=True) if "passes3-fresh" not in f]
    before = min(load(f)["J"] for f in oracle_files + others)
    best = min([before] + [r["J"] for r in three])
    if best < before:
        beat.append(f"{name} ({gap(best, before)})")
    oracle_gaps.append(oracle["J"] / best - 1)
    for r, (t, w) in enumerate(zip(three, two), 1):
        p = t["details"]["passes"]
        runs = p["runs"]
        # Passes 1 and 2 are the two-pass run's.
        same += all(a["J"] == b["J"] and a["zeta"] == b["zeta"] for a, b in zip(runs[:2], w["details"]["passes"]["runs"]))
        ranked += t["J"] == min(x["J"] for x in runs)
        gaps["one"].append(runs[0]["J"] / best - 1)
        gaps["two"].append(w["J"] / best - 1)
        gaps["three"].append(t["J"] / best - 1)
        walls.append(t["seconds"])
        trans.append(t["details"]["transitions"])
        rows.append(f"| {name}{' (held out)' if held else ''} | {best:.6f} | {gap(oracle['J'], best)} | {r} | "
                    f"{gap(runs[0]['J'], best)} | {gap(runs[1]['J'], best)} | {gap(runs[2]['J'], best)} | "
                    f"{gap(w['J'], best)} | {p['kept']} | {gap(t['J'], best)} | {t['seconds']:.0f} s | "
                    f"{t['details']['transitions']:,} |\n")
def summary(g):
    return (f"{sum(x <= 0.01 for x in g)}/{len(g)} (median {100 * statistics.median(g):+.2f}%, "
            f"worst {100 * max(g):+.2f}%)")
n = len(gaps["one"])
with open(f"{base}/table-passes3-fresh.md", "w") as f:
    f.write("# Algorithm 1 with three independent passes at 2,000 users\n\n"
            "Generated instances (`envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed S`, "
            "S = 1–16; 9–16 held out, never used to choose settings), "
            "`envpg-launch --instance FILE --workers 2 --preset uav-large --passes 3 --pass-start fresh --seed R`, "
            "R = 1–3 (model-free: each pass trains from a random ζ₀ with a seed of its own; the pass whose design "
            "and greedy policy cost less on common sampled episodes is kept). *best known*: the best of the "
            "oracle's result files and of every Algorithm 1 run of the instance in results/alg1-scale. *oracle*: "
            "the oracle's default (`envpg oracle --instance FILE --seed 1`, [oracle-scale](../oracle-scale/table.md) "
            "and [held-out](table-heldout.md)). *pass 1–3*: each pass's J (scored for this table, not used to "
            "choose); *two passes*: the two-pass `fresh` run with the same seed, whose passes are this run's "
            "first two; *kept*: the pass the ranking kept. *wall*, *transitions*: the whole run (three passes "
            "and the ranking), measured while other work ran on the machine. Command: "
            "`bash results/alg1-scale/run-passes3-fresh.sh`.\n\n")
    f.write(f"Within 1% of the best design known: one pass {summary(gaps['one'])}; two passes "
            f"{summary(gaps['two'])}; three passes {summary(gaps['three'])}; the oracle's default "
            f"{summary(oracle_gaps)} of the instances. Passes 1 and 2 are the two-pass "
            f"run's (same J and ζ) in {same} of {n}; the ranking kept the pass with the lowest J in {ranked} of {n}. "
            f"A three-pass run took {min(walls):.0f}–{max(walls):.0f} s (median {statistics.median(walls):.0f} s) "
            f"and {min(trans):,}–{max(trans):,} transitions. "
            + (f"Three-pass runs found designs better than the best known before on {', '.join(beat)}.\n\n" if beat
               else "No three-pass run found a design better than the best known before.\n\n"))
    f.write("| instance | best known | oracle | run seed | pass 1 | pass 2 | pass 3 | two passes | kept | three passes "
            "| wall | transitions |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    f.writelines(rows)
print(open(f"{base}/table-passes3-fresh.md").read())
PY
