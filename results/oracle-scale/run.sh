#!/bin/bash
# The oracle's default (16 restarts, the `auto` portfolio at κ = 1, then 6 kicks and 4 relocation
# kicks) on generated UAV instances larger than the bundled one: 2,000 users / 10 UAVs (instance
# seeds 1–16) and 10,000 users / 20 UAVs (seeds 1–8), oracle seed 1. Restart 0 of each run is the single-rate anneal. Every
# instance is also run with other oracle seeds (2–4 at 2,000 users, 2 at 10,000), to know the
# best design this search finds at all.
# Designs found outside this search count towards the best known: warm-*-NAME.json (one warm
# restart from another draw of the users' k-means centres, rerun from its `zeta0`) and
# earlier-*-NAME.json (the result file of an earlier version of the oracle, kept as it was).
# Writes oracle-*.json and best-known-*.json (result files: `envpg evaluate FILE` recomputes each
# J) and table.md.
# Run from the repository root: bash results/oracle-scale/run.sh (≈ 20 min on 2 cores).
set -euo pipefail
out=results/oracle-scale
envpg=./target/release/envpg
cargo build --release --quiet --bin envpg
mkdir -p "$out"
rm -f "$out"/best-known-*.json # a design another seed beat is written again if it still stands
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
specs=()
for seed in $(seq 1 16); do specs+=("2000 10 $seed"); done
for seed in $(seq 1 8); do specs+=("10000 20 $seed"); done
for spec in "${specs[@]}"; do
    read -r users uavs seed <<<"$spec"
    name="u${users}-m${uavs}-s${seed}"
    $envpg instance generate --users "$users" --uavs "$uavs" --clusters "$uavs" --seed "$seed" \
        --out "$tmp/$name.json" >/dev/null
    $envpg oracle --instance "$tmp/$name.json" --seed 1 --out "$out/oracle-$name.json" >/dev/null
    oseeds="2 3 4"
    [ "$users" = 2000 ] || oseeds=2
    for oseed in $oseeds; do
        $envpg oracle --instance "$tmp/$name.json" --seed "$oseed" --out "$tmp/$name-seed$oseed.json" >/dev/null
    done
    # Designs found outside this search (warm-*.json: one warm restart from the k-means centres
    # of another draw, its `zeta0`) are rerun from their own ζ₀ and count towards the best known.
    for extra in "$out"/warm-*-"$name".json; do
        [ -f "$extra" ] || continue
        $envpg oracle --instance "$tmp/$name.json" --init "$extra" --restarts 1 --strategy warm \
            --out "$tmp/$name-extra.json" >/dev/null
        mv "$tmp/$name-extra.json" "$extra"
    done
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
    others = {p: json.load(open(p))["J"]
              for p in glob.glob(f"{tmp}/{name}-seed*.json") + glob.glob(f"{out}/warm-*-{name}.json")
              + glob.glob(f"{out}/earlier-*-{name}.json")}
    known = min([r["J"]] + list(others.values()))
    # Better beyond rounding: another seed reaching the same design is not a better one.
    better = [p for p, j in others.items() if j == known and j < r["J"] * (1 - 1e-9)]
    if better:  # keep the best design known, so that it can be recomputed too
        if not sorted(better)[0].startswith(f"{out}/"):
            os.replace(sorted(better)[0], f"{out}/best-known-{name}.json")
    else:
        known = r["J"]
    by_kind = {k: min((x["J"] for x in rs if x["kind"] == k), default=float("nan"))
               for k in ("anneal", "warm", "kick", "relocation")}
    rows.append((name, rs[0]["J"], by_kind, r["J"], known, best, d["fraction_best"], r["seconds"],
                 sum(x["seconds"] for x in rs)))
with open(f"{out}/table.md", "w") as f:
    f.write("# The oracle at scale: the default portfolio and its kicks against the single-rate anneal\n\n")
    f.write("Generated instances (`envpg instance generate --users U --uavs M --clusters M --seed S`), "
            "`envpg oracle --instance FILE --seed 1` (16 restarts, `auto` = portfolio at κ = 1, then 6 kicks and 4 relocations). "
            "*anneal* is restart 0, the single-rate anneal (cooling 0.8); *best known* is the best J of "
            "this run and of the same run with oracle seeds 2–4 (2,000 users) or 2 (10,000 users), kept as "
            "`best-known-*.json` where better, or a design found outside this search (`warm-*.json`: one warm "
            "restart from another draw of the users' k-means centres, rerun from its `zeta0`; `earlier-*.json`: "
            "the result file of an earlier version of the oracle, kept as it was); *warm* restarts "
            "start from the users' k-means centres; *kicks* are the warm restarts after them, from the best "
            "design so far moved by noise; *relocations* the colder warm restarts after those, from the best design "
            "so far with one UAV moved to serve a costly user; *oracle* is the result (best of all of them). "
            "Command: `bash results/oracle-scale/run.sh`.\n\n")
    f.write("| instance | anneal (restart 0) | best anneal | best warm | best kick | best relocation | oracle "
            "| vs anneal | best known | oracle vs best known | best restart | restarts at the best (±1e-4) | wall | CPU |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    for name, j0, by_kind, j, known, best, frac, wall, cpu in rows:
        f.write(f"| {name} | {j0:.6f} | {by_kind['anneal']:.6f} | {by_kind['warm']:.6f} | "
                f"{by_kind['kick']:.6f} | {by_kind['relocation']:.6f} | {j:.6f} | "
                f"{pct(j, j0)} | {known:.6f} | "
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
