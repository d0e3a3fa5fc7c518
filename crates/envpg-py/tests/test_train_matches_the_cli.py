"""`envpg.train` is `envpg-launch`: the same seed and settings give the same result bit for bit,
for any worker count."""

import json
import subprocess

import numpy as np
import pytest
from conftest import SHORT

import envpg

#: Result fields that must agree bit for bit (timings and transport counters may differ).
SAME = ("env", "instance", "seed", "zeta", "zeta0", "policy", "J", "J_H", "alpha_final", "policy_soft")


def same_result(a: dict, b: dict) -> None:
    for key in SAME:
        assert a.get(key) == b.get(key), key
    for ra, rb in zip(a["history"], b["history"], strict=True):
        for key in ("k", "alpha", "j_h_estimate", "grad_norm", "zeta", "J_exact"):
            assert ra.get(key) == rb.get(key), (ra["k"], key)


def cli_run(binary, tmp_path, *args) -> dict:
    out = tmp_path / "cli.json"
    subprocess.run([str(binary), *args, "--out", str(out), "--quiet"], check=True, timeout=600)
    return json.loads(out.read_text())


def test_train_gives_the_launchers_result_bit_for_bit(envpg_launch, tmp_path):
    cli = cli_run(envpg_launch, tmp_path, "--instance", "flpo-n10m4", "--workers", "2", "--seed", "3",
                  "--iterations", "40", "--polish-iterations", "0")
    for workers in (1, 2):
        r = envpg.train("flpo-n10m4", workers=workers, seed=3, progress=False, **SHORT)
        same_result(r.raw, cli)
    r = envpg.train("flpo-n10m4", workers=2, seed=3, in_process=True, progress=False, **SHORT)
    same_result(r.raw, cli)


def test_the_default_run_matches_the_readme_command(envpg_launch, tmp_path):
    cli = cli_run(envpg_launch, tmp_path, "--workers", "2")
    r = envpg.train(workers=2, progress=False)
    same_result(r.raw, cli)
    assert r.J == cli["J"]


def test_a_result_has_numpy_views_and_saves_as_the_cli_writes_it(envpg_launch, tmp_path):
    cli_path = tmp_path / "cli.json"
    subprocess.run([str(envpg_launch), "--instance", "flpo-n10m4", "--iterations", "40", "--polish-iterations", "0",
                    "--out", str(cli_path), "--quiet"], check=True, timeout=600)
    r = envpg.load_result(cli_path)
    assert r.method == "envpg-ac" and r.env == "flpo"
    assert isinstance(r.zeta, np.ndarray) and r.zeta.shape == (len(r.raw["zeta"]),)
    assert r.policy.shape == (len(r.raw["policy"]), len(r.raw["policy"][0]))
    np.testing.assert_allclose(r.policy.sum(axis=1), 1.0, atol=1e-9)
    h = r.history
    assert h["k"].tolist() == list(range(40))
    assert h["zeta"].shape == (40, r.zeta.size)
    assert np.isfinite(h["J_exact"]).sum() >= 1
    copy = tmp_path / "copy.json"
    r.save(copy)
    assert copy.read_bytes() == cli_path.read_bytes()
    assert envpg.evaluate(cli_path) == pytest.approx(r.J, rel=1e-9)
    assert envpg.evaluate(r) == pytest.approx(r.J, rel=1e-9)


def test_the_run_directory_keeps_metrics_and_the_result(runs_dir):
    r = envpg.train("flpo-n10m4", progress=False, **SHORT)
    assert r.run_dir.parent == runs_dir
    rows = (r.run_dir / "metrics.csv").read_text().splitlines()
    assert len(rows) == 1 + SHORT["iterations"]
    assert json.loads((r.run_dir / "result.json").read_text())["J"] == r.J


def test_passes_keep_each_pass_in_its_directory_and_the_best_as_the_result(envpg_launch, tmp_path, runs_dir):
    cli = cli_run(envpg_launch, tmp_path, "--instance", "flpo-n10m4", "--workers", "2", "--seed", "2",
                  "--iterations", "30", "--polish-iterations", "2", "--passes", "2", "--pass-start", "best")
    r = envpg.train("flpo-n10m4", seed=2, iterations=30, polish_iterations=2, passes=2, pass_start="best",
                    progress=False)
    same_result(r.raw, cli)
    runs = r.raw["details"]["passes"]["runs"]
    assert [p["pass"] for p in runs] == [1, 2]
    # pass_start="best": the second pass starts where the first ended.
    assert runs[1]["zeta0"] == runs[0]["zeta"]
    for p in (1, 2):
        rows = (r.run_dir / f"pass-{p}" / "metrics.csv").read_text().splitlines()
        assert len(rows) == 1 + 30


@pytest.mark.parametrize("start", ["warm", "portfolio"])
def test_the_progress_bar_counts_the_iterations_every_pass_trains(start, runs_dir):
    # Four passes of 30 iterations: `warm` trains 30 + 3 × 8, `portfolio` 2 × 30 + 2 × 8
    # (its first half fresh); the bar's total is what the passes' metrics record.
    r = envpg.train("flpo-n10m4", seed=2, iterations=30, polish_iterations=0, passes=4, pass_start=start,
                    progress=False)
    trained = sum(len((r.run_dir / f"pass-{p}" / "metrics.csv").read_text().splitlines()) - 1 for p in range(1, 5))
    assert trained == {"warm": 54, "portfolio": 76}[start]
    run = json.loads((r.run_dir / "run.json").read_text())
    assert envpg._run.planned_iterations(run) == trained
