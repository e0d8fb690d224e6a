"""One export: a run as ``NAME.xodr`` + ``NAME.xosc``, or a scenario's road as ``NAME.xodr``.

The files are built in a hidden directory beside their destination, checked there
(`simgap.export.checks`: schema, round trip, lane centres) and only then moved into place: an
export that fails leaves nothing behind. A check that fails is simgap's bug (`CheckFailed`), not
the user's input.
"""

from __future__ import annotations

import re
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.scenario import Scenario

from simgap.errors import InputError
from simgap.export import checks
from simgap.export.opendrive import Method, RoadNetwork, UniformRoad, road_network
from simgap.export.opendrive_sampling import RoadSamples, sample_roads
from simgap.export.openscenario import DEFAULT_VERSION, OpenScenarioVersion, description, openscenario, road_users
from simgap.files import publish, staged_directory
from simgap.record import RunRecord, read_run
from simgap.scenario import load_scenario, read_sidecar
from simgap.scenario.relief import road_tilt
from simgap.sim.settings import road_friction

EXACT_TOLERANCE_M = 0.05         # a generated road's lane centres, read back from the file
FITTED_TOLERANCE_M = 0.05        # a fitted road's lane centres, read back, beyond the fit's own deviation (sampled elsewhere)
TRAJECTORY_TOLERANCE_M = 0.01    # a trajectory vertex, parsed back
READING = "reading the scenario"                # phases of an export, as its progress names them
WRITING = "writing the road network"
VALIDATING = "checking against the schema"
Progress = Callable[[str, int, int], None]      # on_progress(phase, done, total): how far an export is


def _silent(phase: str, done: int, total: int) -> None:
    """No progress is shown."""


@dataclass
class Export:
    """What one export wrote and what its checks measured."""

    name: str
    files: list[Path]
    method: Method
    lane_deviation_m: dict[int, float]            # per road: lane centres (file, every 0.1 m) to lanelet centres
    fit_deviation_m: dict[int, float] = field(default_factory=dict)   # fitted: per road, from the lanelet bounds
    lane_deviation_p99_m: float = 0.0             # the 99th percentile over every lane centre sample
    links: checks.LinksKept | None = None         # the lanelets' relations and those the file keeps
    trajectory_error_m: float | None = None       # largest parsed-back vertex error
    entities: int = 0
    schemas: dict[str, str] = field(default_factory=dict)             # file name -> schema it validates against
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)
    road_lanelets: dict[int, tuple[int, ...]] = field(default_factory=dict)  # per road: the lanelets its lanes stand for

    @property
    def largest_deviation_m(self) -> float:
        return max(self.lane_deviation_m.values(), default=0.0)


def safe_name(name: str) -> str:
    """``name`` as a file name: runs of other characters than letters, digits, ``_.-`` as ``_``."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "export"


def _blueprint(scenario_xml: Path | None):
    if scenario_xml is None or not Path(scenario_xml).exists():
        return None
    return read_sidecar(scenario_xml).blueprint


def _write_road(network: LaneletNetwork, name: str, blueprint, surface: UniformRoad, staged: Path,
                on_progress: Progress) -> tuple[RoadNetwork, Path, list[RoadSamples]]:
    """The road network written to ``staged``, its header's bounds those of its lanes as read back."""
    roads = road_network(network, name, blueprint, surface, on_progress)
    path = staged / f"{name}.xodr"
    on_progress(WRITING, 0, 1)
    roads.opendrive.write_xml(str(path))
    on_progress(WRITING, 1, 1)
    samples = sample_roads(path, on_progress=on_progress)
    points = np.vstack([r.reference for r in samples] + [b for r in samples for b in r.lane_borders.values()])
    tree = ET.parse(path)
    header = tree.getroot().find("header")
    assert header is not None, "xodr writes a header"
    for key, value in (("west", points[:, 0].min()), ("south", points[:, 1].min()), ("east", points[:, 0].max()),
                       ("north", points[:, 1].max())):
        header.set(key, repr(float(value)))
    tree.write(path, encoding="utf-8", xml_declaration=True)
    return roads, path, samples


def _check_road(roads: RoadNetwork, path: Path, samples: list[RoadSamples], network: LaneletNetwork,
                result: Export, on_progress: Progress) -> None:
    on_progress(VALIDATING, 0, 1)
    result.schemas[path.name], errors = checks.schema_errors(path)
    on_progress(VALIDATING, 1, 1)
    if errors:
        raise checks.CheckFailed(f"{path.name} does not validate against {result.schemas[path.name]}: {errors[0]}")
    result.links = checks.links_kept(path, roads, network)
    for lane in roads.lanes:
        result.road_lanelets[lane.road] = result.road_lanelets.get(lane.road, ()) + tuple(lane.lanelets)
    deviations = checks.lane_centre_deviation(samples, roads, network, on_progress)
    result.lane_deviation_m = {road: float(d.max()) for road, d in deviations.items()}
    result.lane_deviation_p99_m = float(np.percentile(np.concatenate(list(deviations.values())), 99))
    for road, deviation in result.lane_deviation_m.items():
        bound = EXACT_TOLERANCE_M if roads.method is Method.EXACT else roads.fit_deviation_m[road] + FITTED_TOLERANCE_M
        if deviation > bound:
            raise checks.CheckFailed(f"{path.name}: road {road}'s lane centres lie {deviation:.3f} m from their "
                                     f"lanelets (at most {bound:.3f} m allowed)")


def export_road(scenario_xml: str | Path, out: str | Path, name: str | None = None,
                on_progress: Progress = _silent) -> Export:
    """The road network of a CommonRoad scenario as ``NAME.xodr`` in ``out``; ``on_progress`` is
    told how far each long phase is (per road)."""
    started = time.perf_counter()
    scenario_xml, out = Path(scenario_xml), Path(out)
    on_progress(READING, 0, 1)
    scenario, _ = load_scenario(scenario_xml, needs_problems=False)
    on_progress(READING, 1, 1)
    name = safe_name(name or scenario_xml.stem)
    with staged_directory(out, name) as staged:
        roads, path, samples = _write_road(scenario.lanelet_network, name, _blueprint(scenario_xml), UniformRoad(), staged,
                                           on_progress)
        result = Export(name, [], roads.method, {}, dict(roads.fit_deviation_m), notes=list(roads.notes))
        _check_road(roads, path, samples, scenario.lanelet_network, result, on_progress)
        result.files = publish(staged, out, [path.name])
    result.seconds = time.perf_counter() - started
    return result


def read_driven_scenario(run_dir: Path, run: RunRecord) -> tuple[Path, Scenario, PlanningProblemSet]:
    """The scenario a run drove: its ``driven.xml``, or where it has none, the scenario file it
    names; the file, the scenario and its planning problems."""
    source = run_dir / "driven.xml"
    if not source.exists():
        scenario_path = run.settings.scenario_path
        if not scenario_path or not Path(scenario_path).exists():
            raise InputError("the run has no driven.xml and its scenario file is gone", file=run_dir,
                             allowed="a run directory written by simgap run, an experiment or a search")
        source = Path(scenario_path)
    scenario, problems = load_scenario(source)
    return source, scenario, problems


def export_run(run_dir: str | Path, out: str | Path, version: OpenScenarioVersion = DEFAULT_VERSION,
               scenario_xml: str | Path | None = None, name: str | None = None,
               on_progress: Progress = _silent) -> Export:
    """A run directory as ``NAME.xodr`` and ``NAME.xosc`` in ``out`` (NAME: the scenario and the
    world that ran it). ``scenario_xml``: the scenario file whose sidecar holds the road's
    blueprint (default: the one the run names); ``on_progress`` is told how far each long phase is."""
    started = time.perf_counter()
    run_dir, out = Path(run_dir), Path(out)
    on_progress(READING, 0, 1)
    run = read_run(run_dir)
    scenario_path = run.settings.scenario_path
    _, scenario, problems = read_driven_scenario(run_dir, run)
    on_progress(READING, 1, 1)
    surface = UniformRoad(road_friction(run.settings.backend), road_tilt(run.settings.backend))
    name = safe_name(name or f"{run.scenario_id}_{run.history.backend}")
    blueprint = _blueprint(Path(scenario_xml) if scenario_xml else
                           (Path(scenario_path) if scenario_path else None))
    with staged_directory(out, name) as staged:
        roads, road_path, samples = _write_road(scenario.lanelet_network, name, blueprint, surface, staged,
                                                on_progress)
        result = Export(name, [], roads.method, {}, dict(roads.fit_deviation_m), notes=list(roads.notes))
        if blueprint is None:
            result.notes.append("no blueprint beside the scenario: the road network is fitted")
        _check_road(roads, road_path, samples, scenario.lanelet_network, result, on_progress)
        users = road_users(run, scenario)
        osc = openscenario(run, users, problems, road_path.name, version, description(run, users, result.notes),
                           surface.friction)
        osc_path = staged / f"{name}.xosc"
        osc.write_xml(str(osc_path))
        result.schemas[osc_path.name], errors = checks.schema_errors(osc_path)
        if errors:
            raise checks.CheckFailed(f"{osc_path.name} does not validate against {result.schemas[osc_path.name]}: "
                                     f"{errors[0]}")
        result.entities = len(users)
        result.trajectory_error_m = checks.trajectory_error(
            osc_path, {u.name: u.trajectory for u in users if not u.standing and len(u.trajectory) > 1})
        if result.trajectory_error_m > TRAJECTORY_TOLERANCE_M:
            raise checks.CheckFailed(f"{osc_path.name}: a trajectory vertex parses back "
                                     f"{result.trajectory_error_m:.4f} m from the run's")
        result.files = publish(staged, out, [road_path.name, osc_path.name])
    result.seconds = time.perf_counter() - started
    return result
