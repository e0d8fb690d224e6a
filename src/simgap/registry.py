"""Named plug-ins: what a planner's, a backend's or a controller's name means.

One `Registry` per kind. It knows the built-in names, each mapped to a ``module:attr`` target that
is imported on first use (naming a backend does not load its physics engine), and an entry-point
group through which an installed package adds names of its own, in its pyproject::

    [project.entry-points."simgap.backends"]
    my_world = "my_package.backend:BACKEND"

A built-in name wins over an installed one of the same name. An unknown name is an `InputError`
naming the known names and the entry-point group; a target that cannot be imported is one naming
the target (and the distribution that declared it).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any, Generic, TypeVar

from simgap.errors import InputError

T = TypeVar("T")


def resolve(target: str) -> Any:
    """The object ``module:attr`` names (``attr`` may be dotted), importing its module."""
    module, _, attr = target.partition(":")
    obj = importlib.import_module(module)
    for part in attr.split(".") if attr else ():
        obj = getattr(obj, part)
    return obj


def lazy(target: str | Callable[..., Any]) -> Callable[..., Any]:
    """A callable for ``module:attr`` that imports its module on its first call (a callable
    is returned as it is)."""
    if callable(target):
        return target

    def call(*args: Any, **kwargs: Any) -> Any:
        return resolve(target)(*args, **kwargs)

    return call


@dataclass
class Registry(Generic[T]):
    """The names of one kind of plug-in: built-ins (``name -> "module:attr"``) and the entry points
    of ``group``. ``check(obj, name)`` turns what a target names into a ``T`` (or raises an
    `InputError`); without it the object is taken as it is."""

    kind: str                                   # "planner", "backend", "controller": in messages
    group: str                                  # the entry-point group, e.g. "simgap.backends"
    builtin: Mapping[str, str]
    check: Callable[[Any, str], T] | None = None
    _loaded: dict[str, T] = field(default_factory=dict, init=False, repr=False)

    def installed(self) -> dict[str, EntryPoint]:
        """What installed packages declare in the group (read anew: a test may install one)."""
        return {ep.name: ep for ep in entry_points(group=self.group)}

    def names(self) -> list[str]:
        """The built-in names, then the installed ones (sorted)."""
        return list(self.builtin) + sorted(set(self.installed()) - set(self.builtin))

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __contains__(self, name: object) -> bool:
        return name in self.builtin or name in self.installed()

    def target(self, name: str) -> str:
        """The ``module:attr`` that ``name`` stands for."""
        if name in self.builtin:
            return self.builtin[name]
        return self._entry_point(name).value

    def origin(self, name: str) -> str:
        """``built-in``, or ``installed (DISTRIBUTION)``."""
        if name in self.builtin:
            return "built-in"
        ep = self._entry_point(name)
        return f"installed ({ep.dist.name if ep.dist is not None else '?'})"

    def allowed(self) -> str:
        """The known names, and where others come from: for an error's ``allowed``."""
        return f"{', '.join(self.names())}, or a name installed in the entry-point group '{self.group}'"

    def load(self, name: str, *, file: str | Path | None = None, field: str | None = None) -> T:
        """What ``name`` names, imported once per process; an `InputError` (naming ``file`` and
        ``field``, by default the kind) for an unknown name or a target that does not import."""
        if name in self._loaded:
            return self._loaded[name]
        field = field or self.kind
        target, origin = self.target_of(name, file=file, field=field), self.origin(name)
        try:
            obj = resolve(target)
        except (Exception, SystemExit) as exc:      # a broken package (or one that exits): its error, named
            raise InputError(f"{self.kind} '{name}' ({target}, {origin}) cannot be loaded: "
                             f"{type(exc).__name__}: {exc}", file=file, field=field,
                             allowed=self.allowed()) from None
        checked = self.check(obj, name) if self.check is not None else obj
        self._loaded[name] = checked
        return checked

    def target_of(self, name: str, *, file: str | Path | None = None, field: str | None = None) -> str:
        """`target`, or the `InputError` of an unknown name."""
        if name not in self:
            raise InputError(f"unknown {self.kind} '{name}'", file=file, field=field or self.kind,
                             allowed=self.allowed())
        return self.target(name)

    def _entry_point(self, name: str) -> EntryPoint:
        installed = self.installed()
        if name not in installed:
            raise InputError(f"unknown {self.kind} '{name}'", field=self.kind, allowed=self.allowed())
        return installed[name]
