#!/usr/bin/env bash
# The Python package's tests: builds `crates/envpg-py` into a fresh virtual environment (as a user's
# `pip install ./crates/envpg-py` does: maturin from PyPI, the Rust build in the workspace's
# target directory) and runs its pytest suite against the CLI binaries of the same workspace.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="target/tmp/python-tests-venv"
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --upgrade pip
"$venv/bin/pip" install --quiet "./crates/envpg-py[test,progress]"
cargo build --release --bin envpg-launch --bin envpg --bin queues-launch
cd crates/envpg-py
# A hung test has its stacks dumped after 600 s (pyproject.toml); the session ends at 30 min.
timeout 1800 "../../$venv/bin/python" -m pytest -q "$@"
