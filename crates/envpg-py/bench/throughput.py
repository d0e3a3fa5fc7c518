"""Rollout throughput of an environment written in Python against the same environment in Rust.

    python crates/envpg-py/bench/throughput.py [--work-us 0,50] [--workers 1,2]

Runs ``--bench`` (collect-only rollouts of the default settings, ``--iterations`` 100: raw loop,
worker processes, median of 3 rounds) of the launcher on the queues of ``examples/queues`` twice: the Rust
environment (``target/release/queues-launch``, with ``--emulator-cost-us W`` of busy work in
Rust per step), and its Python port (``tests/queues_env.py``, with W µs of busy work inside the
Python ``step``). Prints transitions/s per worker count and the Python/Rust ratio.
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(HERE.parent / "tests"))

from queues_env import Queues  # noqa: E402

from envpg._pyenv import instance_of  # noqa: E402


class BusyQueues(Queues):
    """The queues with ``work_us`` µs of real Python work in every step."""

    def __init__(self, work_us=0):
        super().__init__()
        self.work_s = work_us * 1e-6

    def step(self, s, a, zeta, rng):
        if self.work_s:
            end = time.perf_counter() + self.work_s
            x = 0
            while time.perf_counter() < end:
                x = (x * 6364136223846793005 + 1) & 0xFFFFFFFF
        return super().step(s, a, zeta, rng)


def parse(text: str) -> dict[tuple[str, int], float]:
    out = {}
    for line in text.splitlines():
        m = re.match(r"^(raw|in-process|ipc)\s+(\d+)\s+(\d+)", line)
        if m:
            out[(m.group(1), int(m.group(2)))] = float(m.group(3))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work-us", default="0,50")
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--iterations", default="100", help="iterations of each measured round")
    ap.add_argument("--out", help="also write the figures as JSON here")
    args = ap.parse_args()
    rust_bin = ROOT / "target" / "release" / "queues-launch"
    if not rust_bin.exists():
        subprocess.run(["cargo", "build", "--release", "-p", "envpg-example-queues", "--bin", "queues-launch"],
                       cwd=ROOT, check=True)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), str(HERE.parent / "tests"), *sys.path]))
    rows = []
    for work in [int(w) for w in args.work_us.split(",")]:
        with tempfile.TemporaryDirectory() as d:
            inst = Path(d) / "busy.json"
            data = instance_of(BusyQueues(work_us=work))
            data["class"] = "throughput:BusyQueues"
            inst.write_text(json.dumps(data))
            bench = ["--bench", "--bench-workers", args.workers, "--iterations", args.iterations]
            py = subprocess.run([sys.executable, "-m", "envpg._launch", "--instance", str(inst), *bench],
                                capture_output=True, text=True, env=env, check=True, cwd=d)
            rust = subprocess.run([str(rust_bin), "--instance", "queues", "--emulator-cost-us", str(work), *bench],
                                  capture_output=True, text=True, check=True, cwd=d)
        p, r = parse(py.stdout), parse(rust.stdout)
        for workers in [int(w) for w in args.workers.split(",")]:
            key = ("ipc", workers)
            rows.append({"work_us": work, "workers": workers, "python": p[key], "rust": r[key]})
    print(f"{'work µs':>8} {'workers':>8} {'Python tr/s':>12} {'Rust tr/s':>12} {'Python/Rust':>12} {'scaling (Python)':>17}")
    for row in rows:
        one = next(x for x in rows if x["work_us"] == row["work_us"] and x["workers"] == 1)
        scaling = row["python"] / (one["python"] * row["workers"])
        print(f"{row['work_us']:>8} {row['workers']:>8} {row['python']:>12.0f} {row['rust']:>12.0f} "
              f"{row['python'] / row['rust']:>11.1%} {scaling:>16.0%}")
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
