"""What a run reads of its scenario, read once before its loop starts (`RunScene`): the CommonRoad
file, its sidecar (typed), the planning problems (the file's, or a placement's), the scenario as the
loop runs it (every agent in place of its recorded vehicle) and its recorded obstacles, the ground
the 3D worlds build and the drivable area the loop and the evaluation judge footprints against.
The loop and the evaluation take these instead of reading the scenario's files or making its
obstacles again (the evaluation still opens the file's header for its benchmark ID's cost function,
and the validity check parses the file it is given; MuJoCo's world builds its recorded obstacles as
bodies from the scenario its ``load`` is given)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.scenario import load_scenario, read_sidecar
from simgap.scenario.ground import ground_of
from simgap.scenario.obstacles import RecordedObstacle, recorded_obstacles, without_recorded_egos
from simgap.scenario.placement import AgentPlacement
from simgap.scenario.relief import LEVEL, RoadTilt, Surface
from simgap.scenario.road_frame import DrivableArea
from simgap.scenario.sidecar import ScenarioSidecar


@dataclass(frozen=True)
class RunScene:
    """A run's scenario, read (see the module doc)."""

    file: Path                       # the scenario file the run names
    read: Scenario                   # the scenario as the file holds it
    scenario: Scenario               # as the loop runs it: the recorded egos left out
    problems: PlanningProblemSet     # the file's, or the placement's
    sidecar: ScenarioSidecar         # with the placement's parameters
    relief: Surface | None           # the ground the 3D worlds build (None: flat, or the flat twin)
    recorded_egos: dict[int, int]    # agent id -> the recorded obstacle it replaces
    road: DrivableArea               # the lanelets' union, widened by the loop's off-road tolerance
    obstacles: tuple[RecordedObstacle, ...]   # the scenario's, as recorded (`recorded_obstacles`)

    @property
    def agent_ids(self) -> list[int]:
        return sorted(self.problems.planning_problem_dict)


def read_scene(file: Path, placement: AgentPlacement | None, flat_road: bool, offroad_tolerance_m: float,
               tilt: RoadTilt = LEVEL) -> RunScene:
    """The scenario of ``file`` with its planning problems (``placement``'s agent instead, for a map
    without any), its relief with the world's ``tilt`` laid on it unless ``flat_road`` (its flat
    twin: no relief, no tilt; `simgap.scenario.ground.ground_of` refuses a tilt it cannot lay,
    naming ``file``), and its road widened by ``offroad_tolerance_m``."""
    read, problems = load_scenario(file, needs_problems=placement is None)
    sidecar = read_sidecar(file)
    if placement is not None:
        problems = placement.planning_problems(read)
        sidecar = sidecar.with_parameters(placement.parameters())
    scenario, recorded_egos = without_recorded_egos(read, problems)
    relief = None if flat_road else ground_of(sidecar, scenario.lanelet_network, tilt, file)
    return RunScene(Path(file), read, scenario, problems, sidecar, relief, recorded_egos,
                    DrivableArea(scenario.lanelet_network, offroad_tolerance_m), tuple(recorded_obstacles(scenario)))
