"""Bad input is an `InputError` before any work; a failing environment an `EnvError` with its
traceback; neither leaves processes or shared memory behind."""

import pytest
from broken_envs import BadActions, BadConstructor, HugeStates, LeavesTheStates, Raises, ReturnsNaN
from conftest import SHORT, run_processes, shm_segments
from queues_env import Queues

import envpg


@pytest.fixture(autouse=True)
def nothing_left_behind():
    before = shm_segments()
    yield
    assert run_processes() == []
    assert shm_segments() <= before


def test_an_exception_in_step_stops_the_run_with_its_traceback():
    with pytest.raises(envpg.EnvError) as e:
        envpg.train(Raises(), workers=2, progress=False, **SHORT)
    text = str(e.value)
    assert "ZeroDivisionError: the simulator broke" in text
    assert "Traceback (most recent call last)" in text and "broken_envs.py" in text and "in step" in text


@pytest.mark.parametrize(
    ("env", "match"),
    [(ReturnsNaN(), "returned the cost NaN"), (LeavesTheStates(), "not a state in 0..25")],
)
def test_invalid_returns_are_named(env, match):
    with pytest.raises(envpg.EnvError, match=match):
        envpg.train(env, workers=1, progress=False, **SHORT)


def test_an_environment_that_cannot_be_built_is_bad_input():
    with pytest.raises(envpg.InputError, match="(?s)Traceback.*FileNotFoundError.*simulator-file"):
        envpg.train(BadConstructor(), progress=False)
    with pytest.raises(envpg.InputError, match="increasing"):
        envpg.train(BadActions(), progress=False)
    with pytest.raises(envpg.InputError, match="at most 4294967295.*got 1099511627776"):
        envpg.train(HugeStates(), progress=False)
    with pytest.raises(envpg.InputError, match="is not an environment"):
        envpg.train(object(), progress=False)

    class Local(Queues):
        pass

    with pytest.raises(envpg.InputError, match="inside a function"):
        envpg.train(Local(), progress=False)
    with pytest.raises(envpg.InputError, match="in_process"):
        envpg.train(Queues(), in_process=True, progress=False)


def test_bad_settings_are_refused_before_any_work(tmp_path, runs_dir):
    with pytest.raises(envpg.InputError, match="no-such-setting"):
        envpg.train("flpo-n10m4", no_such_setting=1, progress=False)
    with pytest.raises(envpg.InputError, match="iterations"):
        envpg.train("flpo-n10m4", iterations="many", progress=False)
    with pytest.raises(envpg.InputError, match="workers"):
        envpg.train("flpo-n10m4", workers="2", progress=False)
    with pytest.raises(envpg.InputError, match="finite"):
        envpg.train("flpo-n10m4", sigma=float("nan"), progress=False)
    with pytest.raises(envpg.InputError, match="list of numbers"):
        envpg.train("flpo-n10m4", sigma={"a": 1}, progress=False)
    with pytest.raises(envpg.InputError, match="--out"):
        envpg.train("flpo-n10m4", out=tmp_path, progress=False)
    with pytest.raises(envpg.InputError, match="--out"):
        envpg.train("flpo-n10m4", out="/proc/envpg/result.json", progress=False)
    assert not runs_dir.exists() or not any(runs_dir.rglob("metrics.csv"))
