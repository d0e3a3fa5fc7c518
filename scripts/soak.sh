#!/usr/bin/env bash
# Soak test (not in the default suite): one Table I-sized run (the bundled uav271, default
# settings, 2000 iterations) with a worker process SIGKILLed every few seconds and the learner
# SIGKILLed once and resumed, against the same run undisturbed. Prints both J's and whether the
# results are bitwise equal (every field but wall-clock seconds and the link's fault counters);
# exit 1 if they differ.
#
#   bash scripts/soak.sh [SEED] [KILL_EVERY_S]
set -euo pipefail
cd "$(dirname "$0")/.."
seed="${1:-1}"
every="${2:-2}"
cargo build --release --bin envpg-launch >/dev/null
bin=target/release/envpg-launch
work="$(mktemp -d)"
trap 'pkill -KILL -f "$work" 2>/dev/null || true; rm -rf "$work"' EXIT

echo "== undisturbed (--in-process, seed $seed)"
"$bin" --in-process --seed "$seed" --quiet --out "$work/reference.json"

echo "== disturbed: a worker killed every ${every} s, the learner killed once"
"$bin" --workers 2 --seed "$seed" --quiet --checkpoint-every 100 --run-dir "$work/run" \
    --out "$work/soak.json" 2>"$work/stderr1" &
launcher=$!
killed_workers=0
learner_killed=0
start=$(date +%s)
while kill -0 "$launcher" 2>/dev/null; do
    sleep "$every"
    pid=$(pgrep -f "worker --run-dir $work/run" | head -1 || true)
    if [ -n "$pid" ]; then kill -KILL "$pid" 2>/dev/null && killed_workers=$((killed_workers + 1)) || true; fi
    if [ "$learner_killed" = 0 ] && [ $(( $(date +%s) - start )) -ge $((3 * every)) ] \
        && [ -f "$work/run/checkpoint.bin" ]; then
        lpid=$(pgrep -f "learner --run-dir $work/run" | head -1 || true)
        if [ -n "$lpid" ]; then kill -KILL "$lpid" && learner_killed=1; fi
    fi
done
wait "$launcher" || true
if [ "$learner_killed" = 1 ]; then
    echo "   learner killed; resuming"
    "$bin" --resume "$work/run" --quiet 2>"$work/stderr2" &
    launcher=$!
    while kill -0 "$launcher" 2>/dev/null; do
        sleep "$every"
        pid=$(pgrep -f "worker --run-dir $work/run" | head -1 || true)
        if [ -n "$pid" ]; then kill -KILL "$pid" 2>/dev/null && killed_workers=$((killed_workers + 1)) || true; fi
    done
    wait "$launcher"
fi
echo "   workers killed: $killed_workers, learner killed: $learner_killed"

python3 - "$work/reference.json" "$work/soak.json" <<'PY'
import json, sys
def comparable(p):
    r = json.load(open(p))
    # Everything but wall-clock seconds and the link's counters (which record the faults).
    r.pop("seconds", None)
    r.pop("details", None)
    return r
a, b = comparable(sys.argv[1]), comparable(sys.argv[2])
print(f"undisturbed J = {a['J']!r}\ndisturbed   J = {b['J']!r}")
print("bitwise equal (every field but seconds and details):", a == b)
sys.exit(0 if a == b else 1)
PY
