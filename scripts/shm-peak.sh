#!/usr/bin/env bash
# Runs a command (a training run) and reports the peak, over the run, of the shared memory its
# iceoryx2 segments in /dev/shm reserve (apparent size) and touch (allocated blocks), and the
# peak resident memory (VmHWM) of its learner and worker processes. Polls every 50 ms.
#
#   bash scripts/shm-peak.sh target/release/envpg-launch --workers 8 --iterations 100 --quiet
set -u
[ $# -gt 0 ] || { echo "usage: $0 COMMAND [ARGS…]" >&2; exit 2; }
"$@" > /dev/null &
pid=$!
reserved=0 touched=0 largest=0 learner=0 worker=0
max() { if (( $2 > $1 )); then echo "$2"; else echo "$1"; fi; }
# Peak resident memory (VmHWM, kB) of the largest process of a role: the kernel's own
# high-water mark, so short peaks between two polls count too.
rss() {
    for p in $(pgrep -f "envpg-launch.* $1( |$)"); do awk '/^VmHWM/ {print $2}' "/proc/$p/status" 2>/dev/null; done |
        sort -n | tail -1
}
while kill -0 "$pid" 2>/dev/null; do
    sizes=$(find /dev/shm -maxdepth 1 -name 'iox2_*' -printf '%s\n' 2>/dev/null || true)
    r=$(echo "$sizes" | awk '{s += $1} END {print s + 0}')
    b=$(echo "$sizes" | sort -n | tail -1)
    t=$(find /dev/shm -maxdepth 1 -name 'iox2_*' -printf '%b\n' 2>/dev/null | awk '{s += $1 * 512} END {print s + 0}')
    l=$(rss learner) w=$(rss worker)
    reserved=$(max "$reserved" "$r") largest=$(max "$largest" "${b:-0}") touched=$(max "$touched" "$t")
    learner=$(max "$learner" "${l:-0}") worker=$(max "$worker" "${w:-0}")
    sleep 0.05
done
status=0
wait "$pid" || status=$?
mib() { awk -v b="$1" 'BEGIN {printf "%.1f MiB", b / 1048576}'; }
echo "exit $status; /dev/shm: reserved $(mib "$reserved") (largest segment $(mib "$largest")), touched $(mib "$touched"); peak RSS: learner $(mib $((learner * 1024))), worker $(mib $((worker * 1024)))"
