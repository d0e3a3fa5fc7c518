"""Instances: an environment's name and its canonical instance (every field, every parameter)."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Any

from . import _native
from ._native import InputError


@dataclass(frozen=True)
class Instance:
    """One problem: the environment's registered name and the canonical instance that result
    files carry (its fields, ``env``, ``name`` and every parameter in use)."""

    env: str
    data: dict[str, Any]

    @property
    def name(self) -> str:
        """The instance's name."""
        return str(self.data.get("name", ""))

    @property
    def params(self) -> dict[str, float]:
        """Every parameter of the instance."""
        return dict(self.data.get("params", {}))

    def to_json(self) -> str:
        """The canonical instance as JSON (what ``--instance FILE`` reads)."""
        return json.dumps(self.data)


def load_instance(path_or_name: str | Instance, **params: float) -> Instance:
    """A bundled instance (``"uav271"``, ``"aac1800"``, ``"flpo-n10m4"``) or an instance file
    (JSON naming its ``env``), with parameters overridden by keyword: ``load_instance("uav271",
    kappa=0.9)``. Raises :class:`InputError` for an unknown name, a malformed file, an unknown
    parameter or a value out of range."""
    if isinstance(path_or_name, Instance):
        return _load(json_text=path_or_name.to_json(), params=params)
    try:
        spec = os.fspath(path_or_name)
    except TypeError:
        raise InputError(f"an instance is a bundled name or a path, not {type(path_or_name).__name__}") from None
    return _load(spec=str(spec), params=params)


def _load(spec: str | None = None, json_text: str | None = None, params: dict[str, Any] | None = None) -> Instance:
    overrides = []
    for key, value in (params or {}).items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"parameter {key}={value!r}: must be a finite number")
        overrides.append((key, float(value)))
    if json_text is not None:
        env, text = _native.load_instance(json_text, True, overrides)
    else:
        env, text = _native.load_instance(spec, False, overrides)
    return Instance(env=env, data=json.loads(text))


def envs() -> dict[str, Any]:
    """The registered environments (name, one line about it, parameters with their defaults)
    and the bundled instances' names."""
    return json.loads(_native.envs())
