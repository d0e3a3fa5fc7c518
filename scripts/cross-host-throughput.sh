#!/usr/bin/env bash
# Training throughput with the workers on another "host": the learner in one network namespace,
# the workers in another behind a veth pair, on this machine — to set beside the throughput
# model's predictions (docs/training.md#throughput). Needs root, iproute2 and the multi-host
# build:
#   cargo build --release --bin envpg-launch --features envpg-launch/multi-host
#   sudo bash scripts/cross-host-throughput.sh OUT_DIR [ITERATIONS]
# For each emulator cost (0 and 50 µs a step) and worker count W (1, 2) it runs the same
# training twice, `--polish-iterations 0`, seed 1: W local workers, then W workers on the
# other host (`--workers 0 --listen` and `worker --connect --workers W`), and prints the
# steady rate of each from its metrics.csv: transitions per second from iteration 50 to the
# last (the remote run's start waits for the host to join, which the result file's overall
# rate would count).
set -euo pipefail
out=${1:?usage: scripts/cross-host-throughput.sh OUT_DIR [ITERATIONS]}
iterations=${2:-300}
bin=${BIN:-target/release/envpg-launch}
"$bin" --help | grep -q -- '--listen' || { echo "$bin lacks --listen: build it with --features envpg-launch/multi-host" >&2; exit 2; }
mkdir -p "$out"
a=envpg-xa b=envpg-xb
cleanup() { ip netns del "$a" 2>/dev/null || true; ip netns del "$b" 2>/dev/null || true; }
trap cleanup EXIT
cleanup
ip netns add "$a"
ip netns add "$b"
ip link add envpgxa type veth peer name envpgxb
ip link set envpgxa netns "$a"
ip link set envpgxb netns "$b"
ip -n "$a" addr add 10.99.1.1/24 dev envpgxa
ip -n "$b" addr add 10.99.1.2/24 dev envpgxb
ip -n "$a" link set envpgxa up
ip -n "$b" link set envpgxb up
rate() {
  python3 - "$1/metrics.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
done = lambda r: float(r["transitions_per_s"]) * float(r["seconds"])
a, b = rows[min(50, len(rows) // 4)], rows[-1]
print(round((done(b) - done(a)) / (float(b["seconds"]) - float(a["seconds"]))))
PY
}
printf '%-10s %-8s %-14s %-14s %s\n' cost_us workers local_tr/s cross_tr/s cross/local
for cost in 0 50; do
  for w in 1 2; do
    common=(--iterations "$iterations" --polish-iterations 0 --seed 1 --emulator-cost-us "$cost" --quiet)
    rm -rf "$out/local-$cost-$w" "$out/cross-$cost-$w"
    "$bin" --workers "$w" "${common[@]}" --run-dir "$out/local-$cost-$w" --out "$out/local-$cost-$w.json" > /dev/null
    ip netns exec "$a" "$bin" --workers 0 --listen tcp/10.99.1.1:7447 "${common[@]}" \
      --run-dir "$out/cross-$cost-$w" --out "$out/cross-$cost-$w.json" > /dev/null &
    learner=$!
    sleep 1
    ip netns exec "$b" "$bin" worker --connect tcp/10.99.1.1:7447 --workers "$w" > /dev/null 2>&1 &
    host=$!
    wait "$learner"
    wait "$host" || true
    l=$(rate "$out/local-$cost-$w")
    c=$(rate "$out/cross-$cost-$w")
    printf '%-10s %-8s %-14s %-14s %s\n' "$cost" "$w" "$l" "$c" "$(python3 -c "print(f'{$c/$l:.2f}')")"
  done
done
