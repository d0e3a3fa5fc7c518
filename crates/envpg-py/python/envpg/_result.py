"""Results: the ``envpg.result.v2`` files of the CLI, with numpy views of their contents."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from . import _native
from ._instance import Instance


class Result:
    """One result: a design ζ with its policy and its exact J, as the CLI's result file holds it
    (environment, full instance, ζ, ζ₀, policy rows over the non-terminal states in state order,
    columns the global actions).

    ``raw`` is the file's JSON; :meth:`save` writes it back bit for bit."""

    def __init__(self, raw: dict[str, Any], path: str | os.PathLike[str] | None = None, run_dir: Path | None = None):
        self.raw = raw
        self.path = Path(path) if path is not None else None
        self.run_dir = run_dir

    @property
    def J(self) -> float | None:  # noqa: N802 (the paper's name)
        """Exact objective of (ζ, policy); ``None`` when the policy does not terminate from some
        state or the environment has no model."""
        return self.raw.get("J")

    @property
    def J_H(self) -> float | None:  # noqa: N802
        """Entropy-regularised objective of the final soft policy at the final temperature."""
        return self.raw.get("J_H")

    @property
    def zeta(self) -> np.ndarray:
        """The final design ζ."""
        return np.asarray(self.raw["zeta"], dtype=np.float64)

    @property
    def zeta0(self) -> np.ndarray:
        """The initial design ζ₀."""
        return np.asarray(self.raw["zeta0"], dtype=np.float64)

    @property
    def policy(self) -> np.ndarray:
        """The policy: one row per non-terminal state (state order), one column per action."""
        return np.asarray(self.raw["policy"], dtype=np.float64)

    @property
    def method(self) -> str:
        """``"envpg-ac"`` (Algorithm 1), ``"oracle"``, …"""
        return str(self.raw["method"])

    @property
    def env(self) -> str:
        """The environment's registered name."""
        return str(self.raw["env"])

    @property
    def instance(self) -> Instance:
        """The full instance the result is for."""
        return Instance(env=self.env, data=self.raw["instance"])

    @property
    def seed(self) -> int:
        """The run seed."""
        return int(self.raw["seed"])

    @property
    def history(self) -> dict[str, np.ndarray]:
        """Per-iteration history as arrays: ``k``, ``alpha``, ``J_H_estimate``, ``grad_norm``,
        ``J_exact`` (NaN where not evaluated), ``zeta`` (iterations × d), and each numeric
        per-iteration statistic."""
        rows = self.raw.get("history") or []
        nan = float("nan")

        def col(key: str) -> np.ndarray:
            return np.asarray([nan if r.get(key) is None else r[key] for r in rows], dtype=np.float64)

        out: dict[str, np.ndarray] = {
            "k": np.asarray([r["k"] for r in rows], dtype=np.int64),
            "alpha": col("alpha"),
            "J_H_estimate": col("j_h_estimate"),
            "grad_norm": col("grad_norm"),
            "J_exact": col("J_exact"),
            "zeta": np.asarray([r["zeta"] for r in rows], dtype=np.float64).reshape(len(rows), -1),
        }
        stats = sorted({k for r in rows for k, v in (r.get("stats") or {}).items() if isinstance(v, (int, float))})
        for key in stats:
            out[key] = np.asarray([nan if (r.get("stats") or {}).get(key) is None else r["stats"][key] for r in rows])
        return out

    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes the result file (``envpg.result.v2``) to ``path`` atomically, as the CLI does."""
        _native.save_result(json.dumps(self.raw), os.fspath(path))

    def evaluate(self) -> float | None:
        """Recomputes J exactly from the result's own contents (see :func:`envpg.evaluate`)."""
        j, _ = _native.evaluate(json.dumps(self.raw), str(self.path or "<result>"))
        return j

    def __repr__(self) -> str:
        j = "None" if self.J is None else f"{self.J:.6f}"
        return f"Result(method={self.method!r}, env={self.env!r}, instance={self.instance.name!r}, J={j})"


def load_result(path: str | os.PathLike[str]) -> Result:
    """Reads a result file (``envpg.result.v2``; v1 files are read as v2). Raises
    :class:`envpg.InputError` if it is missing or malformed."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as e:
        raise _native.InputError(f"{p}: {e}") from None
    return Result(json.loads(_native.read_result(text, str(p))), path=p)
