"""The scalars of one run that a search or a failure rule looks at, per agent and worst over
agents: how far each agent strayed from its lane's centre, whether its footprint left its lanes,
how far it drifted from its plans, and how much of the road's grip it used.

They are computed from the run alone (no other fidelity needed), in the route-centre Frenet
frame of `simgap.evaluate.route_centre`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim.history import AgentHistory, History
from simgap.evaluate.errors import FrenetTrackingErrors, frenet_tracking_errors, lateral_profile
from simgap.evaluate.route_centre import route_centre, route_lanelets
from simgap.evaluate.surface_grip import grip_use_on_surface
from simgap.scenario.road_frame import DrivableArea, PathFrame, footprint
from simgap.vehicles import Vehicle
from simgap.vehicles.constants import GRAVITY

#: name -> (unit, meaning); every one is the worst over the run's agents
RUN_METRICS = {
    "max_lateral_offset_m": ("m", "largest |d| of the driven path from its lane's centre line"),
    "max_lane_excursion_m": ("m", "how far the footprint reached beyond the lanes of its route (0: stayed in)"),
    "max_tracking_lateral_m": ("m", "largest lateral gap between the driven and the promised (planned) position"),
    "peak_grip_use": ("-", "peak of sqrt(a_long^2 + a_lat^2) / (road friction x g): above 1 asks more than the road gives"),
    "peak_grip_use_3d": ("-", "peak grip use on the road's relief: the friction force the motion needs (gravity's "
                              "share along the surface included) / (road friction x the normal load on the surface, "
                              "less on a crest); the flat world's run: what the flat plan asks of the real road"),
}


def lane_excursion(driven, vehicle: Vehicle, scenario: Scenario, problem) -> float:
    """How far [m] an agent's footprint reached beyond the lanes of its route (lane departure)."""
    lanes = route_lanelets(scenario.lanelet_network, problem)
    if not lanes:
        return float("nan")
    area = DrivableArea(scenario.lanelet_network, 0.0, lanes)
    return max((area.excursion(footprint(st, vehicle.length, vehicle.width)) for st in driven), default=0.0)


@dataclass(frozen=True)
class RouteMeasures:
    """What an agent's metrics and tracking measure in its route's frame, measured once: the
    frame (None: no route to its goal), the tracking errors in it (None without a route) and how
    far the footprint reached beyond the route's lanes (NaN without a route)."""

    frame: PathFrame | None
    tracking: FrenetTrackingErrors | None
    lane_excursion_m: float


def route_measures(agent: AgentHistory, scenario: Scenario, problem) -> RouteMeasures:
    frame = route_centre(scenario.lanelet_network, problem) if problem is not None else None
    if frame is None or not len(agent.driven):
        return RouteMeasures(frame, None, math.nan)
    return RouteMeasures(frame, frenet_tracking_errors(agent.driven, list(agent.plans), frame),
                         lane_excursion(agent.driven, agent.vehicle, scenario, problem))


def run_metrics(history: History, scenario: Scenario, problems: PlanningProblemSet, road_friction: float,
                relief=None, measured: Mapping[int, RouteMeasures] | None = None) -> dict[str, float]:
    """`RUN_METRICS` of ``history`` on a road of friction ``road_friction`` and surface ``relief`` (the
    scenario's surface, `simgap.scenario.ground.ground_of`; None: flat) (NaN where an agent has no
    route to its goal); ``measured``: each agent's `RouteMeasures` where already measured."""
    worst = {name: -math.inf for name in RUN_METRICS}
    grip = road_friction * GRAVITY
    for agent in history.agents:
        driven = agent.driven
        route = (measured or {}).get(agent.id) or \
            route_measures(agent, scenario, problems.planning_problem_dict.get(agent.id))
        values = {name: math.nan for name in RUN_METRICS}
        if route.frame is not None and len(driven):
            _, d = lateral_profile(driven, route.frame)
            values["max_lateral_offset_m"] = float(np.max(np.abs(d)))
            assert route.tracking is not None, "measured with the frame (route_measures)"
            lateral = route.tracking.lateral
            values["max_tracking_lateral_m"] = float(np.max(np.abs(lateral))) if len(lateral) else 0.0
            values["max_lane_excursion_m"] = route.lane_excursion_m
        if len(driven):
            combined = np.hypot(driven.a, driven.v * driven.yaw_rate)
            values["peak_grip_use"] = float(combined.max() / grip)
            values["peak_grip_use_3d"] = float(grip_use_on_surface(driven, relief, road_friction).max())
        for name, v in values.items():
            if not math.isnan(v):
                worst[name] = max(worst[name], v)
    return {name: (v if math.isfinite(v) else math.nan) for name, v in worst.items()}
