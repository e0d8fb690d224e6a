"""A closed-loop score in [0, 1] for each agent of a run, built like nuPlan's closed-loop score (CLS,
``closed_loop_nonreactive_agents_weighted_average``): the product of four multipliers times the
weighted mean of four terms, every threshold and weight a setting (`ScoreSettings`, defaults and
their sources there).

Multipliers (each 0, 0.5 or 1 — a run that breaks one scores 0):

- ``at_fault_collisions``: per kind of road user hit at fault (`simgap.evaluate.at_fault`),
  max(0, 1 - n / (tolerated + 1)); the loop ends an agent's run at its first collision;
- ``drivable_area``: 0 when the footprint reached beyond the drivable area by more than
  ``drivable_area_tolerance_m``, or the loop ended the run off road (`Outcome.OFF_ROAD`);
- ``driving_direction``: by the largest distance driven against the lane's direction within
  ``direction_horizon_s`` (1 below ``direction_compliance_m``, 0.5 below ``direction_violation_m``,
  else 0);
- ``making_progress``: 0 when the progress ratio (below) is under ``min_progress_ratio``.

Weighted terms:

- ``progress``: progress along the route's lane centre over the progress to the goal (nuPlan
  compares with an expert's progress; the planning problem's goal stands in for the expert: its
  position's nearest point along the route; 1 when the goal is reached; without a route on the
  lanelets, the distance closed towards the goal's position over its distance from the start, and
  1 when the goal has no position), max(progress, floor) / max(goal progress, floor), capped at 1,
  0 when it drove backwards (or away from the goal) further than the floor;
- ``time_to_collision``: 1 when the TTC (`simgap.evaluate.time_to_collision`) stays above
  ``min_time_to_collision_s`` at every step, else 0;
- ``speed_limit``: 1 - (time integral of the speed above the lanelet's limit) / (``overspeed_scale_m_s``
  x the run's duration), at least 0 (1 where lanelets carry no speed limit);
- ``comfort``: 1 when every comfort bound holds (`simgap.evaluate.ride_comfort`), else 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim.history import AgentHistory, History, Outcome
from simgap.evaluate.at_fault import Collision, CollisionType, at_fault, collision_type
from simgap.evaluate.closest_approach import closest_approaches
from simgap.evaluate.lane_occupancy import LaneOccupancy
from simgap.evaluate.ride_comfort import comfort_check
from simgap.evaluate.road_users import RoadUser, RoadUserKind, road_users
from simgap.evaluate.route_centre import route_centre
from simgap.evaluate.settings import ScoreSettings, ScoreWeights
from simgap.evaluate.time_to_collision import time_to_collision
from simgap.scenario.goal import Goal
from simgap.scenario.obstacles import RecordedObstacle
from simgap.scenario.road_frame import DrivableArea, footprint
from simgap.trajectory import Trajectory

#: component -> (role, meaning); the multipliers first, then the weighted terms
COMPONENTS = {
    "at_fault_collisions": ("multiplier", "no collision the agent is at fault for"),
    "drivable_area": ("multiplier", "the footprint stayed on the drivable area"),
    "driving_direction": ("multiplier", "no driving against the lane's direction"),
    "making_progress": ("multiplier", "made at least the least progress towards the goal"),
    "progress": ("weighted", "progress along the route over the progress to the goal"),
    "time_to_collision": ("weighted", "time to collision within bound at every step"),
    "speed_limit": ("weighted", "speed-limit compliance"),
    "comfort": ("weighted", "accelerations, jerks, yaw rate and yaw acceleration within bounds"),
}
MULTIPLIERS = tuple(k for k, (role, _) in COMPONENTS.items() if role == "multiplier")
WEIGHTED = tuple(k for k, (role, _) in COMPONENTS.items() if role == "weighted")


@dataclass(frozen=True)
class ClosedLoopScore:
    score: float
    components: dict[str, float]
    measures: dict[str, float | None]     # what the components were computed from


def combine(components: dict[str, float], weights: ScoreWeights) -> float:
    """The score of ``components``: the multipliers' product times the weighted mean of the rest."""
    w = {"progress": weights.progress, "time_to_collision": weights.time_to_collision,
         "speed_limit": weights.speed_limit, "comfort": weights.comfort}
    product = math.prod(components[k] for k in MULTIPLIERS)
    return product * sum(w[k] * components[k] for k in WEIGHTED) / sum(w.values())


# ------------------------------------------------------------------------------ the components
def collision_multiplier(collisions: list[Collision], settings: ScoreSettings) -> float:
    """nuPlan's product over kinds of max(0, 1 - at-fault collisions / (tolerated + 1))."""
    tolerated = {RoadUserKind.VEHICLE: settings.at_fault_collisions_vehicle,
                 RoadUserKind.VRU: settings.at_fault_collisions_vru,
                 RoadUserKind.OBJECT: settings.at_fault_collisions_object}
    return math.prod(max(0.0, 1.0 - sum(c.at_fault and c.kind == kind for c in collisions) / (n + 1))
                     for kind, n in tolerated.items())


def drivable_area_multiplier(outcome: Outcome, loop_excursion_m: float, offroad_tolerance_m: float,
                             settings: ScoreSettings) -> tuple[float, float]:
    """(the multiplier, how far [m] the footprint reached beyond the drivable area). The loop
    measures the excursion beyond its own ``offroad_tolerance`` and ends the run off road when there
    is one; the score's tolerance is nuPlan's."""
    beyond = loop_excursion_m + offroad_tolerance_m if loop_excursion_m > 0 else 0.0
    return float(outcome != Outcome.OFF_ROAD and beyond <= settings.drivable_area_tolerance_m), beyond


def direction_multiplier(worst_against_m: float, settings: ScoreSettings) -> float:
    if worst_against_m < settings.direction_compliance_m:
        return 1.0
    return 0.5 if worst_against_m < settings.direction_violation_m else 0.0


def worst_wrong_way(progress: np.ndarray, dt: float, horizon_s: float) -> float:
    """The largest distance [m] driven against the lanes' direction within any window of
    ``horizon_s`` (nuPlan sums the per-step progress over the window ending at each step)."""
    n = int(horizon_s / dt + 1e-9)
    cumulative = np.concatenate([[0.0], np.cumsum(progress)])
    ends = np.arange(1, len(progress) + 1)
    sums = cumulative[ends] - cumulative[np.maximum(0, ends - 1 - n)]
    return float(max(0.0, -sums.min())) if len(sums) else 0.0


def progress_ratio(progress_m: float, goal_progress_m: float, floor_m: float) -> float:
    if progress_m < -floor_m:
        return 0.0
    return min(1.0, max(progress_m, floor_m) / max(goal_progress_m, floor_m))


def speed_limit_compliance(t: np.ndarray, v: np.ndarray, limits: np.ndarray, scale_m_s: float) -> tuple[float, float]:
    """(the score, the largest overspeed [m/s]) of speeds ``v`` under ``limits`` (NaN: none)."""
    over = np.where(np.isfinite(limits), np.maximum(v - np.nan_to_num(limits, nan=np.inf), 0.0), 0.0)
    duration = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    if not over.any() or duration <= 0:
        return 1.0, float(over.max(initial=0.0))
    dt = duration / (len(t) - 1)
    return max(0.0, 1.0 - float(over.sum()) * dt / (scale_m_s * duration)), float(over.max())


def _goal_progress(problem: PlanningProblem, frame, s_start: float) -> float:
    """Arc length from the start to where the route first enters the goal's position (the route's
    end when the goal has no position)."""
    points = []
    for state in problem.goal.state_list:
        if state.has_value("position"):
            shapes = getattr(state.position, "shapes", [state.position])
            for shape in shapes:
                outline = shape.shapely_object
                points.append(np.asarray(outline.exterior.coords if hasattr(outline, "exterior") else outline.coords))
    if not points:
        return frame.length - s_start
    s, _ = frame.project(np.vstack(points))
    return float(s.min()) - s_start


# ------------------------------------------------------------------------------ one agent
class _AgentScorer:
    """Everything one agent's score needs: its run, the road, the others, the settings."""

    def __init__(self, history: History, agent: AgentHistory, road_excursion_m: float, problem: PlanningProblem | None,
                 lanes: LaneOccupancy, users: dict[int, RoadUser], settings: ScoreSettings, offroad_tolerance_m: float):
        self.history, self.agent, self.problem, self.lanes = history, agent, problem, lanes
        self.road_excursion_m = road_excursion_m
        self.users, self.settings, self.offroad_tolerance_m = users, settings, offroad_tolerance_m
        self.driven: Trajectory = agent.driven
        self.vehicle = agent.vehicle
        self.measures: dict[str, float | None] = {}

    def score(self) -> ClosedLoopScore:
        collisions = self._collisions()
        lane_ids = self.lanes.lane_of_each_step(self.driven)
        ratio = self._progress_ratio()
        components = {
            "at_fault_collisions": collision_multiplier(collisions, self.settings),
            "drivable_area": self._drivable_area(),
            "driving_direction": self._driving_direction(lane_ids),
            "making_progress": float(ratio >= self.settings.min_progress_ratio),
            "progress": ratio,
            "time_to_collision": self._time_to_collision(collisions),
            "speed_limit": self._speed_limit(lane_ids),
            "comfort": self._comfort(),
        }
        return ClosedLoopScore(combine(components, self.settings.weights), components, self.measures)

    def _collisions(self) -> list[Collision]:
        """The agent's collision (the loop ends its run at the first), classified."""
        event = next((e for e in self.history.events if e.agent_id == self.agent.id and e.kind == Outcome.COLLISION),
                     None)
        if event is None:
            self.measures["collision"] = None
            return []
        ego = self.driven[len(self.driven) - 1]
        other = None if event.other_id is None else self.users.get(event.other_id)
        if other is None:          # a contact the physics reported with something unknown: the ego's fault
            self.measures["collision"] = None
            return [Collision(-1 if event.other_id is None else event.other_id, RoadUserKind.VEHICLE,
                              CollisionType.ACTIVE_FRONT, True)]
        at = other.at(np.array([ego.t]))
        other_state = ego.replace(x=float(at.x[0]), y=float(at.y[0]), yaw=float(at.yaw[0]), v=float(at.v[0]))
        kind = collision_type(ego, self.vehicle.length, self.vehicle.width, self.vehicle.rear_axle_to_center,
                              other_state, other.length, other.width, self.settings.stopped_speed_m_s,
                              self.settings.behind_angle_deg)
        corners = np.asarray(footprint(ego, self.vehicle.length, self.vehicle.width).exterior.coords)[:4]
        collision = Collision(other.id, other.kind, kind, at_fault(kind, self.lanes.straddles_lanes(corners)))
        self.measures["collision"] = float(collision.at_fault)
        self.measures["collision_other"] = float(other.id)
        self.measures[f"collision_{kind.value}"] = 1.0
        return [collision]

    def _drivable_area(self) -> float:
        value, beyond = drivable_area_multiplier(self.agent.outcome, self.road_excursion_m,
                                                 self.offroad_tolerance_m, self.settings)
        self.measures["max_road_excursion_m"] = beyond
        return value

    def _driving_direction(self, lane_ids: np.ndarray) -> float:
        progress = self.lanes.progress_along_lanes(self.driven, lane_ids)
        worst = worst_wrong_way(progress, self.history.dt, self.settings.direction_horizon_s)
        self.measures["max_wrong_way_m"] = worst
        return direction_multiplier(worst, self.settings)

    def _progress_ratio(self) -> float:
        measured = None if self.agent.outcome == Outcome.GOAL_REACHED else self._progress()
        if measured is None:
            self.measures["progress_ratio"] = 1.0
            return 1.0
        progress, goal = measured
        ratio = progress_ratio(progress, goal, self.settings.progress_floor_m)
        self.measures |= {"progress_m": progress, "goal_progress_m": goal, "progress_ratio": ratio}
        return ratio

    def _progress(self) -> tuple[float, float] | None:
        """(progress made, progress to the goal) [m]: along the route's lane centre; without a route
        on the lanelets (the agent's planner may still drive), the distance closed towards the goal's
        position and its distance from the start; None when neither can be measured."""
        if self.problem is None:
            return None
        first, last = self.driven[0], self.driven[len(self.driven) - 1]
        frame = route_centre(self.lanes.network, self.problem)
        if frame is not None:
            s, _ = frame.project(np.array([[first.x, first.y], [last.x, last.y]]))
            return float(s[1] - s[0]), _goal_progress(self.problem, frame, float(s[0]))
        goal = Goal.of(self.problem.goal, self.history.dt)
        away, left = goal.distance_from_position(first.x, first.y), goal.distance_from_position(last.x, last.y)
        if away is None or left is None:        # both or neither: no goal state bounds the position
            return None
        return away - left, away

    def _time_to_collision(self, collisions: list[Collision]) -> float:
        st = self.settings
        others = [u for uid, u in self.users.items() if uid != self.agent.id]
        collided = {c.other_id for c in collisions}
        vehicle, driven = self.vehicle, self.driven

        def exposed(k: int) -> bool:
            state = driven[k]
            corners = np.asarray(footprint(state, vehicle.length, vehicle.width).exterior.coords)[:4]
            lane = self.lanes.lanelets_at(np.array([[state.x, state.y]]))[0]
            return self.lanes.straddles_lanes(corners) or bool(set(lane) & self.lanes.junction_lanelets)

        def ttc(traj: Trajectory, users: list[RoadUser]) -> np.ndarray:
            return time_to_collision(traj, vehicle.length, vehicle.width, vehicle.rear_axle_to_center, users,
                                     st.ttc_horizon_s, st.ttc_step_s, st.ahead_angle_deg, st.behind_angle_deg,
                                     st.ttc_stopped_speed_m_s, exposed)

        values = ttc(driven, others)
        if collisions:           # the step of the collision: 0 if at fault, else without the road user hit
            last = len(driven) - 1
            if any(c.at_fault for c in collisions):
                values[last] = 0.0
            else:
                values[last] = ttc(Trajectory.from_states([driven[last]], driven.dt),
                                   [u for u in others if u.id not in collided])[0]
        least = float(values.min()) if len(values) else math.inf
        self.measures["min_time_to_collision_s"] = least if math.isfinite(least) else None
        return float(bool(np.all(values > st.min_time_to_collision_s)))

    def _speed_limit(self, lane_ids: np.ndarray) -> float:
        limits = self.lanes.speed_limits(lane_ids)
        value, worst = speed_limit_compliance(self.driven.t, self.driven.v, limits, self.settings.overspeed_scale_m_s)
        self.measures["max_overspeed_m_s"] = worst
        return value

    def _comfort(self) -> float:
        within, peaks = comfort_check(self.driven, self.settings.comfort)
        self.measures |= peaks
        self.measures |= {f"{name}_within": float(ok) for name, ok in within.items()}
        return float(all(within.values()))


def closed_loop_scores(history: History, scenario: Scenario, problems: PlanningProblemSet, settings: ScoreSettings,
                       offroad_tolerance_m: float,
                       road_excursions_m: Mapping[int, float] | None = None, road: DrivableArea | None = None,
                       obstacles: Sequence[RecordedObstacle] | None = None) -> dict[int, ClosedLoopScore]:
    """Every agent's closed-loop score (none for an agent that drove no step: its run failed
    before), given the loop's road tolerance (``offroad_tolerance_m``, the excursions are measured
    beyond it) and each agent's largest road excursion (`simgap.evaluate.closest_approach`;
    measured here when not given, on ``road``: the drivable area widened by the tolerance); ``road``
    and ``obstacles`` (the scenario's `recorded_obstacles`) when the caller has them."""
    if road_excursions_m is None:
        road_excursions_m = {aid: round(a.max_road_excursion_m, 3)      # to the mm, as a run's evaluation keeps it
                             for aid, a in closest_approaches(history, scenario, offroad_tolerance_m, road,
                                                              obstacles).items()}
    lanes = LaneOccupancy(scenario.lanelet_network)
    users = road_users(history, scenario, obstacles)
    return {a.id: _AgentScorer(history, a, road_excursions_m[a.id], problems.planning_problem_dict.get(a.id), lanes,
                               users, settings, offroad_tolerance_m).score()
            for a in history.agents if len(a.driven) > 1}
