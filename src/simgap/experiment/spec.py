"""The experiment spec: a YAML file saying which scenarios to sample, in which fidelities, with
which vehicles and controllers, how often — and the one expansion of it into runs (`jobs`).

Example (the built-in `demo`)::

    name: demo
    logical: curve                    # built-in logical scenario, or a YAML file beside the spec
    parameters:                       # optional: narrow the logical scenario's space
      radius: {values: [10, 30, 75]}
      angle: {values: [90]}
    sampler: {kind: grid}             # grid | random | lhs | sobol (with samples and seed)
    fidelities:
      - backend: ideal
      - backend: mujoco
        vehicles: [sedan, city]
        controllers: [pure_pursuit]
    cosim: {replan_every: 1}

A wrong key, type or range is an `InputError` naming the file, the field path and what is allowed.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from simgap.cosim import CosimSettings
from simgap.errors import InputError, validated
from simgap.files import read_model
from simgap.planning.frenet import FrenetSettings
from simgap.scenario.logical import LogicalScenario, load_logical


class ParameterRange(BaseModel):
    """How a spec narrows one parameter: a list of values, or a range for random samplers."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    values: list[float] | None = None
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _one_form(self) -> "ParameterRange":
        if self.values is not None and (self.min is not None or self.max is not None):
            raise ValueError("give either values or min/max, not both")
        if self.values is not None and not self.values:
            raise ValueError("values must not be empty")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError("min must not exceed max")
        return self


class SamplerSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: Literal["grid", "random", "lhs", "sobol"] = "grid"
    samples: int | None = Field(None, ge=1, le=100_000, description="number of samples (not for grid)")
    seed: int = 0

    @model_validator(mode="after")
    def _samples_given(self) -> "SamplerSpec":
        if self.kind == "grid" and self.samples is not None:
            raise ValueError("a grid has no 'samples': it takes every combination")
        if self.kind != "grid" and self.samples is None:
            raise ValueError(f"the {self.kind} sampler needs 'samples'")
        return self


class FidelitySpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    backend: str
    vehicles: list[str] = Field(default_factory=lambda: ["sedan"], min_length=1)
    controllers: list[str] = Field(default_factory=lambda: ["pure_pursuit"], min_length=1)
    settings: dict[str, Any] = Field(default_factory=dict, description="backend settings (physics_hz, ...)")


class ExperimentSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
    description: str = ""
    logical: str
    parameters: dict[str, ParameterRange] = Field(default_factory=dict)
    sampler: SamplerSpec = Field(default_factory=SamplerSpec)
    fidelities: list[FidelitySpec] = Field(min_length=1)
    repeats: int = Field(1, ge=1, le=1000)
    seed: int = 0
    planner: dict[str, Any] = Field(default_factory=dict)
    cosim: dict[str, Any] = Field(default_factory=dict)
    run_timeout_s: float = Field(600.0, gt=0, description="a run taking longer is stopped and recorded as failed")

    def results_hash(self) -> str:
        """Over everything that changes results (not the name, description or timeout)."""
        relevant = self.model_dump(exclude={"name", "description", "run_timeout_s"})
        return hashlib.sha256(json.dumps(relevant, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Job:
    """One run of an experiment."""

    key: str                      # unique and stable: scenario/fidelity[/repeat]
    scenario: str                 # scenario name
    parameters: dict[str, Any]
    backend: str
    vehicle: str
    controller: str | None
    backend_settings: dict[str, Any]
    repeat: int
    seed: int
    cosim: dict[str, Any] = field(default_factory=dict)      # over the experiment's cosim settings
    scenario_path: str | None = None                          # else the context's scenarios[scenario]

    @property
    def fidelity(self) -> str:
        if self.backend == "ideal":
            return "ideal"
        label = f"{self.backend}/{self.vehicle}"
        return label if self.controller in (None, "pure_pursuit") else f"{label}/{self.controller}"


def _builtin_dir() -> Path:
    return Path(str(resources.files("simgap.experiment") / "builtin"))


def builtin_or_file(name_or_path: str | Path, folder: Path, what: str) -> Path:
    """A YAML file given by path, or the built-in ``folder/NAME.yaml``."""
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml") or "/" in str(name_or_path):
        return path
    builtin = folder / f"{name_or_path}.yaml"
    if not builtin.exists():
        names = ", ".join(sorted(p.stem for p in folder.glob("*.yaml")))
        raise InputError(f"unknown {what} '{name_or_path}'", field="spec", allowed=f"a YAML file, or one of {names}")
    return builtin


def spec_path(name_or_path: str | Path) -> Path:
    return builtin_or_file(name_or_path, _builtin_dir(), "experiment")


def read_spec(path: Path, model: type[BaseModel], what: str, keys: str) -> Any:
    """``path`` read as YAML and validated as ``model``; every problem is an `InputError`."""
    return read_model(path, model, what, keys)


def logical_of(spec: Any, path: Path) -> LogicalScenario:
    """The logical scenario a spec names: built-in, or a YAML file relative to the spec."""
    ref = spec.logical
    if ref.endswith((".yaml", ".yml")) and not Path(ref).is_absolute():
        ref = str(path.parent / ref)
    return load_logical(ref)


def load_spec(name_or_path: str | Path) -> tuple[ExperimentSpec, LogicalScenario, Path]:
    """The spec, its logical scenario, and the spec file; every problem is an `InputError`."""
    path = spec_path(name_or_path)
    spec = read_spec(path, ExperimentSpec, "experiment spec", "name, logical, fidelities, ...")
    logical = logical_of(spec, path)
    _check_against(spec, logical, path)
    return spec, logical, path


def _check_against(spec: ExperimentSpec, logical: LogicalScenario, path: Path) -> None:
    from simgap.control import controller_names
    from simgap.sim.registry import BACKENDS
    from simgap.vehicles import vehicle_names

    for name, rng in spec.parameters.items():
        if name not in logical.parameters:
            raise InputError(f"'{name}' is not a parameter of logical scenario '{logical.name}'", file=path,
                             field=f"parameters.{name}", allowed=", ".join(logical.parameters))
        par = logical.parameters[name]
        for v in (rng.values or []) + [x for x in (rng.min, rng.max) if x is not None]:
            if not par.min <= v <= par.max:
                raise InputError(f"{v:g} {par.unit} is out of range", file=path, field=f"parameters.{name}",
                                 allowed=f"{par.min:g} to {par.max:g} {par.unit}")
    for i, fid in enumerate(spec.fidelities):
        if fid.backend not in BACKENDS:
            raise InputError(f"unknown backend '{fid.backend}'", file=path, field=f"fidelities.{i}.backend",
                             allowed=", ".join(BACKENDS))
        for v in fid.vehicles:
            if v not in vehicle_names() and not v.endswith((".yaml", ".yml")):
                raise InputError(f"unknown vehicle '{v}'", file=path, field=f"fidelities.{i}.vehicles",
                                 allowed=", ".join(vehicle_names()))
        for c in fid.controllers:
            if c not in controller_names():
                raise InputError(f"unknown controller '{c}'", file=path, field=f"fidelities.{i}.controllers",
                                 allowed=", ".join(controller_names()))
    for section, model in (("planner", FrenetSettings), ("cosim", CosimSettings)):
        validated(model, getattr(spec, section), file=path, prefix=section)


def _settings(model, values: dict):
    return model.model_validate(dict(values or {}))


def planner_settings(spec: ExperimentSpec) -> FrenetSettings:
    return _settings(FrenetSettings, spec.planner)


def cosim_settings(spec: ExperimentSpec) -> CosimSettings:
    return _settings(CosimSettings, spec.cosim)


def jobs(spec: ExperimentSpec, logical: LogicalScenario) -> list[tuple[dict[str, Any], list[Job]]]:
    """Every concrete parameter set of the spec with the runs it takes, in a stable order."""
    from simgap.experiment.samplers import sample

    out = []
    for params in sample(spec, logical):
        name = logical.scenario_name(params)
        runs = []
        for fid in spec.fidelities:
            combos = [("sedan", None)] if fid.backend == "ideal" else \
                [(v, c) for v in fid.vehicles for c in fid.controllers]
            for vehicle, controller in combos:
                for r in range(spec.repeats):
                    settings = dict(fid.settings)
                    if controller is not None:
                        settings["controller"] = controller
                    job = Job("", name, params, fid.backend, vehicle, controller, settings, r, spec.seed + r)
                    key = f"{name}/{job.fidelity}" + (f"/r{r}" if spec.repeats > 1 else "")
                    runs.append(replace(job, key=key))
        out.append((params, runs))
    return out
