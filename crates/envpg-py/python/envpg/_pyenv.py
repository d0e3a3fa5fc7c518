"""Environments written in Python: the :class:`Env` contract, and how a run's processes rebuild
the user's environment (its class by module and name, its constructor's keyword arguments)."""

from __future__ import annotations

import importlib.util
import inspect
import json
import os
import sys
from typing import Any

from ._native import InputError


class Env:
    """A finite MDP whose dynamics depend on a design ζ, written in Python.

    Subclass it (or write any class with the same members) and pass an instance to
    :func:`envpg.train`. Every process of the run — the learner and each worker — imports your
    module and rebuilds the environment with the keyword arguments it was constructed with
    (recorded by this base class; without it, define ``config()`` returning them), so the
    class must be importable: defined at module level, in a module on ``sys.path`` or in the
    script being run (whose top level then runs again in each worker, as with
    ``multiprocessing``'s spawn: keep the work under ``if __name__ == "__main__":``).

    Required (attributes, or methods without arguments):
      ``n_states``, ``n_actions``; the design's bounds ``zeta_low`` and ``zeta_high`` (or
      ``zeta_dim`` for an unbounded design).

    Required methods:
      ``valid_actions(s) -> list[int]`` — increasing, empty exactly for terminal states;
      ``is_terminal(s) -> bool``; ``initial_state(rng) -> int``;
      ``step(s, a, zeta, rng) -> (next_state, cost)`` — ``zeta`` a tuple of floats, every
      random draw from ``rng`` (:class:`envpg.Rng`), so that episodes replay bit for bit.

    Optional: ``gamma`` (1.0: a stochastic shortest path problem), ``zeta_names``,
    ``cost_scale`` (an episode's typical cost, the unit of Algorithm 1's scale-free settings),
    ``initial_design`` (ζ₀ for ``zeta0="env"``), ``exploring_start(rng) -> int``,
    ``clustered_design(rng) -> list[float]`` (a design drawn from the problem's structure: ζ₀
    for ``zeta0="clustered"`` and the start of the oracle portfolio's warm restarts); and the model
    for the oracle and exact evaluation: ``initial_distribution() -> [(s, p), …]`` and
    ``outcomes(s, a, zeta, grad) -> (next, prob, cost)``, with ``grad`` also ``(dprob, dcost)``:
    per outcome a list of the d derivatives by ζ.

    The learner stays in Rust; sizes, bounds, valid actions and terminal states are read once.
    """

    _envpg_config: dict[str, Any]

    def __new__(cls, *args: Any, **kwargs: Any) -> Env:
        obj = super().__new__(cls)
        config: dict[str, Any] = dict(kwargs)
        try:
            bound = inspect.signature(cls.__init__).bind(None, *args, **kwargs)
        except TypeError:
            bound = None  # __init__ itself reports the mismatch
        if bound is not None:
            params = inspect.signature(cls.__init__).parameters
            config = {}
            for name, value in list(bound.arguments.items())[1:]:
                kind = params[name].kind
                if kind is inspect.Parameter.VAR_POSITIONAL:
                    if value:
                        obj._envpg_unrebuildable = f"positional arguments *{name}"
                elif kind is inspect.Parameter.VAR_KEYWORD:
                    config.update(value)
                else:
                    config[name] = value
        obj._envpg_config = config
        return obj

    def config(self) -> dict[str, Any]:
        """The keyword arguments that rebuild this environment (JSON values)."""
        return dict(self._envpg_config)


_REQUIRED = ("n_states", "n_actions", "valid_actions", "is_terminal", "initial_state", "step")


def instance_of(env: Any) -> dict[str, Any]:
    """The instance of a Python environment object: ``{"env": "python", "class": …, "config": …}``."""
    missing = [m for m in _REQUIRED if not hasattr(env, m)]
    if missing:
        raise InputError(
            f"{type(env).__name__} is not an environment: it lacks {', '.join(missing)} (see envpg.Env)"
        )
    cls = type(env)
    if "<locals>" in cls.__qualname__:
        raise InputError(
            f"{cls.__qualname__} is defined inside a function: the run's worker processes cannot import it; "
            "define it at module level"
        )
    if getattr(env, "_envpg_unrebuildable", None):
        raise InputError(
            f"{cls.__name__} was built with {env._envpg_unrebuildable}, which its run's processes cannot "
            "pass again: take keyword arguments, or define config()"
        )
    config = env.config() if callable(getattr(env, "config", None)) else {}
    try:
        config = json.loads(json.dumps(config, allow_nan=False))
    except (TypeError, ValueError) as e:
        raise InputError(f"{cls.__name__}'s constructor arguments must be JSON values ({e})") from None
    inst: dict[str, Any] = {
        "env": "python",
        "name": str(getattr(env, "name", cls.__name__)),
        "class": f"{cls.__module__}:{cls.__qualname__}",
        "config": config,
    }
    if cls.__module__ == "__main__":
        main = sys.modules["__main__"]
        path = getattr(main, "__file__", None)
        if path is None:
            raise InputError(
                f"{cls.__name__} is defined interactively: the run's worker processes cannot import it; "
                "put it in a module or a script"
            )
        inst["script"] = os.path.abspath(path)
    return inst


def import_script(path: str) -> Any:
    """The module of the script at ``path``: ``__main__`` if that is the script running here,
    otherwise the script imported as ``__envpg_main__`` (its ``__main__`` block does not run)."""
    main = sys.modules.get("__main__")
    main_file = getattr(main, "__file__", None)
    if main_file is not None and os.path.abspath(main_file) == path:
        return main
    if "__envpg_main__" in sys.modules:
        return sys.modules["__envpg_main__"]
    spec = importlib.util.spec_from_file_location("__envpg_main__", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot import the script {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules["__envpg_main__"] = module
    spec.loader.exec_module(module)
    return module


def python_path() -> str:
    """``sys.path`` of this interpreter as ``PYTHONPATH``, so a run's processes import what it can."""
    here = [p if p else os.getcwd() for p in sys.path]
    return os.pathsep.join(dict.fromkeys(here))


__all__ = ["Env", "import_script", "instance_of", "python_path"]
