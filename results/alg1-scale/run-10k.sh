#!/bin/bash
# Algorithm 1 (model-free, `envpg-launch --workers 2 --seed 1`) on the generated UAV instance
# with 10,000 users and 20 UAVs of results/oracle-scale (instance seed 1): the default preset
# `uav`, `uav-large`, `uav-large` with four times the episodes or three times the iterations,
# both presets from the users' k-means centres (`--zeta0 clustered`), and `uav-large` with two
# passes (`--passes 2`) from either ζ₀, the second pass from the first pass's design
# (`--pass-start best`, the default) or from a ζ₀ of its own (`--pass-start fresh`), three fresh
# passes from clustered ζ₀, three kicked passes from clustered ζ₀ (`--pass-start kick`: each later
# pass from the best design so far moved by noise), five warm passes from clustered ζ₀
# (`--pass-start warm`: kicked, with the best pass's networks, over the last quarter of the
# schedule), five portfolio passes from clustered ζ₀ (`--pass-start portfolio`: three fresh,
# then two warm), and one clustered pass with five times the polish's iterations, against
# the best design known there. Writes alg1-10k-*.json (result files: `envpg evaluate FILE`
# recomputes each J) and table-10k.md; result files already there are kept. Run from the
# repository root: bash results/alg1-scale/run-10k.sh (≈ 90 min on 2 cores).
set -euo pipefail
out=results/alg1-scale
cargo build --release --quiet --bin envpg --bin envpg-launch
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
name=u10000-m20-s1
./target/release/envpg instance generate --users 10000 --uavs 20 --clusters 20 --seed 1 --out "$tmp/$name.json" >/dev/null
run() { # FILE ARGS…
    local file=$1
    shift
    [ -f "$file" ] && return
    ENVPG_RUNS_DIR="$tmp/runs" ./target/release/envpg-launch --instance "$tmp/$name.json" --workers 2 --seed 1 \
        --quiet --out "$file" "$@"
}
run "$out/alg1-10k-uav.json" --preset uav
run "$out/alg1-10k-uav-large.json" --preset uav-large
run "$out/alg1-10k-uav-large-e128.json" --preset uav-large --episodes 128 --explore-episodes 64
run "$out/alg1-10k-uav-large-i6000.json" --preset uav-large --iterations 6000
run "$out/alg1-10k-uav-clustered.json" --preset uav --zeta0 clustered
run "$out/alg1-10k-uav-large-clustered.json" --preset uav-large --zeta0 clustered
run "$out/alg1-10k-uav-large-passes2-fresh.json" --preset uav-large --passes 2 --pass-start fresh
run "$out/alg1-10k-uav-large-clustered-passes2-fresh.json" --preset uav-large --zeta0 clustered --passes 2 \
    --pass-start fresh
run "$out/alg1-10k-uav-large-passes2.json" --preset uav-large --passes 2 --pass-start best
run "$out/alg1-10k-uav-large-clustered-passes2.json" --preset uav-large --zeta0 clustered --passes 2 \
    --pass-start best
run "$out/alg1-10k-uav-large-clustered-passes3-fresh.json" --preset uav-large --zeta0 clustered --passes 3 \
    --pass-start fresh
run "$out/alg1-10k-uav-large-clustered-pi400.json" --preset uav-large --zeta0 clustered --polish-iterations 400
run "$out/alg1-10k-uav-large-clustered-passes3-kick.json" --preset uav-large --zeta0 clustered --passes 3 \
    --pass-start kick
run "$out/alg1-10k-uav-large-clustered-passes5-warm.json" --preset uav-large --zeta0 clustered --passes 5 \
    --pass-start warm
run "$out/alg1-10k-uav-large-clustered-passes5-portfolio.json" --preset uav-large --zeta0 clustered --passes 5 \
    --pass-start portfolio
python3 - "$out" "$name" <<'PY'
import glob, json, sys
out, name = sys.argv[1:]
best = min(json.load(open(f))["J"] for f in glob.glob(f"results/oracle-scale/*-{name}.json"))
with open(f"{out}/table-10k.md", "w") as f:
    f.write("# Algorithm 1 at 10,000 users against the best design known\n\n")
    f.write("Generated instance `envpg instance generate --users 10000 --uavs 20 --clusters 20 --seed 1`, "
            "`envpg-launch --instance FILE --workers 2 --seed 1 --preset P [settings]` (model-free, with the ζ polish); "
            f"*best known* {best:.6f} from [oracle-scale](../oracle-scale/table.md). *alone*: Algorithm 1 before the "
            "polish (of the kept pass, with `--passes`). Command: `bash results/alg1-scale/run-10k.sh`.\n\n")
    f.write("| preset | settings | J | vs best known | alone vs best known | wall | transitions |\n|---|---|---|---|---|---|---|\n")
    for file, preset, settings in ((f"{out}/alg1-10k-uav.json", "uav", "—"),
                                   (f"{out}/alg1-10k-uav-large.json", "uav-large", "—"),
                                   (f"{out}/alg1-10k-uav-large-e128.json", "uav-large",
                                    "`--episodes 128 --explore-episodes 64`"),
                                   (f"{out}/alg1-10k-uav-large-i6000.json", "uav-large", "`--iterations 6000`"),
                                   (f"{out}/alg1-10k-uav-clustered.json", "uav", "`--zeta0 clustered`"),
                                   (f"{out}/alg1-10k-uav-large-clustered.json", "uav-large", "`--zeta0 clustered`"),
                                   (f"{out}/alg1-10k-uav-large-passes2-fresh.json", "uav-large",
                                    "`--passes 2 --pass-start fresh`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-passes2-fresh.json", "uav-large",
                                    "`--zeta0 clustered --passes 2 --pass-start fresh`"),
                                   (f"{out}/alg1-10k-uav-large-passes2.json", "uav-large",
                                    "`--passes 2 --pass-start best`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-passes2.json", "uav-large",
                                    "`--zeta0 clustered --passes 2 --pass-start best`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-passes3-fresh.json", "uav-large",
                                    "`--zeta0 clustered --passes 3 --pass-start fresh`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-pi400.json", "uav-large",
                                    "`--zeta0 clustered --polish-iterations 400`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-passes3-kick.json", "uav-large",
                                    "`--zeta0 clustered --passes 3 --pass-start kick`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-passes5-warm.json", "uav-large",
                                    "`--zeta0 clustered --passes 5 --pass-start warm`"),
                                   (f"{out}/alg1-10k-uav-large-clustered-passes5-portfolio.json", "uav-large",
                                    "`--zeta0 clustered --passes 5 --pass-start portfolio`")):
        r = json.load(open(file))
        before = ((r.get("details") or {}).get("polish") or {}).get("J_before")
        alone = f"{100 * (before / best - 1):+.2f}%" if before else "—"
        f.write(f"| `{preset}` | {settings} | {r['J']:.6f} | {100 * (r['J'] / best - 1):+.2f}% | {alone} | "
                f"{r['seconds']:.0f} s | {r['details']['transitions']} |\n")
print(open(f"{out}/table-10k.md").read())
PY
# Committed result files keep what recomputing J needs: history, policy_soft dropped, compact JSON.
python3 results/alg1-scale/compact.py "$out"/alg1-10k-*.json
