"""A scenario on an OpenDRIVE road: one agent from a start to a goal, each given as a place on a
lane (``ROAD:LANE:S``: road id, lane id, station along the road's reference line) or as a point
(``X,Y``: the driving lane under it). The goal is a 10 m x lane-width rectangle centred there,
along the lane, to be reached within the time limit; it must lie ahead of the start along the
lanes' links (successors and lane changes the same way).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
from commonroad.planning.planning_problem import PlanningProblemSet
from pydantic import BaseModel, ConfigDict, Field

from simgap.errors import InputError, validated
from simgap.scenario.lane_places import LanePlace, on_lanelet, place_under, reachable
from simgap.scenario.opendrive.lanes import lane_centre
from simgap.scenario.opendrive.network import OpenDriveNetwork, opendrive_network
from simgap.scenario.physical_bounds import MAX_TIME_STEP_S, MIN_TIME_STEP_S
from simgap.scenario.problem import planning_problem
from simgap.scenario.templates import ConcreteScenario, scenario_of
from simgap.trajectory import DEFAULT_TIME_STEP_S
from simgap.vehicles.constants import MAX_SPEED

PLACE_FORMS = "ROAD:LANE:S (road id, lane id, station along the road [m]) or X,Y (a point on a driving lane)"
_PLACE = re.compile(r"^(?P<road>[^:]+):(?P<lane>-?\d+):(?P<s>[-+0-9.eE]+)$")
_POINT = re.compile(r"^(?P<x>[-+0-9.eE]+),(?P<y>[-+0-9.eE]+)$")


class ProblemSettings(BaseModel):
    """What ``--set`` may pin for a scenario on an OpenDRIVE road."""

    model_config = ConfigDict(extra="forbid")
    initial_speed: float = Field(0.0, ge=0.0, le=MAX_SPEED, description="speed at the start [m/s]")
    time_limit: float = Field(60.0, gt=0.0, le=600.0, description="time to reach the goal [s] (no run simulates "
                                                                   "longer: cosim's MAX_SIMULATED_TIME_S)")
    dt: float = Field(DEFAULT_TIME_STEP_S, ge=MIN_TIME_STEP_S, le=MAX_TIME_STEP_S, description="time step [s]")


UNITS = {"initial_speed": "m/s", "time_limit": "s", "dt": "s"}


def _number(text: str, option: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise InputError(f"'{text}' is not a number", field=option, allowed=PLACE_FORMS) from None


def _by_lane(roads: OpenDriveNetwork, road_id: str, lane_id: int, station: float, option: str) -> LanePlace:
    road = roads.document.roads.get(road_id)
    places = roads.origin.lanelets
    with_lanelets = sorted({p.road for p in places.values()}, key=lambda r: (len(r), r))
    if road is None or road_id not in with_lanelets:
        raise InputError(f"road '{road_id}' has no driving lane", field=option,
                         allowed="roads " + ", ".join(with_lanelets[:20]) + (" ..." if len(with_lanelets) > 20 else ""))
    lanes = sorted({p.lane for p in places.values() if p.road == road_id})
    if lane_id not in lanes:
        raise InputError(f"lane {lane_id} of road {road_id} is no driving lane", field=option,
                         allowed=f"lanes {', '.join(map(str, lanes))} of road {road_id}")
    found = [(lid, p) for lid, p in places.items() if p.road == road_id and p.lane == lane_id
             and p.s_start - 1e-9 <= station <= p.s_end + 1e-9]
    if not found:
        spans = sorted((p.s_start, p.s_end) for p in places.values() if p.road == road_id and p.lane == lane_id)
        raise InputError(f"station {station:g} m is not on lane {lane_id} of road {road_id}", field=option,
                         allowed=", ".join(f"{a:.1f} to {b:.1f} m" for a, b in _merged(spans)))
    lanelet_id, place = found[0]
    point = lane_centre(road, place.section, lane_id, station)
    return on_lanelet(roads.lanelets.find_lanelet_by_id(lanelet_id), point)


def _merged(spans: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b in spans:
        if out and a <= out[-1][1] + 1e-6:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def lane_place(roads: OpenDriveNetwork, text: str, option: str, prefer: set[int] | None = None) -> LanePlace:
    """The place ``text`` names (see `PLACE_FORMS`)."""
    text = text.strip()
    if (m := _PLACE.match(text)) is not None:
        return _by_lane(roads, m["road"], int(m["lane"]), _number(m["s"], option), option)
    if (m := _POINT.match(text)) is not None:
        return place_under(roads.lanelets, np.array([_number(m["x"], option), _number(m["y"], option)]), option,
                           PLACE_FORMS, prefer)
    raise InputError(f"'{text}' names no place", field=option, allowed=PLACE_FORMS)


def opendrive_scenario(path: str | Path, start: str, goal: str, pins: dict[str, str] | None = None,
                       roads: OpenDriveNetwork | None = None, name: str | None = None,
                       logical: str = "opendrive") -> ConcreteScenario:
    """One agent from ``start`` to ``goal`` on the OpenDRIVE road at ``path`` (``pins``: NAME=VALUE
    settings of `ProblemSettings`; ``roads``: the file already read; ``name`` and ``logical``: what
    the scenario is called and its logical scenario, by default the file's stem and ``opendrive``)."""
    path = Path(path)
    settings = validated(ProblemSettings, pins or {}, prefix="--set")
    roads = roads or opendrive_network(path)
    begin = lane_place(roads, start, "--start")
    ahead = reachable(roads.lanelets, begin.lanelet.lanelet_id)
    end = lane_place(roads, goal, "--goal", prefer=ahead)
    goal_id = end.lanelet.lanelet_id
    if goal_id not in ahead or (goal_id == begin.lanelet.lanelet_id and end.s <= begin.s):
        dropped = sum(d.count for d in roads.dropped)
        why = f" ({dropped} of the file's links lead nowhere and were dropped: " + \
            "; ".join(d.describe() for d in roads.dropped) + ")" if dropped else ""
        raise InputError(f"the goal (lanelet {goal_id}, road {roads.origin.lanelets[goal_id].road} lane "
                         f"{roads.origin.lanelets[goal_id].lane}) is not ahead of the start along the lanes' "
                         f"links{why}",
                         field="--goal", allowed="a place reached from the start by following the lanes' "
                                                 "successors and lane changes the same way")
    problem = planning_problem(1, (begin.lanelet, begin.s), (end.lanelet, end.s),
                               initial_speed=settings.initial_speed, time_limit_s=settings.time_limit, dt=settings.dt)
    name = name or re.sub(r"[^A-Za-z0-9_-]+", "_", path.stem).strip("_") or "opendrive"
    parameters = {"source": path.name, "start": start, "goal": goal, **settings.model_dump()}
    return ConcreteScenario(name, logical, parameters, scenario_of(name, settings.dt, roads.lanelets),
                            PlanningProblemSet([problem]), roads.sections, dict(UNITS), opendrive=roads.origin,
                            warnings=tuple(f"{path}: {d.describe()}" for d in roads.dropped))


def opendrive_template(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    """The logical scenarios' template ``opendrive``: one agent on the road of ``file`` (a path the
    logical scenario resolved beside its YAML) from ``start`` to ``goal`` (`PLACE_FORMS`), with the
    `ProblemSettings` among the parameters; the scenario is named ``name``."""
    missing = [key for key in ("file", "start", "goal") if not p.get(key)]
    if missing:
        raise InputError(f"the opendrive template needs '{missing[0]}'", field=f"fixed.{missing[0]}",
                         allowed="fixed: {file: ROAD.xodr (beside the YAML), start: PLACE, goal: PLACE}; "
                                 f"a place is {PLACE_FORMS}")
    path = Path(p["file"])
    if not path.is_file():
        raise InputError(f"no OpenDRIVE file {path}", field="fixed.file", allowed="an .xodr file (a path "
                                                                                 "relative to the YAML)")
    pins = {key: str(p[key]) for key in UNITS if key in p}
    concrete = opendrive_scenario(path, str(p["start"]), str(p["goal"]), pins, name=name, logical=logical)
    concrete.parameters = {key: value for key, value in p.items() if key != "file"} | {"source": path.name}
    return concrete
