"""Backends by name. A new backend registers here: a name and a constructor taking settings."""

from __future__ import annotations

from typing import Any, Callable

from simgap.errors import InputError
from simgap.sim.protocol import Backend


def _ideal(**settings: Any) -> Backend:
    from simgap.sim.ideal import IdealBackend

    return IdealBackend(**settings)


def _dynamic(**settings: Any) -> Backend:
    from simgap.sim.dynamic.backend import DynamicBackend

    return DynamicBackend(**settings)


def _mujoco(**settings: Any) -> Backend:
    from simgap.sim.mujoco import MujocoBackend

    return MujocoBackend(**settings)


BACKENDS: dict[str, Callable[..., Backend]] = {"ideal": _ideal, "dynamic": _dynamic, "mujoco": _mujoco}


def backend_available(name: str) -> bool:
    """Whether the backend's module is installed (optional backends may be missing)."""
    import importlib.util

    module = {"ideal": "simgap.sim.ideal", "dynamic": "simgap.sim.dynamic.backend",
              "mujoco": "simgap.sim.mujoco"}.get(name)
    return module is not None and importlib.util.find_spec(module) is not None


def make_backend(name: str, **settings: Any) -> Backend:
    available = [b for b in BACKENDS if backend_available(b)]
    if name not in BACKENDS:
        raise InputError(f"unknown backend '{name}'", field="backend", allowed=", ".join(available))
    if name not in available:
        raise InputError(f"the '{name}' backend is not part of this installation", field="backend",
                         allowed=", ".join(available))
    return BACKENDS[name](**settings)
