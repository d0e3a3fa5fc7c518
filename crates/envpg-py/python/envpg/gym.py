"""Any envpg environment as a ``gymnasium.Env``: ``envpg.gym.make("uav271", kappa=0.9)``.

Observations are the state (``Discrete(n_states)``), actions the global actions
(``Discrete(n_actions)``), the reward the negative cost of the transition. The design ζ is the
attribute ``env.zeta`` (checked against the bounds; set it between episodes). ``info`` carries
the valid-action mask of the new state (``"action_mask"``, int8, as Gymnasium's own masked
environments do), the transition's ``"cost"`` and ``"zeta"``.

An action that is not valid in the current state leaves the state unchanged and costs
``invalid_action_cost`` (default: the environment's cost scale, the order of one episode's
cost), with ``info["invalid_action"] = True`` — as Gymnasium's Taxi treats illegal moves — or
raises ``ValueError`` with ``invalid_action="raise"``. Episodes end (``terminated``) in terminal
states; ``max_episode_steps`` truncates them (needed for discounted problems without terminal
states, such as the queues).

Every random draw comes from envpg's ChaCha streams, seeded from ``reset(seed=…)`` through
``self.np_random``: the same seed replays the same episodes. Only the sampler is used; the
model is never touched.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from . import _native
from ._instance import Instance, load_instance

__all__ = ["EnvpgEnv", "make"]


class EnvpgEnv(gymnasium.Env):
    """An envpg instance's sampler as a Gymnasium environment (see the module docs)."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        instance: Instance | str = "uav271",
        zeta: Any = None,
        invalid_action: str = "penalty",
        invalid_action_cost: float | None = None,
        max_episode_steps: int | None = None,
    ):
        inst = instance if isinstance(instance, Instance) else load_instance(instance)
        if inst.env == "python":
            raise _native.InputError("envpg.gym wraps registered environments; a Python environment is already Python")
        if invalid_action not in ("penalty", "raise"):
            raise _native.InputError(f"invalid_action={invalid_action!r}: choose 'penalty' or 'raise'")
        if max_episode_steps is not None and max_episode_steps < 1:
            raise _native.InputError(f"max_episode_steps={max_episode_steps}: must be at least 1")
        self.instance = inst
        self._sim = _native.Sampler(inst.to_json())
        self.observation_space = spaces.Discrete(self._sim.n_states)
        self.action_space = spaces.Discrete(self._sim.n_actions)
        self.invalid_action = invalid_action
        self.invalid_action_cost = float(self._sim.cost_scale if invalid_action_cost is None else invalid_action_cost)
        self.max_episode_steps = max_episode_steps
        self.gamma = self._sim.gamma
        self.zeta_names = list(self._sim.zeta_names)
        self.zeta_low = np.asarray(self._sim.zeta_low)
        self.zeta_high = np.asarray(self._sim.zeta_high)
        self._zeta = np.asarray(self._sim.initial_design(), dtype=np.float64)
        if zeta is not None:
            self.zeta = zeta
        self._state: int | None = None
        self._steps = 0

    @property
    def zeta(self) -> np.ndarray:
        """The design ζ the environment is stepped at (a copy)."""
        return self._zeta.copy()

    @zeta.setter
    def zeta(self, value: Any) -> None:
        z = np.asarray(value, dtype=np.float64)
        if z.shape != self._zeta.shape:
            raise ValueError(f"zeta has shape {z.shape}, the design has {self._zeta.shape}")
        if not np.isfinite(z).all():
            raise ValueError(f"zeta must be finite, got {z}")
        self._sim.check_zeta(z.tolist())
        self._zeta = z.copy()

    def action_mask(self, state: int | None = None) -> np.ndarray:
        """The valid actions of ``state`` (default: the current one) as an int8 mask."""
        s = self._state if state is None else state
        mask = np.zeros(self._sim.n_actions, dtype=np.int8)
        if s is not None:
            mask[self._sim.valid_actions(int(s))] = 1
        return mask

    def _info(self, **extra: Any) -> dict[str, Any]:
        return {"action_mask": self.action_mask(), "zeta": self.zeta, **extra}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if options and "zeta" in options:
            self.zeta = options["zeta"]
        self._sim.seed(int(self.np_random.integers(0, 2**63)))
        self._state = int(self._sim.initial_state())
        self._steps = 0
        return self._state, self._info()

    def step(self, action: Any):
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        if self._sim.is_terminal(self._state):
            raise RuntimeError("the episode has terminated: call reset()")
        a = int(action)
        self._steps += 1
        valid = self._sim.valid_actions(self._state)
        if a in valid:
            nxt, cost = self._sim.step(self._state, a, self._zeta.tolist())
            invalid = False
        elif self.invalid_action == "raise" or not 0 <= a < self._sim.n_actions:
            raise ValueError(f"action {a} is not valid in state {self._state} (valid: {valid})")
        else:
            nxt, cost, invalid = self._state, self.invalid_action_cost, True
        self._state = int(nxt)
        terminated = bool(self._sim.is_terminal(self._state))
        truncated = self.max_episode_steps is not None and self._steps >= self.max_episode_steps and not terminated
        return self._state, -float(cost), terminated, truncated, self._info(cost=float(cost), invalid_action=invalid)


def make(instance: Instance | str = "uav271", **kwargs: Any) -> EnvpgEnv:
    """A Gymnasium environment of a bundled instance or an instance file. Keywords that are
    parameters of the instance's environment (``kappa=0.9``) override them; the rest go to
    :class:`EnvpgEnv` (``zeta``, ``invalid_action``, ``invalid_action_cost``,
    ``max_episode_steps``)."""
    options = {k: kwargs.pop(k) for k in ("zeta", "invalid_action", "invalid_action_cost", "max_episode_steps") if k in kwargs}
    return EnvpgEnv(load_instance(instance, **kwargs), **options)


def _register() -> None:
    """``gymnasium.make("envpg/uav271")`` for every bundled instance."""
    for name in _native_bundled():
        env_id = f"envpg/{name}"
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="envpg.gym:make", kwargs={"instance": name})


def _native_bundled() -> list[str]:
    import json

    return list(json.loads(_native.envs())["bundled"])


_register()
