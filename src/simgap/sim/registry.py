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


def _beamng(**settings: Any) -> Backend:
    from simgap.sim.beamng import BeamngBackend

    return BeamngBackend(**settings)


BACKENDS: dict[str, Callable[..., Backend]] = {"ideal": _ideal, "dynamic": _dynamic, "mujoco": _mujoco,
                                               "beamng": _beamng}


def backend_available(name: str) -> bool:
    """Whether the backend's modules are installed (``beamng`` needs the optional beamngpy)."""
    import importlib.util

    module = {"ideal": "simgap.sim.ideal", "dynamic": "simgap.sim.dynamic.backend",
              "mujoco": "simgap.sim.mujoco", "beamng": "beamngpy"}.get(name)
    return module is not None and importlib.util.find_spec(module) is not None


def make_backend(name: str, **settings: Any) -> Backend:
    available = [b for b in BACKENDS if backend_available(b)]
    if name not in BACKENDS:
        raise InputError(f"unknown backend '{name}'", field="backend", allowed=", ".join(available))
    if name not in available:
        hint = " (pip install 'simgap[beamng]')" if name == "beamng" else ""
        raise InputError(f"the '{name}' backend is not part of this installation{hint}", field="backend",
                         allowed=", ".join(available))
    return BACKENDS[name](**settings)


def preflight(name: str, settings: dict[str, Any]) -> None:
    """Fail now, with the reason, when ``name`` cannot run with ``settings`` at all (a backend
    behind a server that does not answer), rather than once per run of a batch."""
    if name != "beamng":
        return
    if not backend_available(name):
        make_backend(name, **settings)          # raises the not-installed error
    from simgap.sim.beamng.session import probe
    from simgap.sim.beamng.settings import load_settings

    cfg = load_settings(settings)
    probe(cfg.host, cfg.port, cfg.connect_timeout)
