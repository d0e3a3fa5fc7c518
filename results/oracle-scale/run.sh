#!/bin/bash
# The oracle's default (16 restarts, the `auto` portfolio at κ = 1) on generated UAV instances
# larger than the bundled one: 2,000 users / 10 UAVs (instance seeds 1–5) and 10,000 users /
# 20 UAVs (seeds 1–2), oracle seed 1. Restart 0 of each run is the single-rate anneal, bit for
# bit the anneal every restart of the previous default ran. The 2,000-user instances are also
# run with oracle seeds 2–4, to know the best design this search finds at all.
# Writes oracle-*.json and best-known-*.json (result files: `envpg evaluate FILE` recomputes each
# J) and table.md.
# Run from the repository root: bash results/oracle-scale/run.sh (≈ 6 min on 2 cores).
set -euo pipefail
out=results/oracle-scale
envpg=./target/release/envpg
cargo build --release --quiet --bin envpg
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for spec in "2000 10 1" "2000 10 2" "2000 10 3" "2000 10 4" "2000 10 5" "10000 20 1" "10000 20 2"; do
    read -r users uavs seed <<<"$spec"
    name="u${users}-m${uavs}-s${seed}"
    $envpg instance generate --users "$users" --uavs "$uavs" --clusters "$uavs" --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    $envpg oracle --instance "$tmp/$name.json" --seed 1 --out "$out/oracle-$name.json" >/dev/null
    if [ "$users" = 2000 ]; then
        for oseed in 2 3 4; do
            $envpg oracle --instance "$tmp/$name.json" --seed "$oseed" --out "$tmp/$name-seed$oseed.json" >/dev/null
        done
    fi
done
python3 - "$out" "$tmp" <<'PY'
import glob, json, os, sys
out, tmp = sys.argv[1], sys.argv[2]
def pct(a, b):
    x = 100 * (a / b - 1)
    return "0.00%" if abs(x) < 0.005 else f"{x:+.2f}%"
rows = []
for path in sorted(glob.glob(f"{out}/oracle-*.json"), key=lambda p: (len(p), p)):
    name = os.path.basename(path)[len("oracle-"):-len(".json")]
    r = json.load(open(path))
    d = r["details"]
    rs = d["restarts"]
    best = rs[d["best_restart"]]
    others = {p: json.load(open(p))["J"] for p in glob.glob(f"{tmp}/{name}-seed*.json")}
    known = min([r["J"]] + list(others.values()))
    # Better beyond rounding: another seed reaching the same design is not a better one.
    better = [p for p, j in others.items() if j == known and j < r["J"] * (1 - 1e-9)]
    if better:  # keep the best design known, so that it can be recomputed too
        os.replace(sorted(better)[0], f"{out}/best-known-{name}.json")
    else:
        known = r["J"]
    rows.append((name, rs[0]["J"], r["J"], known, best, d["fraction_best"], r["seconds"],
                 sum(x["seconds"] for x in rs)))
with open(f"{out}/table.md", "w") as f:
    f.write("# The oracle at scale: the default portfolio against its single-rate anneal\n\n")
    f.write("Generated instances (`envpg instance generate --users U --uavs M --clusters M --seed S`), "
            "`envpg oracle --instance FILE --seed 1` (16 restarts, `auto` = portfolio at κ = 1). "
            "*anneal* is restart 0, the single-rate anneal (cooling 0.8); *best known* is the best J of "
            "this run and, for 2,000 users, of the same run with oracle seeds 2–4 (kept as "
            "`best-known-*.json` where better). "
            "Command: `bash results/oracle-scale/run.sh`.\n\n")
    f.write("| instance | anneal (restart 0) | portfolio | vs anneal | best known | portfolio vs best known "
            "| best restart | restarts at the best (±1e-4) | wall | CPU |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|\n")
    for name, j0, j, known, best, frac, wall, cpu in rows:
        f.write(f"| {name} | {j0:.6f} | {j:.6f} | {pct(j, j0)} | {known:.6f} | "
                f"{pct(j, known)} | {best['index']} ({best['kind']}, cooling {best['cooling']:.3f}) | "
                f"{round(frac * 16)}/16 | {wall:.1f} s | {cpu:.1f} s |\n")
print(open(f"{out}/table.md").read())
PY
# Committed result files keep what recomputing J needs: policy_soft dropped, compact JSON.
python3 - "$out" <<'PY'
import glob, json, sys
for path in glob.glob(f"{sys.argv[1]}/*.json"):
    r = json.load(open(path))
    for key in ("policy_soft",):
        r.pop(key, None)
    json.dump(r, open(path, "w"), separators=(",", ":"))
PY
