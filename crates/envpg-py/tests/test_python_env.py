"""Environments written in Python: trained by the Rust learner with Python worker processes,
bit for bit the result of the same environment written in Rust."""

import json
import subprocess

import pytest
from conftest import SHORT
from queues_env import Queues

import envpg


def test_a_python_port_of_a_rust_env_gives_its_result_bit_for_bit(queues_launch, tmp_path):
    out = tmp_path / "rust.json"
    subprocess.run([str(queues_launch), "--instance", "queues", "--workers", "2", "--iterations", "40",
                    "--polish-iterations", "0", "--seed", "5", "--out", str(out), "--quiet"], check=True, timeout=600)
    rust = json.loads(out.read_text())
    # The Rust env's preset is the default with σ = 0.1.
    r = envpg.train(Queues(), workers=2, seed=5, sigma=0.1, progress=False, **SHORT)
    assert r.env == "python" and r.instance.data["class"] == "queues_env:Queues"
    for key in ("zeta", "zeta0", "policy", "J", "J_H", "policy_soft"):
        assert r.raw.get(key) == rust.get(key), key
    for a, b in zip(r.raw["history"], rust["history"], strict=True):
        assert (a["zeta"], a.get("J_exact"), a.get("grad_norm")) == (b["zeta"], b.get("J_exact"), b.get("grad_norm"))
    assert envpg.evaluate(r) == pytest.approx(r.J, rel=1e-12)


def test_any_worker_count_gives_the_same_result():
    one = envpg.train(Queues(buffer=3), workers=1, seed=2, progress=False, **SHORT)
    three = envpg.train(Queues(buffer=3), workers=3, seed=2, progress=False, **SHORT)
    assert one.raw["zeta"] == three.raw["zeta"] and one.raw["policy"] == three.raw["policy"]
    assert one.instance.data["config"]["buffer"] == 3


def test_a_black_box_trains_and_the_model_only_calls_refuse_it():
    r = envpg.train(Queues(model=False), workers=2, progress=False, **SHORT)
    assert r.J is None and r.zeta.shape == (2,)
    with pytest.raises(envpg.InputError, match="no model"):
        envpg.evaluate(r)


def test_the_oracle_runs_on_a_python_model():
    r = envpg.oracle(Queues(buffer=2), restarts=1, threads=1)
    assert r.J is not None and r.J > 0
    assert envpg.evaluate(r) == pytest.approx(r.J, rel=1e-9)


def test_a_clustered_design_hook_starts_training_and_the_portfolios_warm_restarts():
    from queues_env import ClusteredQueues

    r = envpg.train(ClusteredQueues(), workers=1, seed=3, zeta0="clustered", progress=False, **SHORT)
    assert all(0.4 <= z <= 0.6 for z in r.raw["zeta0"]), r.raw["zeta0"]
    o = envpg.oracle(ClusteredQueues(), restarts=2, threads=1, strategy="portfolio")
    warm = o.raw["details"]["restarts"][1]
    assert warm["kind"] == "warm" and all(0.4 <= z <= 0.6 for z in warm["zeta0"]), warm
    with pytest.raises(envpg.InputError, match="clustered"):
        envpg.train(ClusteredQueues(outside=True), workers=1, zeta0="clustered", progress=False, **SHORT)
    with pytest.raises(envpg.InputError, match="restart 1"):
        envpg.oracle(ClusteredQueues(outside=True), restarts=2, threads=1, strategy="portfolio")
    with pytest.raises(envpg.InputError, match="no clustered design"):
        envpg.train(Queues(), workers=1, zeta0="clustered", progress=False, **SHORT)


def test_constructor_arguments_are_recorded_by_name():
    from broken_envs import TakesStar

    from envpg._pyenv import instance_of

    assert instance_of(Queues(3, hold=2.0))["config"] == {"buffer": 3, "hold": 2.0}
    assert instance_of(TakesStar())["config"] == {}
    with pytest.raises(envpg.InputError, match="positional arguments"):
        envpg.train(TakesStar(1, 2), progress=False)
