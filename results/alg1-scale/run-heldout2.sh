#!/bin/bash
# A second set of held-out instances (2,000 users, 10 UAVs, instance seeds 17–24: generated
# after `--pass-start warm` and `portfolio` were chosen, never used to choose anything): the
# oracle's default (oracle seeds 1 and 2) and `envpg-launch --preset uav-large --passes 5` with
# `--pass-start warm` (the default) and `--pass-start portfolio` (passes 1–3 fresh, 4–5 warm),
# run seeds 1–3. Pass 1 of both is the one-pass run, and passes 1–3 of `portfolio` are
# `--passes 3 --pass-start fresh` bit for bit (each pass's sampled cost in the ranking does not
# depend on what it is ranked with), so that run's result is the best of them by that cost; the
# script checks this against one real `--pass-start fresh` run. The best design known is the
# best of these result files. Writes heldout2/*.json (result files whose J `envpg evaluate FILE`
# recomputes) and table-heldout2.md; result files already there are kept. Run from the
# repository root: bash results/alg1-scale/run-heldout2.sh (≈ 75 min on 2 cores).
set -euo pipefail
out=results/alg1-scale/heldout2
mkdir -p "$out"
cargo build --release --quiet --bin envpg --bin envpg-launch
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
launch() { # instance-name run-seed pass-start passes file
    [ -f "$5" ] && return
    ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$1.json" --workers 2 \
        --preset uav-large --passes "$4" --pass-start "$3" --seed "$2" --quiet --out "$5" >/dev/null
    python3 results/alg1-scale/compact.py "$5"
}
for seed in $(seq 17 24); do
    name="u2000-m10-s$seed"
    ./target/release/envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    for oseed in 1 2; do
        file="$out/oracle-$name-seed$oseed.json"
        [ -f "$file" ] && continue
        ./target/release/envpg oracle --instance "$tmp/$name.json" --seed "$oseed" --out "$file" >/dev/null
        python3 results/alg1-scale/compact.py "$file"
    done
    for run in 1 2 3; do
        for start in warm portfolio; do
            launch "$name" "$run" "$start" 5 "$out/alg1-large-passes5-$start-$name-seed$run.json"
        done
    done
done
launch u2000-m10-s17 1 fresh 3 "$out/alg1-large-passes3-fresh-u2000-m10-s17-seed1.json"
python3 - "$out" <<'PY'
import json, statistics, sys
out = sys.argv[1]
load = lambda f: json.load(open(f))
gap = lambda j, best: f"{100 * (j / best - 1):+.2f}%"
def fresh3(runs):
    # The ranking's order (envpg-ac polish::sampled): looping policies last, fewer capped
    # episodes first among them, then by sampled cost; ties to the earlier pass.
    key = lambda r: (r["loops"], r["capped"] if r["loops"] else 0, r["j_estimate"])
    return min(runs[:3], key=key)
check = load(f"{out}/alg1-large-passes3-fresh-u2000-m10-s17-seed1.json")
derived = fresh3(load(f"{out}/alg1-large-passes5-portfolio-u2000-m10-s17-seed1.json")["details"]["passes"]["runs"])
assert check["J"] == derived["J"] and check["zeta"] == derived["zeta"], "passes 1-3 of portfolio are not the fresh run"
rows, oracle = [], []
gaps = {k: [] for k in ("one", "fresh", "warm", "portfolio")}
secs = {"warm": [], "portfolio": []}
trans = {"warm": [], "portfolio": []}
for seed in range(17, 25):
    name = f"u2000-m10-s{seed}"
    o = [load(f"{out}/oracle-{name}-seed{s}.json") for s in (1, 2)]
    a = {s: [load(f"{out}/alg1-large-passes5-{s}-{name}-seed{r}.json") for r in (1, 2, 3)] for s in ("warm", "portfolio")}
    best = min([r["J"] for r in o] + [r["J"] for runs in a.values() for r in runs])
    oracle += [r["J"] / best - 1 for r in o]
    for i in range(3):
        w, p = a["warm"][i], a["portfolio"][i]
        wr, pr = w["details"]["passes"]["runs"], p["details"]["passes"]["runs"]
        assert wr[0]["J"] == pr[0]["J"] and wr[0]["zeta"] == pr[0]["zeta"], "pass 1 differs"
        f = fresh3(pr)
        for k, j in (("one", pr[0]["J"]), ("fresh", f["J"]), ("warm", w["J"]), ("portfolio", p["J"])):
            gaps[k].append(j / best - 1)
        for k, r in (("warm", w), ("portfolio", p)):
            secs[k].append(r["seconds"])
            # The passes' own transitions: these runs' rankings scored every finished pass again
            # (before 11033b6, which scores each pass once), so their totals count them repeatedly.
            trans[k].append(sum(x["transitions"] for x in r["details"]["passes"]["runs"]))
        rows.append(f"| {name} | {best:.6f} | {gap(o[0]['J'], best)}, {gap(o[1]['J'], best)} | {i + 1} | "
                    f"{gap(pr[0]['J'], best)} | {gap(f['J'], best)} | {gap(w['J'], best)} | "
                    f"{w['details']['passes']['kept']} | {w['seconds']:.0f} s | {gap(p['J'], best)} | "
                    f"{p['details']['passes']['kept']} | {p['seconds']:.0f} s |\n")
def summary(g):
    return (f"{sum(x <= 0.01 for x in g)}/{len(g)} (median {100 * statistics.median(g):+.2f}%, "
            f"worst {100 * max(g):+.2f}%)")
span = lambda x, fmt: f"{fmt(min(x))}–{fmt(max(x))} (median {fmt(statistics.median(x))})"
with open("results/alg1-scale/table-heldout2.md", "w") as f:
    f.write("# Held-out instances 17–24: warm and portfolio passes at 2,000 users\n\n"
            "Generated instances (`envpg instance generate --users 2000 --uavs 10 --clusters 10 --seed S`, "
            "S = 17–24, generated after every setting here was chosen), the oracle's default (`envpg oracle`, "
            "seeds 1 and 2) and `envpg-launch --instance FILE --workers 2 --preset uav-large --passes 5 "
            "--pass-start warm|portfolio --seed R`, R = 1–3. *best known*: the best of these result files. "
            "*one pass*: pass 1 (the one-pass run); *three fresh*: `--passes 3 --pass-start fresh`, which is "
            "the best of the portfolio's passes 1–3 by the ranking's sampled cost (checked against a real run on "
            "u2000-m10-s17 seed 1); *kept*: the pass the ranking kept. Wall times measured while other work ran "
            "on the machine; *transitions*: the passes' own, without the rankings'. Command: "
            "`bash results/alg1-scale/run-heldout2.sh`.\n\n")
    f.write(f"Within 1% of the best design known: oracle {summary(oracle)}; one pass {summary(gaps['one'])}; "
            f"three `fresh` passes {summary(gaps['fresh'])}; five `warm` passes {summary(gaps['warm'])}; five "
            f"`portfolio` passes {summary(gaps['portfolio'])}. Five warm passes took "
            f"{span(secs['warm'], lambda s: f'{s:.0f} s')} and {span(trans['warm'], lambda t: f'{t:,.0f}')} "
            f"transitions; five portfolio passes {span(secs['portfolio'], lambda s: f'{s:.0f} s')} and "
            f"{span(trans['portfolio'], lambda t: f'{t:,.0f}')}.\n\n")
    f.write("| instance | best known | oracle seeds 1, 2 | run seed | one pass | three fresh | five warm | kept "
            "| wall | five portfolio | kept | wall |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    f.writelines(rows)
print(open("results/alg1-scale/table-heldout2.md").read())
PY
