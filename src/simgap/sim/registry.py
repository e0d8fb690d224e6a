"""Backends by name. A new backend registers here: a name, a constructor taking its settings model,
the function that validates a mapping into that model (with the backend's own checks, and errors
that name the field), the module it needs installed (and the pip extra that installs it, for an
optional one), and, for a backend that can be unable to run at all (a server that does not
answer), a check that batches make once before their first run. Each is named ``module:attr`` and
imported on first use.

Settings are validated once, where they are read (`backend_settings`: the CLI, a spec file), into
the backend's model, which then flows unchanged to `make_backend` and the backend's plant."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from pydantic import BaseModel, ConfigDict

from simgap.errors import InputError
from simgap.sim.protocol import REFERENCE, Backend


def _lazy(target: str) -> Callable[..., Any]:
    """A callable for ``module:attr`` that imports the module on its first call (so naming a
    backend does not load its physics engine, nor an optional one that is not installed)."""
    module, _, attr = target.partition(":")

    def call(*args: Any, **kwargs: Any) -> Any:
        return getattr(importlib.import_module(module), attr)(*args, **kwargs)

    return call


class NoSettings(BaseModel):
    """The settings of a backend that takes none (the ideal world executes every plan exactly)."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def _no_settings(settings: Mapping[str, Any]) -> NoSettings:
    if settings:
        raise InputError("the ideal backend has no settings: it executes every plan exactly",
                         field=f"backend_settings.{next(iter(settings))}", allowed="none")
    return NoSettings()


@dataclass(frozen=True)
class BackendEntry:
    make: Callable[[BaseModel], Backend]                    # the backend, from its settings model
    settings: Callable[[dict[str, Any]], BaseModel]         # a mapping validated into that model
    module: str                                             # must be importable
    extra: str | None = None                                # pip extra that installs it (optional backends)
    check: Callable[[BaseModel], None] | None = None        # raises when it cannot run with these settings


BACKENDS: dict[str, BackendEntry] = {
    REFERENCE: BackendEntry(_lazy("simgap.sim.ideal:IdealBackend"), _no_settings, "simgap.sim.ideal"),
    "dynamic": BackendEntry(_lazy("simgap.sim.dynamic.backend:DynamicBackend"),
                            _lazy("simgap.sim.dynamic.settings:dynamic_settings"), "simgap.sim.dynamic.backend"),
    "mujoco": BackendEntry(_lazy("simgap.sim.mujoco.backend:MujocoBackend"),
                           _lazy("simgap.sim.mujoco.settings:mujoco_settings"), "mujoco",
                           check=_lazy("simgap.sim.mujoco.graphics:check_mujoco_gl")),
    "beamng": BackendEntry(_lazy("simgap.sim.beamng.backend:BeamngBackend"),
                           _lazy("simgap.sim.beamng.settings:load_settings"), "beamngpy", extra="beamng",
                           check=_lazy("simgap.sim.beamng.session:check_server")),
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


def make_backend(name: str, settings: BaseModel | None = None) -> Backend:
    """Backend ``name`` with its ``settings`` model (`backend_settings`; None: its defaults)."""
    entry = _entry(name)
    return entry.make(settings if settings is not None else entry.settings({}))


def backend_settings(name: str, values: Mapping[str, Any] | None = None, *, file: str | Path | None = None,
                     where: str = "backend_settings") -> BaseModel:
    """``values`` validated, where they were read, into the settings model of backend ``name``;
    an error names ``file`` and the field under ``where``."""
    entry = _entry(name)
    try:
        return entry.settings(dict(values or {}))
    except InputError as exc:
        field = exc.field.replace("backend_settings", where, 1) if exc.field else where
        raise InputError(exc.reason, file=file if file is not None else exc.file, field=field,
                         allowed=exc.allowed) from None


def preflight(name: str, settings: BaseModel) -> None:
    """Fail now, with the reason, when ``name`` cannot run with ``settings`` at all, rather than
    once per run of a batch."""
    entry = _entry(name)
    if entry.check is not None:
        entry.check(settings)
