"""The planner registry: which planner class a name or a reference means, and its settings.

A planner class is named in one of three ways:

* a built-in name (`BUILTIN_PLANNERS`, one line per planner, imported on first use);
* the name of an installed planner: a package declares its class in the entry-point group
  ``simgap.planners`` (in its pyproject: ``[project.entry-points."simgap.planners"]``,
  ``time_gap = "time_gap_planner:TimeGapPlanner"``);
* a reference to any class: ``my_pkg.module:MyPlanner`` (an importable module) or
  ``path/to/file.py:MyPlanner`` (a Python file, imported by its path).

A planner in a process of its own is named ``exec:COMMAND ARGS`` (simgap starts it) or by its
address, ``tcp://HOST:PORT`` or ``ipc://PATH`` (`simgap.planning.remote`); ``isolate`` runs a
planner class that way (`PlannerChoice`).

A built-in name wins over an installed planner of the same name. A class qualifies when it has a
``plan`` method and a constructor that takes ``()``, ``(setup)`` or ``(setup, settings)``
(`PlannerSetup`; by its signature, settings only when it takes them); the pydantic model in its
optional ``Settings`` attribute validates what the user passes, and a class that declares one
must take ``(setup, settings)``. Every problem is an `InputError` naming the reference (or the
file and field) and what is allowed.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import json
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any, Protocol

from pydantic import BaseModel, ConfigDict, Field, model_validator

from simgap.errors import InputError, validated
from simgap.planning.protocol import Planner, PlannerSetup, as_planner
from simgap.planning.remote import PlannerTarget, ProcessLimits, RemotePlanner, RemotePlannerClass, json_settings
from simgap.registry import Registry

BUILTIN_PLANNERS: dict[str, str] = {
    "frenet": "simgap.planning.frenet:FrenetPlanner",
    "reactive": "simgap.planning.reactive:ReactivePlanner",
    "idm": "simgap.planning.idm_planner:IdmPlanner",
}
ENTRY_POINT_GROUP = "simgap.planners"
#: the planners by name: the built-ins, then the installed ones (each checked by `load_planner`)
PLANNERS: Registry[Any] = Registry("planner", ENTRY_POINT_GROUP, BUILTIN_PLANNERS)
DEFAULT_PLANNER = "frenet"
LABEL = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"      # what names a planner in job keys, store rows and reports


@dataclass(frozen=True)
class PlannerClass:
    """A loaded planner class: what it was named by, where it comes from, and its settings model."""

    ref: str            # the name or reference it was loaded by
    origin: str         # "built-in", "installed (DIST)", "module" or "file"
    cls: type
    arguments: int = 2  # what its constructor takes: 0 (), 1 (setup) or 2 (setup, settings)

    @property
    def settings_model(self) -> type[BaseModel] | None:
        model = getattr(self.cls, "Settings", None)
        return model if isinstance(model, type) and issubclass(model, BaseModel) else None

    @property
    def description(self) -> str:
        """The first paragraph of the class's docstring, on one line."""
        doc = inspect.getdoc(self.cls) or ""
        return " ".join(doc.split("\n\n")[0].split())

    def settings(self, values: Mapping[str, Any] | None, *, file: str | Path | None = None,
                 prefix: str | None = None) -> BaseModel | dict[str, Any]:
        """``values`` validated by the class's ``Settings``; for a class without one, as they are
        once they are sure to be a JSON object (its planners read them in ``setup.settings``, as
        a planner in its own process does)."""
        model = self.settings_model
        if model is None:
            return json_settings(values, file=file, prefix=prefix)
        return validated(model, values, file=file, prefix=prefix)

    def build(self, setup: PlannerSetup, settings: BaseModel | Mapping[str, Any] | None) -> Planner:
        """One planner: ``cls(setup, settings)``, ``cls(setup)`` or ``cls()``, as it is constructed
        (``settings`` its ``Settings`` model's, None for a class without one; with the whole
        `Planner` contract: `as_planner`)."""
        model = settings if isinstance(settings, BaseModel) else None
        return as_planner(self.cls(*(setup, model)[:self.arguments]))


@dataclass(frozen=True)
class IsolatedPlannerClass:
    """A planner class of the registry run in a child process of simgap's interpreter: its
    settings are checked here by its ``Settings`` model (a bad field fails before any run), its
    planners are built and asked over the protocol (`simgap.planning.isolated`)."""

    planner: PlannerClass
    limits: ProcessLimits = ProcessLimits()

    @property
    def ref(self) -> str:
        return self.planner.ref

    @property
    def origin(self) -> str:
        return f"{self.planner.origin}, isolated"

    @property
    def description(self) -> str:
        return self.planner.description

    def settings(self, values: Mapping[str, Any] | None, *, file: str | Path | None = None,
                 prefix: str | None = None) -> BaseModel | dict[str, Any]:
        return self.planner.settings(values, file=file, prefix=prefix)

    def build(self, setup: PlannerSetup, settings: BaseModel | Mapping[str, Any] | None) -> RemotePlanner:
        target = PlannerTarget(command=(sys.executable, "-m", "simgap.planning.isolated", self.planner.ref))
        settings_json = settings.model_dump_json() if isinstance(settings, BaseModel) else \
            json.dumps(dict(settings or {}))
        return RemotePlanner(setup, target, settings_json, self.limits)


class PlannerFactory(Protocol):
    """What builds an agent's planner: a class of the registry (`PlannerClass`), the same in a
    process of its own (`IsolatedPlannerClass`), or a planner that is one already
    (`RemotePlannerClass`)."""

    @property
    def ref(self) -> str: ...             # the name or reference it was loaded by

    @property
    def origin(self) -> str: ...          # where it comes from ("built-in", "file", "process", ...)

    @property
    def description(self) -> str: ...

    def settings(self, values: Mapping[str, Any] | None, *, file: str | Path | None = None,
                 prefix: str | None = None) -> Any:
        """``values`` checked: the class's settings model (or None), or for a planner in its own
        process the JSON object it is sent."""

    def build(self, setup: PlannerSetup, settings: Any) -> Planner:
        """One agent's planner (``settings`` as `settings` returned them)."""


def planner_names() -> list[str]:
    """Built-in names, then installed planners' names."""
    return PLANNERS.names()


def allowed_planners() -> str:
    return ", ".join(planner_names()) + ", a module:Class or a path/to/file.py:Class (a name installed in the " \
        f"entry-point group '{ENTRY_POINT_GROUP}' is one more name)"


def load_planner(ref: str, *, file: str | Path | None = None, field: str = "planner") -> PlannerClass:
    """The planner class ``ref`` names (a name or a reference); an `InputError` if none qualifies."""
    ref = ref.strip()
    if ":" not in ref:                  # a name: built-in or installed
        if ref not in PLANNERS:
            raise InputError(f"unknown planner '{ref}'", file=file, field=field, allowed=allowed_planners())
        return _checked(ref, PLANNERS.origin(ref), PLANNERS.load(ref, file=file, field=field), file, field)
    where, _, _ = ref.rpartition(":")
    origin = "file" if where.endswith(".py") or "/" in where or "\\" in where else "module"
    return _checked(ref, origin, _import_class(ref, ref, file, field), file, field)


def _import_class(target: str, ref: str, file: str | Path | None, field: str) -> Any:
    """The object ``module:attr`` or ``path/file.py:attr`` names."""
    where, _, attr = target.rpartition(":")
    if not where or not attr.isidentifier():
        raise InputError(f"'{ref}' is not a planner reference", file=file, field=field, allowed=allowed_planners())
    if where.endswith(".py") and not Path(where).is_file():
        raise InputError(f"no such planner file '{where}'", file=file, field=field,
                         allowed="path/to/file.py:Class (relative to the working directory, or in a spec to "
                                 "the spec's folder)")
    try:
        module = _module_of_file(str(Path(where).resolve())) if where.endswith(".py") \
            else importlib.import_module(where)
    except (Exception, SystemExit) as exc:      # a module that raises or exits while it is imported
        raise InputError(f"cannot import '{where}' for planner '{ref}': {type(exc).__name__}: {exc}",
                         file=file, field=field, allowed=allowed_planners()) from None
    if not hasattr(module, attr):
        classes = sorted(n for n, v in vars(module).items() if inspect.isclass(v) and hasattr(v, "plan")
                         and getattr(v, "__module__", None) == module.__name__)
        raise InputError(f"'{where}' has no class '{attr}' (planner '{ref}')", file=file, field=field,
                         allowed=", ".join(classes) or "a class with a plan method")
    return getattr(module, attr)


@cache
def _module_of_file(path_text: str) -> Any:
    """The module a Python file defines, imported once per process under a name of its own."""
    path = Path(path_text)
    name = f"simgap_planner_{re.sub(r'[^A-Za-z0-9_]', '_', path.stem)}_" \
           f"{hashlib.sha1(str(path).encode()).hexdigest()[:8]}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:       # not for a .py file; said as any import's failure is
        raise ImportError(f"no module loader for {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module            # dataclasses and pickling look their module up here
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _checked(ref: str, origin: str, cls: Any, file: str | Path | None, field: str) -> PlannerClass:
    """``cls`` as a `PlannerClass`, if it is one: a class with ``plan``, built from (setup, settings),
    (setup) or () — settings only when it takes them; a class with a ``Settings`` model must."""
    if not inspect.isclass(cls) or not callable(getattr(cls, "plan", None)):
        raise InputError(f"'{ref}' is not a planner class (a class with a plan(observed, t, world) method)",
                         file=file, field=field, allowed=allowed_planners())
    settings = getattr(cls, "Settings", None)
    if settings is not None and not (isinstance(settings, type) and issubclass(settings, BaseModel)):
        raise InputError(f"planner class '{ref}' has a Settings attribute that is not a pydantic model",
                         file=file, field=field, allowed="a pydantic BaseModel subclass, or no Settings")
    arguments = _constructor_arguments(cls, 2 if settings is not None else 0)
    if arguments is None:
        takes = "cls(setup, settings), as its Settings model asks" if settings is not None else \
            "cls(), cls(setup) or cls(setup, settings)"
        raise InputError(f"planner class '{ref}' cannot be constructed as {takes}", file=file, field=field,
                         allowed="__init__(self, setup: PlannerSetup, settings)" if settings is not None else
                         "no __init__, __init__(self, setup: PlannerSetup) or __init__(self, setup, settings)")
    return PlannerClass(ref, origin, cls, arguments)


def _constructor_arguments(cls: type, fewest: int) -> int | None:
    """How many of (setup, settings) ``cls``'s constructor takes — the most it accepts, and at
    least ``fewest`` — or None when it takes none of those counts."""
    try:
        signature = inspect.signature(cls)
    except ValueError:
        return 2                # no signature to inspect (a class implemented in C)
    for count in range(2, fewest - 1, -1):
        try:
            signature.bind(*[None] * count)
        except TypeError:
            continue
        return count
    return None


def default_label(ref: str) -> str:
    """How a planner is named where no label is given: its name, its class's name, or for a planner
    in its own process its script's or program's name (or its address)."""
    target = PlannerTarget.parse(ref)
    if target is not None:
        return target.label
    return ref.rpartition(":")[2] if ":" in ref else ref


class PlannerChoice(BaseModel):
    """The planner an agent drives with: a name or reference, its settings (validated by the
    class's ``Settings`` when it is loaded) and the label that names it in keys, rows and reports.
    In YAML: ``frenet``, or ``{planner: frenet, settings: {speed: {cruise_m_s: 8}}, label: slow}``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    planner: str = Field(DEFAULT_PLANNER, min_length=1, description="a planner name, module:Class, "
                         "path/to/file.py:Class, or a planner in its own process: exec:COMMAND ARGS (simgap starts "
                         "it) or tcp://HOST:PORT / ipc://PATH (it runs already)")
    settings: dict[str, Any] = Field(default_factory=dict, description="the planner's settings")
    label: str | None = Field(None, pattern=LABEL, description="its name in job keys, the store and the report "
                              "(default: the planner's name, its class's name, or its program's)")
    isolate: bool = Field(False, description="run a planner class in a process of its own (over the planner "
                          "protocol), so that a hang or a crash costs its agent, never the batch")
    process: ProcessLimits = Field(default_factory=ProcessLimits, description="deadlines and restarts of a planner "
                                   "in its own process (exec:, an address, or isolate)")

    @model_validator(mode="before")
    @classmethod
    def _from_name(cls, data: Any) -> Any:
        return {"planner": data} if isinstance(data, str) else data

    @property
    def name(self) -> str:
        return self.label or default_label(self.planner)

    def load(self, *, file: str | Path | None = None, field: str = "planner",
             settings_field: str | None = None) -> tuple[PlannerFactory, Any]:
        """What builds the planners and their checked settings; errors name ``file`` and ``field``
        (a bad setting: ``settings_field`` and the setting's path; default ``FIELD.settings``).
        A planner in its own process checks its settings itself, when it is initialised."""
        target = PlannerTarget.parse(self.planner)
        if target is not None:
            if self.isolate:
                raise InputError(f"'{self.planner}' runs in its own process already; isolate is for planner "
                                 "classes", file=file, field="isolate", allowed="false for exec: and addresses")
            target.check(file, field)
            planner: PlannerFactory = RemotePlannerClass(self.planner, target, self.process)
        else:
            planner = load_planner(self.planner, file=file, field=field)
            if self.isolate:
                planner = IsolatedPlannerClass(planner, self.process)
        prefix = f"{field}.settings" if settings_field is None else settings_field or None
        return planner, planner.settings(self.settings, file=file, prefix=prefix)

    def with_file_base(self, folder: Path) -> PlannerChoice:
        """This choice with a relative ``path/file.py:Class`` made absolute against ``folder``."""
        where, _, attr = self.planner.rpartition(":")
        if not where.endswith(".py") or Path(where).is_absolute():
            return self
        return self.model_copy(update={"planner": f"{(folder / where).resolve()}:{attr}"})

#: the planner of every agent, or one per agent (planning problem id)
PlannerAssignment = PlannerChoice | Mapping[int, PlannerChoice]


def assignment_label(planners: PlannerAssignment) -> str:
    """``frenet``, or per agent ``1=frenet,2=idm``."""
    if isinstance(planners, PlannerChoice):
        return planners.name
    return ",".join(f"{aid}={c.name}" for aid, c in sorted(planners.items()))


def planner_of(planners: PlannerAssignment, agent_id: int, agent_ids: list[int]) -> PlannerChoice:
    """The planner of agent ``agent_id``; an `InputError` if a per-agent assignment leaves it out."""
    if isinstance(planners, PlannerChoice):
        return planners
    if agent_id not in planners:
        raise InputError(f"no planner given for planning problem {agent_id}", field="planner",
                         allowed="ids " + ", ".join(map(str, agent_ids)))
    return planners[agent_id]


@dataclass(frozen=True)
class SettingField:
    """One setting of a planner's settings model: its dotted path, default and meaning."""

    name: str
    default: Any                # `REQUIRED` when the setting has no default
    description: str


REQUIRED = "(required)"


def settings_fields(model: type[BaseModel], prefix: str = "") -> list[SettingField]:
    """Every setting of ``model``, nested models flattened to dotted paths."""
    out = []
    for name, info in model.model_fields.items():
        path = f"{prefix}{name}"
        nested = info.annotation if isinstance(info.annotation, type) and issubclass(info.annotation, BaseModel) \
            else None
        if nested is not None:
            out += settings_fields(nested, f"{path}.")
            continue
        default = REQUIRED if info.is_required() else info.get_default(call_default_factory=True)
        out.append(SettingField(path, default, info.description or ""))
    return out
