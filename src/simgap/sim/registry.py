"""Backends by name. A new backend registers here: a name, a constructor taking settings, a
check of those settings (run where they are read: the CLI, a spec file), the module it needs installed (and the pip extra that installs it, for an optional one), and, for a
backend that can be unable to run at all (a server that does not answer), a check that batches
make once before their first run."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

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


def _no_settings(settings: dict[str, Any]) -> None:
    if settings:
        raise InputError("the ideal backend has no settings: it executes every plan exactly",
                         field=f"backend_settings.{next(iter(settings))}", allowed="none")


def _dynamic_settings(settings: dict[str, Any]) -> None:
    from simgap.sim.dynamic.backend import dynamic_settings

    dynamic_settings(settings)


def _mujoco_settings(settings: dict[str, Any]) -> None:
    from simgap.sim.mujoco.backend import mujoco_settings

    mujoco_settings(settings)


def _beamng_settings(settings: dict[str, Any]) -> None:
    from simgap.sim.beamng.settings import load_settings

    load_settings(settings)


def _beamng_server(settings: dict[str, Any]) -> None:
    from simgap.sim.beamng.session import check_server

    check_server(settings)


@dataclass(frozen=True)
class BackendEntry:
    make: Callable[..., Backend]
    settings: Callable[[dict[str, Any]], None]             # validates settings as the backend will
    module: str                                            # must be importable
    extra: str | None = None                               # pip extra that installs it (optional backends)
    check: Callable[[dict[str, Any]], None] | None = None  # raises when it cannot run with these settings


BACKENDS: dict[str, BackendEntry] = {
    "ideal": BackendEntry(_ideal, _no_settings, "simgap.sim.ideal"),
    "dynamic": BackendEntry(_dynamic, _dynamic_settings, "simgap.sim.dynamic.backend"),
    "mujoco": BackendEntry(_mujoco, _mujoco_settings, "simgap.sim.mujoco"),
    "beamng": BackendEntry(_beamng, _beamng_settings, "beamngpy", extra="beamng", check=_beamng_server),
}


def backend_available(name: str) -> bool:
    """Whether the backend's modules are installed (optional backends may be missing)."""
    import importlib.util

    entry = BACKENDS.get(name)
    return entry is not None and importlib.util.find_spec(entry.module) is not None


def _entry(name: str) -> BackendEntry:
    available = [b for b in BACKENDS if backend_available(b)]
    if name not in BACKENDS:
        raise InputError(f"unknown backend '{name}'", field="backend", allowed=", ".join(available))
    entry = BACKENDS[name]
    if name not in available:
        hint = f" (pip install 'simgap[{entry.extra}]')" if entry.extra else ""
        raise InputError(f"the '{name}' backend is not part of this installation{hint}", field="backend",
                         allowed=", ".join(available))
    return entry


def make_backend(name: str, **settings: Any) -> Backend:
    return _entry(name).make(**settings)


def check_settings(name: str, settings: Mapping[str, Any], *, file: str | Path | None = None,
                   where: str = "backend_settings") -> None:
    """Validate ``settings`` of backend ``name`` now, where they were read, as the backend will
    when it is built; the error names ``file`` and the field under ``where``."""
    entry = _entry(name)
    try:
        entry.settings(dict(settings))
    except InputError as exc:
        field = exc.field.replace("backend_settings", where, 1) if exc.field else where
        raise InputError(exc.reason, file=file if file is not None else exc.file, field=field,
                         allowed=exc.allowed) from None


def preflight(name: str, settings: dict[str, Any]) -> None:
    """Fail now, with the reason, when ``name`` cannot run with ``settings`` at all, rather than
    once per run of a batch."""
    entry = _entry(name)
    if entry.check is not None:
        entry.check(settings)
