#!/bin/bash
# Algorithm 1 (model-free, `envpg-launch --workers 2`) with the default preset `uav` and with
# `uav-large` on the generated UAV instances with 2,000 users and 10 UAVs of
# results/oracle-scale (instance seeds 1–5), run seeds 1–3, against the best design known
# there. Writes alg1-*.json (`uav`) and alg1-large-*.json (`uav-large`), result files whose J
# `envpg evaluate FILE` recomputes, and table.md; result files already there are kept. Run from
# the repository root, after results/oracle-scale/run.sh: bash results/alg1-scale/run.sh
# (≈ 11 min per preset on 2 cores).
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
        for preset in uav uav-large; do
            file="$out/alg1-$name-seed$run.json"
            [ "$preset" = uav ] || file="$out/alg1-large-$name-seed$run.json"
            [ -f "$file" ] && continue
            ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$name.json" --workers 2 \
                --preset "$preset" --seed "$run" --quiet --out "$file"
        done
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
            "`envpg-launch --instance FILE --workers 2 --preset P --seed R` (model-free, with the ζ polish), "
            "P = `uav` (the default: a one-hot input column per user) and `uav-large` (users share one column; "
            "the hop features tell them apart); *best known* from [oracle-scale](../oracle-scale/table.md). "
            "*alone*: Algorithm 1 before the polish (— where its greedy policy loops). "
            "Command: `bash results/alg1-scale/run.sh`.\n\n")
    f.write("| instance | best known | run seed | preset | J | vs best known | alone vs best known | wall | transitions |\n")
    f.write("|---|---|---|---|---|---|---|---|---|\n")
    within = {"uav": 0, "uav-large": 0}
    for seed in range(1, 6):
        name = f"u2000-m10-s{seed}"
        best = known(name)
        for run in (1, 2, 3):
            for preset, prefix in (("uav", "alg1"), ("uav-large", "alg1-large")):
                r = json.load(open(f"{out}/{prefix}-{name}-seed{run}.json"))
                pol = (r.get("details") or {}).get("polish") or {}
                before = pol.get("J_before")
                alone = f"{100 * (before / best - 1):+.2f}%" if before else "—"
                tr = (r.get("details") or {}).get("transitions", "—")
                gap = r["J"] / best - 1
                within[preset] += gap <= 0.01
                f.write(f"| {name} | {best:.6f} | {run} | `{preset}` | {r['J']:.6f} | {100 * gap:+.2f}% | {alone} | "
                        f"{r['seconds']:.0f} s | {tr} |\n")
    f.write(f"\nRuns within 1% of the best design known: `uav` {within['uav']}/15, `uav-large` {within['uav-large']}/15.\n")
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
