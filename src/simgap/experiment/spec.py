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
    planners:                         # optional (default [frenet]): every run with each planner
      - frenet
      - {planner: frenet, label: frenet-slow, settings: {speed: {cruise_m_s: 6}}}
      - my_planners.py:TimeGapPlanner # a file beside the spec (or my_pkg.module:Class, or an installed name)
    cosim: {replan_every: 1}
    evaluation: {cost_function: SM1}  # optional: the cost function, score thresholds and weights

A wrong key, type or range is an `InputError` naming the file, the field path and what is allowed.
An experiment samples at most `MAX_SCENARIOS` concrete scenarios: every one is written (about
160 kB of CommonRoad XML) before the first run.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from simgap.control import DEFAULT_CONTROLLER
from simgap.control.registry import CONTROLLERS
from simgap.cosim import REFERENCE, CosimSettings, Fidelity
from simgap.cosim.interruptions import DEFAULT_RUN_TIMEOUT_S
from simgap.errors import InputError, validated
from simgap.evaluate import EvaluationSettings
from simgap.experiment.job import Job, JobId
from simgap.experiment.samplers import grid_size, sample
from simgap.files import read_model
from simgap.planning.registry import DEFAULT_PLANNER, PlannerChoice
from simgap.planning.remote import ProcessLimits
from simgap.scenario.logical import LogicalScenario, load_logical
from simgap.scenario.relief import road_tilt
from simgap.scenario.templates import ONE_ROAD
from simgap.sim.assumptions import Assumption
from simgap.sim.registry import BACKENDS, backend_available, backend_settings
from simgap.sim.settings import realism_of
from simgap.vehicles import DEFAULT_VEHICLE, is_vehicle_file, load_vehicle, vehicle_names

MAX_SCENARIOS = 10_000      # concrete scenarios per experiment: about 1.6 GB of files, minutes to write

# spec fields newer than stored results, and their defaults
ADDED_FIELDS = {"planner_vehicle": DEFAULT_VEHICLE, "planners": [{"planner": DEFAULT_PLANNER, "settings": {},
                                                                    "label": None}], "evaluation": {}}
# the evaluation's settings a spec once gave under cosim (read as evaluation's; the spec's hash unchanged)
EVALUATION_KEYS_UNDER_COSIM = ("cost_function", "score")
# fields of a planner newer than stored results, and their defaults
ADDED_PLANNER_FIELDS = {"isolate": False, "process": ProcessLimits().model_dump()}
PLANNERS_DESCRIPTION = ("the planners every run is made with (each a dimension value): a name, module:Class, "
                        "path/to/file.py:Class (relative to the spec), or {planner, settings, label}")
LEGACY_PLANNER_DESCRIPTION = "the frenet planner's settings (older specs; now: planners: [{planner: frenet, settings: ...}])"


class ParameterRange(BaseModel):
    """How a spec narrows one parameter: a list of values, or a range for random samplers."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    values: list[float] | None = None
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _one_form(self) -> ParameterRange:
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
    samples: int | None = Field(None, ge=1, le=MAX_SCENARIOS, description="number of samples (not for grid)")
    seed: int = 0

    @model_validator(mode="after")
    def _samples_given(self) -> SamplerSpec:
        if self.kind == "grid" and self.samples is not None:
            raise ValueError("a grid has no 'samples': it takes every combination")
        if self.kind != "grid" and self.samples is None:
            raise ValueError(f"the {self.kind} sampler needs 'samples'")
        return self


class FidelitySpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    backend: str
    vehicles: list[str] = Field(default_factory=lambda: [DEFAULT_VEHICLE], min_length=1)
    controllers: list[str] = Field(default_factory=lambda: [DEFAULT_CONTROLLER], min_length=1)
    settings: dict[str, Any] = Field(default_factory=dict, description="backend settings (physics_hz, ...)")


class BatchSpec(BaseModel):
    """What experiment and search specs share, each default written once: the name, the logical
    scenario, the seed, the planners, the vehicle the planner assumes, the loop settings and the
    per-run timeout."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
    description: str = ""
    logical: str
    seed: int = 0
    planners: list[PlannerChoice] = Field(default_factory=lambda: [PlannerChoice()], min_length=1,
                                          description=PLANNERS_DESCRIPTION)
    planner: dict[str, Any] = Field(default_factory=dict, description=LEGACY_PLANNER_DESCRIPTION)
    planner_vehicle: str = Field(DEFAULT_VEHICLE, description="the vehicle the planner assumes it drives; the ideal "
                                 "world drives it too (a catalogue name or a data file beside the spec)")
    cosim: dict[str, Any] = Field(default_factory=dict)
    run_timeout_s: float = Field(DEFAULT_RUN_TIMEOUT_S, gt=0, allow_inf_nan=False,
                                 description="wall time [s]: a run taking longer is stopped and recorded as failed")


class ExplainSpec(BaseModel):
    """Which of an experiment's physical runs are explained once they have run (`simgap explain`:
    which of the planner's assumptions each broke, and by how much), the worst first."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    failed: bool = Field(True, description="explain the physical runs that did not reach every goal")
    gap_above_m: float | None = Field(None, gt=0, allow_inf_nan=False,
                                      description="and those whose max |d| against the ideal run of their scenario "
                                                  "and planner exceeds this [m]")
    assumptions: list[Assumption] | None = Field(None, min_length=1, description="restore only these of the "
                                                 "assumptions a run broke (default: every one: 2^n runs each)")
    limit: int | None = Field(None, ge=1, description="explain at most this many runs (default: every one chosen)")


class ExperimentSpec(BatchSpec):
    parameters: dict[str, ParameterRange] = Field(default_factory=dict)
    sampler: SamplerSpec = Field(default_factory=SamplerSpec)
    fidelities: list[FidelitySpec] = Field(min_length=1)
    repeats: int = Field(1, ge=1, le=1000)
    explain: ExplainSpec | None = Field(None, description="explain the runs that failed or parted from their ideal "
                                        "run by more than a threshold (simgap explain), after the runs")
    evaluation: dict[str, Any] = Field(default_factory=dict, description="what every run is evaluated by "
                                       "(simgap.evaluate.EvaluationSettings: cost_function, score)")

    def results_relevant(self) -> dict[str, Any]:
        return results_relevant(self, {"name", "description", "run_timeout_s", "explain"})

    def results_hash(self) -> str:
        """Over everything that changes results (not the name, description or timeout)."""
        return results_hash(self.results_relevant())


def results_relevant(spec: BaseModel, exclude: set[str]) -> dict[str, Any]:
    """The fields of ``spec`` that change results. A field added since results were first stored
    counts only when it differs from its default, so that existing directories still resume."""
    relevant = spec.model_dump(exclude=exclude)
    for choice in relevant.get("planners") or []:
        for name, default in ADDED_PLANNER_FIELDS.items():
            if choice.get(name) == default:
                choice.pop(name)
    for name, default in ADDED_FIELDS.items():
        if relevant.get(name) == default:
            relevant.pop(name, None)
    return relevant


def results_hash(relevant: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(relevant, sort_keys=True, default=str).encode()).hexdigest()[:16]


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


@dataclass(frozen=True)
class FidelityVariant:
    """One fidelity of a spec as its runs take it: the fidelity, the vehicle a run loads (a
    catalogue name or a data file's absolute path) and the backend's settings, validated once
    (None for an optional backend that is not installed: refused when the batch starts)."""

    fidelity: Fidelity
    vehicle: str
    settings: BaseModel | None


@dataclass(frozen=True)
class Experiment:
    """An experiment spec as read and checked where it was read: the spec as the file says it
    (its results hash), its logical scenario and file, and what its runs take — every fidelity's
    variants with their settings models, the planners (loaded, their settings validated), the
    loop settings and the planner's vehicle."""

    spec: ExperimentSpec
    logical: LogicalScenario
    file: Path
    variants: list[list[FidelityVariant]]      # per fidelity of the spec: its vehicles x controllers
    planners: list[PlannerChoice]
    cosim: CosimSettings
    planner_vehicle: str
    evaluation: EvaluationSettings


def load_spec(name_or_path: str | Path) -> Experiment:
    """The experiment a spec file (or a built-in name) describes; every problem is an `InputError`
    naming the file and the field."""
    path = spec_path(name_or_path)
    spec = read_spec(path, ExperimentSpec, "experiment spec", "name, logical, fidelities, ...")
    return checked_experiment(spec, logical_of(spec, path), path)


def checked_experiment(spec: ExperimentSpec, logical: LogicalScenario, path: Path) -> Experiment:
    """``spec`` checked against ``logical`` and the registries, every setting validated into its
    model; errors name ``path`` and the field."""
    for name, rng in spec.parameters.items():
        values = (rng.values or []) + [x for x in (rng.min, rng.max) if x is not None]
        check_parameter(logical, name, min(values), max(values), path)
    if spec.sampler.kind == "grid" and (size := grid_size(spec, logical)) > MAX_SCENARIOS:
        raise InputError(f"the grid spans {size:,} scenarios", file=path, field="parameters",
                         allowed=f"at most {MAX_SCENARIOS:,} per experiment: fewer values, or a random sampler")
    check_vehicles([spec.planner_vehicle], path, "planner_vehicle")
    planner_vehicle = vehicle_ref(spec.planner_vehicle, path)
    variants = []
    for i, fid in enumerate(spec.fidelities):
        check_backend(fid.backend, path, f"fidelities.{i}")
        check_vehicles(fid.vehicles, path, f"fidelities.{i}.vehicles")
        for c in fid.controllers:
            check_controller(c, path, f"fidelities.{i}.controllers")
        combos = [(planner_vehicle, None)] if fid.backend == REFERENCE else \
            [(vehicle_ref(v, path), c) for v in fid.vehicles for c in fid.controllers]
        fidelity_variants = []
        for vehicle, controller in combos:
            settings = settings_of(fid.backend, dict(fid.settings) | (
                {"controller": controller} if controller is not None else {}), path, f"fidelities.{i}.settings")
            check_tilt(logical, not road_tilt(settings).is_level, path, f"fidelities.{i}.settings")
            fidelity = Fidelity(fid.backend, load_vehicle(vehicle).name, controller, realism_of(settings))
            fidelity_variants.append(FidelityVariant(fidelity, vehicle, settings))
        variants.append(fidelity_variants)
    _check_each_fidelity_once(variants, path)
    planners = planner_choices(spec, path)
    cosim, evaluation = loop_and_evaluation(spec.cosim, spec.evaluation, path)
    return Experiment(spec, logical, path, variants, planners, cosim, planner_vehicle, evaluation)


def loop_and_evaluation(cosim: dict[str, Any], evaluation: dict[str, Any],
                        path: Path) -> tuple[CosimSettings, EvaluationSettings]:
    """The loop's settings and the evaluation's, validated; a spec written when the cost function and
    the score were loop settings (``cosim.cost_function``, ``cosim.score``) is read as it was meant."""
    moved = {k: v for k, v in cosim.items() if k in EVALUATION_KEYS_UNDER_COSIM}
    if twice := sorted(set(moved) & set(evaluation)):
        raise InputError(f"{twice[0]} is given under both cosim and evaluation", file=path, field=f"cosim.{twice[0]}",
                         allowed=f"evaluation.{twice[0]} only (cosim.{twice[0]} is its older place)")
    loop = validated(CosimSettings, {k: v for k, v in cosim.items() if k not in moved}, file=path, prefix="cosim")
    prefix = "cosim" if moved and not evaluation else "evaluation"
    return loop, validated(EvaluationSettings, moved | evaluation, file=path, prefix=prefix)


def _check_each_fidelity_once(variants: list[list[FidelityVariant]], path: Path) -> None:
    """No two variants run as one fidelity: their runs would share a key, and one row."""
    seen: dict[str, str] = {}
    for i, fidelity_variants in enumerate(variants):
        for variant in fidelity_variants:
            label, where = variant.fidelity.label, f"fidelities.{i}"
            if label in seen:
                twice = f"names '{label}' twice" if seen[label] == where else f"runs as '{label}', as {seen[label]} does"
                raise InputError(f"{twice}: their runs would be one", file=path, field=where,
                                 allowed="each backend, vehicle and controller once")
            seen[label] = where


def planner_choices(spec: Any, spec_file: Path) -> list[PlannerChoice]:
    """The planners of an experiment or search spec, each loaded and its settings validated, file
    references made absolute against the spec's folder; an older spec's ``planner:`` section is the
    frenet planner's settings. Errors name the spec file and ``planners.N``."""
    if spec.planner:
        if spec.planners != [PlannerChoice()]:
            raise InputError("a spec with planners gives each planner's settings there, not in 'planner'",
                             file=spec_file, field="planner",
                             allowed="planners: [{planner: frenet, settings: {...}}]")
        choices = [PlannerChoice(planner=DEFAULT_PLANNER, settings=spec.planner)]
        choices[0].load(file=spec_file, field="planner", settings_field="planner")
        return choices
    choices = [c.with_file_base(spec_file.parent) for c in spec.planners]
    seen: dict[str, int] = {}
    for i, choice in enumerate(choices):
        choice.load(file=spec_file, field=f"planners.{i}")
        if choice.name in seen:
            raise InputError(f"two planners are named '{choice.name}' (planners.{seen[choice.name]} and "
                             f"planners.{i})", file=spec_file, field=f"planners.{i}.label",
                             allowed="a label of its own for each planner")
        seen[choice.name] = i
    return choices


def check_parameter(logical: LogicalScenario, name: str, low: float, high: float, path: Path) -> None:
    """``name`` is a parameter of ``logical`` and [low, high] lies in its range."""
    if name not in logical.parameters:
        raise InputError(f"'{name}' is not a parameter of logical scenario '{logical.name}'", file=path,
                         field=f"parameters.{name}", allowed=", ".join(logical.parameters))
    par = logical.parameters[name]
    if low < par.min or high > par.max:
        what = f"{low:g} {par.unit} is out of range" if low == high else f"[{low:g}, {high:g}] leaves the parameter's range"
        raise InputError(what, file=path, field=f"parameters.{name}", allowed=f"{par.min:g} to {par.max:g} {par.unit}")


def check_tilt(logical: LogicalScenario, tilted: bool, path: Path, where: str) -> None:
    """A tilt of the road (``road_bank``, ``road_grade``: the field ``where``) asked of ``logical``'s
    scenarios, refused up front where they have no road's reference line for it to lie along (each
    of their runs would refuse it: `simgap.scenario.ground.ground_of`)."""
    if tilted and not logical.has_reference_line:
        raise InputError(f"the scenarios of '{logical.name}' ({logical.template}) have no road's reference line to "
                         "lay a uniform bank or grade along", file=path, field=where,
                         allowed=f"a logical scenario of one road ({', '.join(sorted(ONE_ROAD))}), or no road_bank "
                                 "and road_grade")


def check_backend(name: str, path: Path, where: str) -> None:
    """``name`` (the field ``where``.backend) is a backend."""
    BACKENDS.target_of(name, file=path, field=f"{where}.backend")


def settings_of(backend: str, values: dict[str, Any], path: Path, where: str) -> BaseModel | None:
    """``values`` (the field ``where``) validated into the settings model of ``backend``, as its
    runs take them (None for an optional backend that is not installed: refused when the batch
    starts)."""
    return backend_settings(backend, values, file=path, where=where) if backend_available(backend) else None


def check_controller(name: str, path: Path, where: str) -> None:
    CONTROLLERS.target_of(name, file=path, field=where)


def vehicle_ref(name_or_file: str, spec_file: Path) -> str:
    """How a run loads a vehicle a spec names: a catalogue name, or a data file's absolute path
    (relative paths are relative to the spec)."""
    if not is_vehicle_file(name_or_file):
        return name_or_file
    return str((spec_file.parent / name_or_file).resolve())


def check_vehicles(names: list[str], path: Path, where: str) -> None:
    """Every vehicle a spec names loads: a catalogue name, or a valid data file."""
    for v in names:
        if is_vehicle_file(v):
            load_vehicle(vehicle_ref(v, path))
        elif v not in vehicle_names():
            raise InputError(f"unknown vehicle '{v}'", file=path, field=where, allowed=", ".join(vehicle_names()))


def jobs(experiment: Experiment) -> list[tuple[dict[str, Any], list[Job]]]:
    """Every concrete parameter set of the experiment with the runs it takes, in a stable order."""
    spec = experiment.spec
    out = []
    for params in sample(spec, experiment.logical):
        name = experiment.logical.scenario_name(params)
        runs = []
        for variant in (v for variants in experiment.variants for v in variants):
            for planner in experiment.planners:
                for r in range(spec.repeats):
                    job_id = JobId(name, variant.fidelity, r if spec.repeats > 1 else None, spec.seed + r, planner.name)
                    runs.append(Job(job_id, params, variant.vehicle, variant.settings, experiment.cosim,
                                    planner=planner))
        out.append((params, runs))
    return out
