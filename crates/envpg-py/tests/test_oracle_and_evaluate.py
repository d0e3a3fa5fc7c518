"""`envpg.oracle` is `envpg oracle`; `envpg.evaluate` recomputes J from a result's contents."""

import json
import subprocess

import pytest

import envpg


def test_the_oracle_gives_the_cli_oracles_result(envpg_tools, tmp_path):
    out = tmp_path / "cli.json"
    subprocess.run([str(envpg_tools), "oracle", "--instance", "flpo-n10m4", "--restarts", "2", "--seed", "4",
                    "--threads", "1", "--out", str(out)], check=True, timeout=600, capture_output=True)
    cli = json.loads(out.read_text())
    r = envpg.oracle("flpo-n10m4", restarts=2, seed=4, threads=1)
    assert r.method == "oracle"
    assert r.J == cli["J"] and r.raw["zeta"] == cli["zeta"] and r.raw["policy"] == cli["policy"]
    assert envpg.evaluate(r) == pytest.approx(r.J, rel=1e-12)


def test_instances_take_parameters_and_check_them():
    i = envpg.load_instance("uav271", kappa=0.9)
    assert i.env == "uav" and i.params["kappa"] == 0.9
    r = envpg.oracle(i, restarts=1, threads=1)
    assert r.instance.params["kappa"] == 0.9
    with pytest.raises(envpg.InputError, match="no-such"):
        envpg.load_instance("no-such-instance")
    with pytest.raises(envpg.InputError, match="frobnicate"):
        envpg.load_instance("uav271", frobnicate=1.0)
    with pytest.raises(envpg.InputError, match="finite"):
        envpg.load_instance("uav271", kappa=float("nan"))
    with pytest.raises(envpg.InputError):
        envpg.load_instance(42)
    assert {"uav", "aac", "flpo", "python"} <= {e["name"] for e in envpg.envs()["envs"]}


def test_evaluate_recomputes_rather_than_reads(tmp_path):
    r = envpg.oracle("flpo-n10m4", restarts=1, threads=1)
    forged = dict(r.raw, J=r.J / 2)
    path = tmp_path / "forged.json"
    path.write_text(json.dumps(forged))
    assert envpg.evaluate(path) == pytest.approx(r.J, rel=1e-12)
    bad = tmp_path / "bad.json"
    bad.write_text('{"schema": "envpg.result.v2"}')
    with pytest.raises(envpg.InputError, match="bad.json"):
        envpg.evaluate(bad)
    with pytest.raises(envpg.InputError):
        envpg.load_result(tmp_path / "missing.json")


def test_bad_oracle_settings_are_input_errors():
    with pytest.raises(envpg.InputError, match="no-such-option"):
        envpg.oracle("flpo-n10m4", restarts=1, no_such_option=3)
    with pytest.raises(envpg.InputError):
        envpg.oracle("flpo-n10m4", restarts=0)


def test_the_oracle_bar_counts_each_restart_and_kick_as_it_ends(monkeypatch):
    """``progress=True`` feeds a bar from the oracle's progress lines: one step per restart and
    kick, the run's total once known, the best J so far; the result is the one without a bar,
    and a refused setting is still an InputError with the CLI's message."""
    bars = []

    class Bar:
        def __init__(self, total, **_):
            self.total, self.n, self.postfix, self.closed = total, 0, {}, False
            bars.append(self)

        def set_postfix(self, refresh=True, **kw):
            self.postfix = kw

        def update(self, n):
            self.n += n

        def close(self):
            self.closed = True

    monkeypatch.setattr(envpg._run, "_tqdm", lambda enabled: Bar if enabled is not False else None)
    r = envpg.oracle("uav271", restarts=2, seed=3, progress=True)
    plain = envpg.oracle("uav271", restarts=2, seed=3, progress=False)
    assert len(bars) == 1, "progress=False draws no bar"
    bar, runs = bars[0], r.raw["details"]["restarts"]
    assert len(runs) > 2, "κ = 1: the portfolio's kicks follow the two restarts"
    assert bar.n == bar.total == len(runs) and bar.closed
    assert float(bar.postfix["best_J"]) == pytest.approx(r.J, abs=1e-6)
    assert r.J == plain.J and r.raw["zeta"] == plain.raw["zeta"] and r.raw["policy"] == plain.raw["policy"]
    with pytest.raises(envpg.InputError, match="threads must be at least 1"):
        envpg.oracle("uav271", restarts=1, threads=0, progress=True)
    assert bars[-1].closed
