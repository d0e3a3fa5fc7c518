"""Ctrl-C during `envpg.train` raises KeyboardInterrupt with every process of the run ended and
its shared memory removed, keeping a checkpoint that `envpg.resume` finishes with the result the
run would have given."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

from conftest import TESTS, run_processes, shm_segments

import envpg

SCRIPT = textwrap.dedent(
    """
    import sys
    sys.path.insert(0, {tests!r})
    import envpg
    from broken_envs import Slow
    try:
        envpg.train(Slow(), workers=2, seed=4, iterations=60, polish_iterations=0, checkpoint_every=1,
                    run_dir={run_dir!r}, progress=False)
    except KeyboardInterrupt:
        print("KeyboardInterrupt raised", flush=True)
        sys.exit(130)
    print("finished", flush=True)
    """
)


def test_ctrl_c_stops_everything_and_the_run_resumes_to_the_same_result(tmp_path):
    before = shm_segments()
    run_dir = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-c", SCRIPT.format(tests=str(TESTS), run_dir=str(run_dir))],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    metrics = run_dir / "metrics.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if metrics.exists() and len(metrics.read_text().splitlines()) > 6:
            break
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    os.kill(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (out, err)
    assert "KeyboardInterrupt raised" in out
    assert run_processes() == []
    assert shm_segments() <= before
    rows = len(metrics.read_text().splitlines()) - 1
    assert 5 <= rows < 60

    from broken_envs import Slow

    resumed = envpg.resume(run_dir, progress=False)
    whole = envpg.train(Slow(), workers=2, seed=4, iterations=60, polish_iterations=0, progress=False)
    assert resumed.raw["zeta"] == whole.raw["zeta"] and resumed.raw["policy"] == whole.raw["policy"]
    assert resumed.J == whole.J
    assert json.loads((run_dir / "result.json").read_text())["J"] == whole.J


def test_ctrl_c_stops_the_oracle_at_once():
    script = (
        "import sys, envpg\n"
        "try:\n"
        "    envpg.oracle('uav271', restarts=400, threads=1)\n"
        "except KeyboardInterrupt:\n"
        "    print('KeyboardInterrupt raised', flush=True)\n"
        "    sys.exit(130)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any("envpg._tools" in p for p in run_processes()):
        time.sleep(0.05)
    time.sleep(0.5)
    assert proc.poll() is None
    os.kill(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "KeyboardInterrupt raised" in out, (out, err)
    assert run_processes() == []
