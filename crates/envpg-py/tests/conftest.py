"""Shared fixtures: the CLI binaries built from the same workspace (the Python results are
checked against them) and a private runs directory per test. A test that hangs has every
thread's stack dumped after 600 s (`faulthandler_timeout` in pyproject.toml); the runner's
`timeout` ends the session."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
TESTS = Path(__file__).resolve().parent
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release"

# The environments written for the tests are imported by the runs' worker processes too.
sys.path.insert(0, str(TESTS))

#: Settings of a short Algorithm 1 run (seconds, not minutes).
SHORT = {"iterations": 40, "polish_iterations": 0}


def cli_binary(name: str, package: str) -> Path:
    """A release binary of the workspace, built if it is missing."""
    path = TARGET / name
    if not path.exists():
        subprocess.run(["cargo", "build", "--release", "-p", package, "--bin", name], cwd=ROOT, check=True)
    return path


@pytest.fixture(scope="session")
def envpg_launch() -> Path:
    return cli_binary("envpg-launch", "envpg-launch")


@pytest.fixture(scope="session")
def envpg_tools() -> Path:
    return cli_binary("envpg", "envpg-cli")


@pytest.fixture(scope="session")
def queues_launch() -> Path:
    return cli_binary("queues-launch", "envpg-example-queues")


@pytest.fixture(autouse=True)
def runs_dir(tmp_path, monkeypatch):
    """Each test's runs go to its own directory."""
    d = tmp_path / "runs"
    monkeypatch.setenv("ENVPG_RUNS_DIR", str(d))
    monkeypatch.chdir(tmp_path)
    return d


def run_processes() -> list[str]:
    """The command lines of running processes of envpg runs (learners and workers)."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if "envpg._launch" in cmd or "envpg._tools" in cmd:
            out.append(cmd)
    return out


def shm_segments() -> set[str]:
    """iceoryx2's files in /dev/shm."""
    try:
        return {n for n in os.listdir("/dev/shm") if n.startswith("iox2_")}
    except OSError:
        return set()
