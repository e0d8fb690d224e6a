"""Concrete scenarios on disk: CommonRoad XML, a JSON sidecar with where it came from, a PNG."""

from __future__ import annotations

import errno
import json
import logging
import os
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from xml.etree import ElementTree

from commonroad.common.file_reader import CommonRoadFileReader
from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.scenario import Location, Scenario
from lxml import etree

from simgap.errors import InputError
from simgap.files import atomic_write, atomic_write_text
from simgap.scenario.physical_bounds import check_lanelets, check_planning_problems, check_time_step
from simgap.scenario.templates import ConcreteScenario

XML_PRECISION = 8  # decimals written for coordinates: a written file reloads equal to 1e-8 m
READ_FORMATS = ("2018b", "2020a")   # the CommonRoad formats commonroad-io 2024.3 reads


def _format_version(path: Path) -> str | None:
    """The ``commonRoadVersion`` of the file's root element (None: not XML, or no such attribute)."""
    try:
        _, root = next(ElementTree.iterparse(path, events=("start",)))
    except (ElementTree.ParseError, StopIteration):
        return None
    return root.get("commonRoadVersion")


@contextmanager
def quiet_reader() -> Iterator[None]:
    """Read CommonRoad files without commonroad-io's warnings (a traffic sign of a country it does not
    know read as an unknown sign: nothing a user can act on, and nothing simgap reads)."""
    reader_log = logging.getLogger("commonroad.common.reader.file_reader_xml")
    level = reader_log.level
    reader_log.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        reader_log.setLevel(level)


def write_xml(scenario: Scenario, problems: PlanningProblemSet, path: Path, source: str = "simgap") -> None:
    """CommonRoad XML of ``scenario`` and ``problems`` at ``path`` (written atomically)."""
    writer = CommonRoadFileWriter(scenario, problems, author="simgap", affiliation="", source=source,
                                  tags=set(), location=Location(), decimal_precision=XML_PRECISION)

    def write(p: Path) -> None:
        try:
            writer.write_to_file(str(p), OverwriteExistingFile.ALWAYS)
        except etree.SerialisationError as exc:      # lxml's word for a failed write: the disk's error
            if "ENOSPC" in str(exc):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path)) from None
            raise

    atomic_write(Path(path), write, keep_suffix=True)


def scenario_xml(scenario: Scenario, problems: PlanningProblemSet) -> str:
    """``scenario`` and ``problems`` as CommonRoad XML text (as `write_xml` writes them)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scenario.xml"
        write_xml(scenario, problems, path)
        return path.read_text()


def write_scenario(concrete: ConcreteScenario, out_dir: str | Path, preview: bool = True) -> Path:
    """Write ``<name>.xml``, ``<name>.json`` (and ``<name>.png``) into ``out_dir``; returns the XML path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    xml = out_dir / f"{concrete.name}.xml"
    write_xml(concrete.scenario, concrete.problems, xml, f"simgap logical scenario '{concrete.logical}'")
    atomic_write_text(xml.with_suffix(".json"), json.dumps(concrete.sidecar.as_json(), indent=2))
    if preview:
        from simgap.scenario.preview import draw_preview

        atomic_write(xml.with_suffix(".png"),
                      lambda p: draw_preview(concrete.scenario, concrete.problems, p, concrete.name), keep_suffix=True)
    return xml


def load_scenario(path: str | Path, needs_problems: bool = True) -> tuple[Scenario, PlanningProblemSet]:
    """Read a CommonRoad XML scenario that has at least one planning problem (or, without
    ``needs_problems``, any: a road network alone)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no such scenario file", file=path, allowed="a CommonRoad XML file")
    version = _format_version(path)
    if version is not None and version not in READ_FORMATS:
        raise InputError(f"CommonRoad format {version}, which commonroad-io 2024.3 does not read", file=path,
                         field="commonRoadVersion", allowed=f"{' or '.join(READ_FORMATS)}; convert older files first")
    try:
        with quiet_reader():
            scenario, problems = CommonRoadFileReader(str(path)).open()
    except Exception as exc:  # the reader raises many kinds on malformed input
        raise InputError(f"not a readable CommonRoad scenario ({type(exc).__name__}: {exc})".strip(),
                         file=path, allowed=f"CommonRoad XML ({' or '.join(READ_FORMATS)} format)") from None
    check_time_step(float(scenario.dt), file=path, field="timeStepSize")
    check_lanelets(scenario.lanelet_network, path)
    _check_obstacles_are_placed(scenario, path)
    if needs_problems and (problems is None or not problems.planning_problem_dict):
        raise InputError("the scenario has no planning problems, so there is no agent to run",
                         file=path, field="planningProblem",
                         allowed="one or more planning problems; simgap run places one agent on any map with "
                                 "--start X,Y --goal X,Y")
    if problems is not None:
        check_planning_problems(problems, path)
    return scenario, problems


def _check_obstacles_are_placed(scenario: Scenario, path: Path) -> None:
    """Every state of a static or dynamic obstacle (the road users simgap places; phantom
    obstacles, occluded road users that may be there, are not) has a position: a recording in
    curvilinear states alone (offset, curvature: commonroad-io reads them) cannot be placed."""
    for obstacle in [*scenario.static_obstacles, *scenario.dynamic_obstacles]:
        prediction = getattr(obstacle, "prediction", None)
        states = [obstacle.initial_state, *(prediction.trajectory.state_list
                                            if isinstance(prediction, TrajectoryPrediction) else [])]
        unplaced = next((st for st in states if getattr(st, "position", None) is None), None)
        if unplaced is not None:
            raise InputError(f"obstacle {obstacle.obstacle_id} has a state without a position (time step "
                             f"{getattr(unplaced, 'time_step', '?')}), so it cannot be placed on the map",
                             file=path, field=f"obstacle {obstacle.obstacle_id}",
                             allowed="states with a position (point or shape), as every state type but the "
                                     "lateral and longitudinal ones has")
