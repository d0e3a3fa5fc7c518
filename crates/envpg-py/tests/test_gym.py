"""`envpg.gym.make` gives a `gymnasium.Env` that passes Gymnasium's checker."""

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envpg
import envpg.gym


@pytest.mark.parametrize("name", ["uav271", "flpo-n10m4", "aac1800"])
def test_every_bundled_instance_passes_the_env_checker(name):
    env = envpg.gym.make(name, max_episode_steps=64)
    check_env(env, skip_render_check=True)
    assert env.observation_space == gymnasium.spaces.Discrete(env._sim.n_states)
    assert env.action_space == gymnasium.spaces.Discrete(env._sim.n_actions)


def test_registered_ids_and_parameters():
    env = gymnasium.make("envpg/uav271", kappa=0.9)
    assert env.unwrapped.instance.params["kappa"] == 0.9


def test_the_mask_the_design_and_invalid_actions():
    env = envpg.gym.make("uav271")
    s, info = env.reset(seed=7)
    mask = info["action_mask"]
    assert mask.dtype == np.int8 and mask.sum() >= 1
    invalid = [a for a in range(env.action_space.n) if not mask[a]]
    valid = int(np.flatnonzero(mask)[0])
    if invalid:
        s2, reward, terminated, truncated, info2 = env.step(invalid[0])
        assert s2 == s and info2["invalid_action"] and reward == -env.invalid_action_cost
        strict = envpg.gym.make("uav271", invalid_action="raise")
        strict.reset(seed=7)
        with pytest.raises(ValueError, match="not valid"):
            strict.step(invalid[0])
    _, reward, _, _, info3 = env.step(valid)
    assert reward == -info3["cost"] and not info3["invalid_action"]
    with pytest.raises(ValueError, match="finite"):
        env.zeta = np.full_like(env.zeta, np.nan)
    bounded = envpg.gym.make("flpo-n10m4")
    with pytest.raises(ValueError):
        bounded.zeta = np.full_like(bounded.zeta, 2.0)
    with pytest.raises(ValueError, match="shape"):
        env.zeta = [1.0]
    z = env.zeta
    z[0] += 0.5
    env.zeta = z
    assert env.zeta[0] == z[0]


def test_the_same_seed_replays_the_same_episode():
    def episode(seed, zeta=None):
        env = envpg.gym.make("flpo-n10m4", zeta=zeta)
        s, info = env.reset(seed=seed)
        trace = [s]
        for _ in range(50):
            a = int(np.flatnonzero(info["action_mask"])[0])
            s, r, term, trunc, info = env.step(a)
            trace.append((s, r))
            if term:
                break
        return trace

    assert episode(3) == episode(3)
    env = envpg.gym.make("flpo-n10m4")
    moved = np.clip(env.zeta + 0.1, env.zeta_low, env.zeta_high)
    assert episode(3) != episode(3, zeta=moved)
