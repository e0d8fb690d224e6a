"""Logical scenarios: a template plus a parameter space, read from YAML.

```yaml
name: curve                      # used in scenario names
description: The paper's turn.
template: curve                  # curve | s-curve | road | hairpins | t-junction | intersection | opendrive
fixed:                           # settings every concrete scenario shares (template-specific)
  straight_length: 100
parameters:                      # the space; every parameter has a unit, a range and a default
  radius: {unit: m, min: 5, max: 1000, default: 50, values: [10, 20, 30, 50, 75, 100]}
  angle:  {unit: deg, min: -180, max: 180, default: 90, grid: {start: -180, stop: 180, step: 30}}
  lanes:  {unit: "-", min: 1, max: 3, default: 1, integer: true}
```

A parameter with ``values`` or ``grid`` spans those values in the full-grid sampler; one
without spans only its default. Concrete scenarios are named from the logical name and every
parameter that spans more than one value or differs from its default, in declaration order:
``curve_radius-10_angle-90``.

The ``opendrive`` template puts one agent on a road network read from an OpenDRIVE file:
``fixed: {file: road.xodr, start: "300:-3:370", goal: "308:-1:105"}`` (the file relative to the
YAML; places as ``simgap generate road.xodr --start --goal`` takes them), with ``initial_speed``,
``time_limit`` and ``dt`` as its parameters. An experiment on such a logical scenario runs the real
road in every fidelity from one command.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterator
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from simgap.errors import InputError
from simgap.files import read_model
from simgap.scenario.opendrive.scenario import opendrive_template
from simgap.scenario.physical_bounds import MAX_TIME_STEP_S, MIN_TIME_STEP_S, TIME_STEP_ALLOWED
from simgap.scenario.templates import ONE_ROAD, ConcreteScenario, check_template_inputs
from simgap.scenario.templates import TEMPLATES as ROAD_TEMPLATES
from simgap.trajectory import DEFAULT_TIME_STEP_S

TEMPLATES = ROAD_TEMPLATES | {"opendrive": opendrive_template}


class Grid(BaseModel):
    model_config = ConfigDict(extra="forbid")
    start: float
    stop: float
    step: float = Field(gt=0)

    def values(self) -> list[float]:
        n = int(round((self.stop - self.start) / self.step))
        return [round(self.start + i * self.step, 10) for i in range(n + 1)]


class Parameter(BaseModel):
    model_config = ConfigDict(extra="forbid")
    unit: str
    min: float
    max: float
    default: float
    description: str = ""
    integer: bool = False
    values: list[float] | None = None
    grid: Grid | None = None

    @model_validator(mode="after")
    def _check(self) -> Parameter:
        if self.values is not None and self.grid is not None:
            raise ValueError("give either values or grid, not both")
        for v in [self.default] + self.span():
            if not self.min <= v <= self.max:
                raise ValueError(f"value {v:g} outside [{self.min:g}, {self.max:g}]")
        return self

    def span(self) -> list[float]:
        if self.values is not None:
            return list(self.values)
        if self.grid is not None:
            return self.grid.values()
        return [self.default]

    def coerce(self, value: float) -> float | int:
        return int(round(value)) if self.integer else float(value)


class LogicalScenario(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(pattern=r"^[a-z][a-z0-9-]*$")
    description: str = ""
    template: str
    fixed: dict[str, Any] = Field(default_factory=dict)
    parameters: dict[str, Parameter]

    @model_validator(mode="after")
    def _known_template(self) -> LogicalScenario:
        if self.template not in TEMPLATES:
            raise ValueError(f"unknown template '{self.template}' (allowed: {', '.join(TEMPLATES)})")
        return self

    @field_validator("fixed")
    @classmethod
    def _fixed_time_step(cls, fixed: dict[str, Any]) -> dict[str, Any]:
        dt = fixed.get("dt", DEFAULT_TIME_STEP_S)
        if not (isinstance(dt, (int, float)) and not isinstance(dt, bool) and math.isfinite(dt)
                and MIN_TIME_STEP_S <= dt <= MAX_TIME_STEP_S):
            raise ValueError(f"dt is {dt!r} (allowed: {TIME_STEP_ALLOWED})")
        return fixed

    @field_validator("parameters")
    @classmethod
    def _time_step_parameter(cls, parameters: dict[str, Parameter]) -> dict[str, Parameter]:
        dt = parameters.get("dt")
        if dt is not None and not (dt.min >= MIN_TIME_STEP_S and dt.max <= MAX_TIME_STEP_S):
            raise ValueError(f"dt spans {dt.min:g} to {dt.max:g} s (allowed: {TIME_STEP_ALLOWED})")
        return parameters

    @property
    def has_reference_line(self) -> bool:
        """Whether its scenarios are one road along a centre line, which a tilt of the road
        (``road_bank``, ``road_grade``) lies along (junctions and imported networks have none)."""
        return self.template in ONE_ROAD

    # ---------------------------------------------------------------- sampling
    def pinned(self, assignments: dict[str, str], source: str = "--set") -> dict[str, float]:
        """Parse NAME=VALUE pins, checking names and ranges."""
        out = {}
        for name, text in assignments.items():
            if name not in self.parameters:
                raise InputError(f"unknown parameter '{name}' of logical scenario '{self.name}'",
                                 file=source, field=name, allowed=", ".join(self.parameters))
            par = self.parameters[name]
            try:
                value = float(text)
            except ValueError:
                raise InputError(f"'{text}' is not a number", file=source, field=name,
                                 allowed=f"{par.min:g} to {par.max:g} {par.unit}") from None
            if not par.min <= value <= par.max:
                raise InputError(f"{value:g} {par.unit} is out of range", file=source, field=name,
                                 allowed=f"{par.min:g} to {par.max:g} {par.unit}")
            out[name] = par.coerce(value)
        return out

    def grid(self, pins: dict[str, float] | None = None) -> Iterator[dict[str, float]]:
        """Every combination of the parameters' spans (pinned parameters: one value)."""
        pins = pins or {}
        names = list(self.parameters)
        spans = [[pins[n]] if n in pins else [self.parameters[n].coerce(v) for v in self.parameters[n].span()]
                 for n in names]
        for combo in itertools.product(*spans):
            yield dict(zip(names, combo))

    def scenario_name(self, params: dict[str, float]) -> str:
        parts = [self.name]
        for n, par in self.parameters.items():
            if len(par.span()) > 1 or params[n] != par.coerce(par.default):
                parts.append(f"{n.replace('_', '')}-{_fmt(params[n])}")
        return "_".join(parts)

    def build(self, params: dict[str, float]) -> ConcreteScenario:
        """The concrete scenario for one parameter combination (defaults fill the rest)."""
        unknown = set(params) - set(self.parameters)
        if unknown:
            raise InputError(f"unknown parameter '{sorted(unknown)[0]}' of logical scenario '{self.name}'",
                             field=sorted(unknown)[0], allowed=", ".join(self.parameters))
        full = {n: par.coerce(par.default) for n, par in self.parameters.items()} | params
        check_template_inputs(self.template, self.fixed, list(self.parameters))
        concrete = TEMPLATES[self.template](self.scenario_name(full), self.name, self.fixed | full)
        concrete.units = {n: par.unit for n, par in self.parameters.items()}
        return concrete


def _fmt(v: float) -> str:
    text = f"{v:g}".replace(".", "p")
    return text.replace("-", "m") if text.startswith("-") else text


# ------------------------------------------------------------------- loading
def builtin_names() -> list[str]:
    return sorted(p.stem for p in _builtin_dir().glob("*.yaml"))


def _builtin_dir() -> Path:
    return Path(str(resources.files("simgap.scenario") / "builtin"))


def load_logical(name_or_path: str | Path) -> LogicalScenario:
    """A built-in logical scenario by name, or one from a YAML file."""
    text = str(name_or_path)
    path = Path(text)
    if not re.search(r"\.ya?ml$", text):
        if text not in builtin_names():
            raise InputError(f"no built-in logical scenario '{text}' and no such YAML file",
                             field="LOGICAL", allowed=", ".join(builtin_names()) + ", or a .yaml path")
        path = _builtin_dir() / f"{text}.yaml"
    logical = read_model(path, LogicalScenario, "logical scenario", "name, description, template, fixed, parameters")
    try:
        check_template_inputs(logical.template, logical.fixed, list(logical.parameters))
    except InputError as err:
        raise InputError(err.reason, file=path, field=err.field, allowed=err.allowed) from None
    source = logical.fixed.get("file")
    if logical.template == "opendrive" and isinstance(source, str):      # a road file beside the YAML
        logical.fixed["file"] = str((path.parent / source).resolve())
    return logical


def build_scenario(logical: str | Path | LogicalScenario, params: dict[str, float] | None = None) -> ConcreteScenario:
    """Build one concrete scenario in memory (no files written)."""
    spec = logical if isinstance(logical, LogicalScenario) else load_logical(logical)
    return spec.build(dict(params or {}))
