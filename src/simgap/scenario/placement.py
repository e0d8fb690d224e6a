"""One agent placed on any CommonRoad map by a start and a goal point (``simgap run MAP.xml
--start X,Y[,HEADING] --goal X,Y[,RADIUS]``): a map without planning problems (a real map, a road
network drawn elsewhere) becomes a scenario with one agent, as the OpenDRIVE import places one.

The start is the centre of the lane under ``X,Y`` nearest it, heading along the lane (or
``HEADING``, degrees counter-clockwise from +x, which also picks the lane where several overlap);
the agent starts at rest. The goal is a 10 m x lane-width box along the lane under its point (or a
disc of ``RADIUS`` m around the point), on a lane reached from the start by following the lanes'
successors and lane changes the same way, within `TIME_LIMIT_S`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.errors import InputError
from simgap.scenario.lane_places import place_under, reachable
from simgap.scenario.problem import planning_problem

START_FORMS = ("X,Y or X,Y,HEADING: a point on a lane [m] (the agent starts on the lane's centre nearest it), "
               "HEADING in degrees counter-clockwise from +x (default: along the lane)")
GOAL_FORMS = ("X,Y or X,Y,RADIUS: a point on a lane ahead of the start [m]; the goal is a 10 m x lane-width box "
              "along the lane there, or a disc of RADIUS m (0 to 50) around the point")
TIME_LIMIT_S = 60.0            # the time to reach the goal, as the OpenDRIVE import's default
MAX_GOAL_RADIUS_M = 50.0
_POINT = re.compile(r"^\s*([^,]+),([^,]+)(?:,([^,]+))?\s*$")


@dataclass(frozen=True)
class MapPoint:
    """A point given on the command line, and its optional third number (a heading, a radius)."""

    x: float
    y: float
    extra: float | None = None

    @classmethod
    def parse(cls, text: str, option: str, allowed: str) -> MapPoint:
        m = _POINT.match(text)
        if m is None:
            raise InputError(f"'{text}' is not a point", field=option, allowed=allowed)
        try:
            numbers = [float(part) for part in m.groups() if part is not None]
        except ValueError:
            raise InputError(f"'{text}' is not numbers", field=option, allowed=allowed) from None
        if not all(math.isfinite(v) for v in numbers):
            raise InputError(f"'{text}' is not finite", field=option, allowed=allowed)
        return cls(numbers[0], numbers[1], numbers[2] if len(numbers) == 3 else None)

    @property
    def xy(self) -> np.ndarray:
        return np.array([self.x, self.y])


@dataclass(frozen=True)
class AgentPlacement:
    """Where the one agent of a map starts and where its goal is (`START_FORMS`, `GOAL_FORMS`)."""

    start: MapPoint
    goal: MapPoint
    start_text: str
    goal_text: str

    @classmethod
    def of_options(cls, start: str | None, goal: str | None) -> AgentPlacement | None:
        """The placement ``--start`` and ``--goal`` ask for (None when neither is given)."""
        if start is None and goal is None:
            return None
        if start is None or goal is None:
            missing = "--start" if start is None else "--goal"
            raise InputError(f"{'--goal' if start is None else '--start'} needs {missing} too", field=missing,
                             allowed=START_FORMS if start is None else GOAL_FORMS)
        begin = MapPoint.parse(start, "--start", START_FORMS)
        end = MapPoint.parse(goal, "--goal", GOAL_FORMS)
        if end.extra is not None and not 0.0 < end.extra <= MAX_GOAL_RADIUS_M:
            raise InputError(f"a goal radius of {end.extra:g} m", field="--goal",
                             allowed=f"a radius > 0 and <= {MAX_GOAL_RADIUS_M:g} m")
        return cls(begin, end, start.strip(), goal.strip())

    def parameters(self) -> dict[str, str]:
        """What the run records of it, beside the scenario's parameters."""
        return {"start": self.start_text, "goal": self.goal_text}

    def planning_problems(self, scenario: Scenario) -> PlanningProblemSet:
        """The agent's planning problem on ``scenario``'s lanelets (its id 1, or a free one of the
        scenario's when 1 is taken)."""
        network = scenario.lanelet_network
        heading = None if self.start.extra is None else math.radians(self.start.extra)
        begin = place_under(network, self.start.xy, "--start", START_FORMS, heading=heading)
        ahead = reachable(network, begin.lanelet.lanelet_id)
        end = place_under(network, self.goal.xy, "--goal", GOAL_FORMS, prefer=ahead)
        goal_id = end.lanelet.lanelet_id
        if goal_id not in ahead or (goal_id == begin.lanelet.lanelet_id and end.s <= begin.s):
            raise InputError(f"the goal (lanelet {goal_id}) is not ahead of the start (lanelet "
                             f"{begin.lanelet.lanelet_id}) along the lanes' links", field="--goal",
                             allowed="a point reached from the start by following the lanes' successors and lane "
                                     "changes the same way")
        disc = None if self.goal.extra is None else (self.goal.xy, self.goal.extra)
        free = 1 if not scenario._is_object_id_used(1) else scenario.generate_object_id()   # commonroad-io's own check
        problem = planning_problem(free, (begin.lanelet, begin.s), (end.lanelet, end.s),
                                   time_limit_s=TIME_LIMIT_S, dt=float(scenario.dt), heading=heading, goal_disc=disc)
        return PlanningProblemSet([problem])
