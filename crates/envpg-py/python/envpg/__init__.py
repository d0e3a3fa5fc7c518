"""envpg: co-design in reinforcement learning with the Environment Parameter Gradient theorem.

A control policy and the design ζ of the environment are learnt together, model-free, by
Algorithm 1 (an actor–critic with the EnvPG gradient). The learner and the rollout workers are
envpg's Rust ones; this package runs them from Python and brings the results back as numpy
arrays.

- :func:`load_instance` — a bundled instance (``"uav271"``, ``"aac1800"``, ``"flpo-n10m4"``) or
  an instance file, with parameter overrides.
- :func:`train` — Algorithm 1 with a learner and ``workers`` rollout-worker processes, on an
  instance or on an environment written in Python (:class:`Env`).
- :func:`oracle` — the model-based oracle with exact gradients (for reporting).
- :func:`evaluate` — the exact J of a result, recomputed from its own contents.
- :func:`check_env` — an environment's model derivatives against finite differences, its
  sampler against its model.
- :class:`Result` / :func:`load_result` — the ``envpg.result.v2`` files the CLI writes.
- :mod:`envpg.gym` — any environment as a ``gymnasium.Env``.
"""

from ._native import EnvCheckError, EnvError, InputError, Rng, RunError, __version__
from ._instance import Instance, envs, load_instance
from ._pyenv import Env
from ._result import Result, load_result
from ._run import check_env, evaluate, oracle, resume, train

__all__ = [
    "Env",
    "EnvCheckError",
    "EnvError",
    "InputError",
    "Instance",
    "Result",
    "Rng",
    "RunError",
    "__version__",
    "check_env",
    "envs",
    "evaluate",
    "load_instance",
    "load_result",
    "oracle",
    "resume",
    "train",
]
