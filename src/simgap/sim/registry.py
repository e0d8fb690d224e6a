"""Backends by name. A backend declares itself with a `BackendEntry` (`simgap.sim.protocol`): a
constructor taking its settings model, the function that validates a mapping into that model (with
the backend's own checks, and errors that name the field), the module it needs installed (and the
pip extra that installs it, for an optional one), and, for a backend that can be unable to run at
all (a server that does not answer), a check that batches make once before their first run. A
built-in is one line in `BUILTIN_BACKENDS` naming its declaration (beside its settings model, in a
module that loads without its physics engine); an installed package names its own in the
entry-point group ``simgap.backends`` (``my_world = "my_package.backend:BACKEND"``).

Settings are validated once, where they are read (`backend_settings`: the CLI, a spec file), into
the backend's model, which then flows unchanged to `make_backend` and the backend's plant."""

from __future__ import annotations

import importlib.util
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from simgap.errors import InputError
from simgap.registry import Registry, lazy
from simgap.sim.protocol import REFERENCE, Backend, BackendEntry

BUILTIN_BACKENDS: dict[str, str] = {
    REFERENCE: "simgap.sim.ideal:BACKEND",
    "dynamic": "simgap.sim.dynamic.settings:BACKEND",
    "mujoco": "simgap.sim.mujoco.settings:BACKEND",
    "beamng": "simgap.sim.beamng.settings:BACKEND",
}


def _backend_entry(obj: Any, name: str) -> BackendEntry:
    if not isinstance(obj, BackendEntry):
        raise InputError(f"backend '{name}' does not name a backend declaration", field="backend",
                         allowed="a simgap.sim.protocol.BackendEntry (module:attr of one)")
    return obj


#: the backends by name: the built-ins, then those installed in the entry-point group
BACKENDS: Registry[BackendEntry] = Registry("backend", "simgap.backends", BUILTIN_BACKENDS, _backend_entry)


def backend_available(name: str) -> bool:
    """Whether the backend's modules are installed (optional backends may be missing)."""
    if name not in BACKENDS:
        return False
    return importlib.util.find_spec(BACKENDS.load(name).module) is not None


def _entry(name: str) -> BackendEntry:
    if name not in BACKENDS:
        available = [b for b in BACKENDS.names() if backend_available(b)]
        raise InputError(f"unknown backend '{name}'", field="backend",
                         allowed=f"{', '.join(available)}, or a name installed in the entry-point group "
                                 f"'{BACKENDS.group}'")
    entry = BACKENDS.load(name)
    if not backend_available(name):
        available = [b for b in BACKENDS.names() if backend_available(b)]
        hint = f" (pip install 'simgap[{entry.extra}]')" if entry.extra else ""
        raise InputError(f"the '{name}' backend is not part of this installation{hint}", field="backend",
                         allowed=", ".join(available))
    return entry


def make_backend(name: str, settings: BaseModel | None = None) -> Backend:
    """Backend ``name`` with its ``settings`` model (`backend_settings`; None: its defaults)."""
    entry = _entry(name)
    return lazy(entry.make)(settings if settings is not None else lazy(entry.settings)({}))


def backend_settings(name: str, values: Mapping[str, Any] | None = None, *, file: str | Path | None = None,
                     where: str = "backend_settings") -> BaseModel:
    """``values`` validated, where they were read, into the settings model of backend ``name``;
    an error names ``file`` and the field under ``where``."""
    entry = _entry(name)
    try:
        return lazy(entry.settings)(dict(values or {}))
    except InputError as exc:
        field = exc.field.replace("backend_settings", where, 1) if exc.field else where
        raise InputError(exc.reason, file=file if file is not None else exc.file, field=field,
                         allowed=exc.allowed) from None


def settings_model(name: str) -> type[BaseModel]:
    """The settings model of backend ``name`` (installed or not: an optional backend's settings
    module loads without its physics engine), as its defaults are validated into."""
    return type(lazy(BACKENDS.load(name).settings)({}))


def preflight(name: str, settings: BaseModel) -> None:
    """Fail now, with the reason, when ``name`` cannot run with ``settings`` at all, rather than
    once per run of a batch."""
    entry = _entry(name)
    if entry.check is not None:
        lazy(entry.check)(settings)
