"""Scenario templates: functions from a complete parameter set to a concrete CommonRoad scenario.

A logical scenario (see `logical`) names one of these templates and spans a space over its
parameters. Templates validate what only they can judge (a radius too small for the road, a
road that crosses itself, a road or junction approach longer than `MAX_ROAD_LENGTH_M`, 20 km) and
raise `InputError` naming the parameter.

A road (``curve``, ``s-curve``, ``road``) may have a relief (`simgap.scenario.relief`), from these
parameters: ``grade`` [%] from its start; ``grade_change`` [%] at one vertical curve of
``vertical_radius`` [m] (a crest where the grade falls, a sag where it rises) whose vertex lies
``vertical_curve_shift`` [m] after the road's middle; ``bank`` [deg] on every curve, positive into
the turn (its outside raised), negative against it (an adverse camber), built up over the curve's
clothoids or, without, over ``bank_transition`` [m] of the road before and after it. All zero: a
flat road, with no relief at all.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import yaml
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.scenario import Scenario, ScenarioID
from pydantic import TypeAdapter, ValidationError

from simgap.errors import InputError, validation_error
from simgap.scenario.blueprint import JunctionBlueprint, RoadBlueprint
from simgap.scenario.geometry import (
    MAX_ROAD_LENGTH_M,
    Arc,
    SectionKind,
    Segment,
    Straight,
    centre_line,
    curvature_pieces,
    self_intersects,
)
from simgap.scenario.opendrive.origin import OpenDriveOrigin
from simgap.scenario.physical_bounds import MIN_LANE_WIDTH
from simgap.scenario.problem import planning_problem
from simgap.scenario.relief import (
    MAX_BANK_DEG,
    MAX_GRADE_PERCENT,
    BankKnot,
    ElevationProfile,
    ReliefProfile,
    VerticalCurve,
)
from simgap.scenario.road import LaneLayout, build_road
from simgap.scenario.sections import RoadSections
from simgap.scenario.sidecar import ScenarioSidecar
from simgap.trajectory import DEFAULT_TIME_STEP_S

LANELET_ID_START = 100  # planning problems (agents) take ids 1, 2, 3, ...
VERTICAL_RADIUS_M = 500.0       # a vertical curve's radius unless told
BANK_TRANSITION_M = 20.0        # length of a bank's run-in and run-out on the straights unless told
VERTICAL_CURVE_FIELDS = "grade, grade_change, vertical_radius, vertical_curve_shift"


@dataclass
class ConcreteScenario:
    """A scenario built from a logical one: CommonRoad objects plus where they came from."""

    name: str
    logical: str
    parameters: dict[str, Any]
    scenario: Scenario
    problems: PlanningProblemSet
    sections: RoadSections = field(default_factory=RoadSections)   # lanelet id -> straight|curve|clothoid|junction
    units: dict[str, str] = field(default_factory=dict)      # parameter -> unit (of the logical scenario)
    blueprint: RoadBlueprint | JunctionBlueprint | None = None   # what the road network was built from
    opendrive: OpenDriveOrigin | None = None     # the OpenDRIVE file its lanelets were read from, and its relief
    warnings: tuple[str, ...] = ()     # what building it dropped from its source, one line each (not in the sidecar)

    @property
    def sidecar(self) -> ScenarioSidecar:
        """What its sidecar file keeps (`simgap.scenario.files.write_scenario`)."""
        return ScenarioSidecar(self.name, self.logical, self.parameters, self.units, self.sections, self.blueprint,
                               self.opendrive)


def scenario_of(name: str, dt: float, network: LaneletNetwork) -> Scenario:
    """A CommonRoad scenario named after ``name`` (its map name and a map id from it) holding ``network``."""
    map_name = re.sub(r"[^A-Za-z0-9]", "", name.title())[:60] or "Simgap"
    map_id = int(hashlib.sha1(name.encode()).hexdigest(), 16) % 9999 + 1
    scenario = Scenario(dt, scenario_id=ScenarioID(country_id="ZAM", map_name=map_name, map_id=map_id))
    scenario.add_objects(network)
    return scenario


def _layout(p: dict[str, Any]) -> LaneLayout:
    lanes = int(p.get("lanes", 1))
    if not 1 <= lanes <= 3:
        raise InputError(f"{lanes} lanes per direction", field="lanes", allowed="1, 2 or 3")
    return LaneLayout(lanes_per_direction=lanes, lane_width=_lane_width(p),
                      two_way=bool(p.get("two_way", True)),
                      centre_marking=str(p.get("centre_marking", "solid")))


def _lane_width(p: dict[str, Any]) -> float:
    width = p.get("lane_width", 3.0)
    if not (isinstance(width, (int, float)) and MIN_LANE_WIDTH <= width < math.inf):
        raise InputError(f"lane width {width!r}", field="lane_width", allowed=f"a number of m >= {MIN_LANE_WIDTH:g}")
    return float(width)


def _check_radii(segments: list[Segment], layout: LaneLayout) -> None:
    for i, seg in enumerate(segments):
        if isinstance(seg, Arc) and seg.angle != 0:
            inner = layout.half_width_left if seg.angle > 0 else layout.half_width_right
            if seg.radius <= inner + 1.0:
                raise InputError(
                    f"arc radius {seg.radius:g} m is too small for a road reaching {inner:g} m "
                    f"to the inside of the curve", field=f"segments[{i}].radius" if len(segments) > 3 else "radius",
                    allowed=f"> {inner + 1.0:g} m (inner half-width + 1 m)")


def _road_relief(p: dict[str, Any], segments: list[Segment]) -> ReliefProfile | None:
    """The relief the road parameters ask for (see the module doc); None when they leave it flat."""
    pieces = curvature_pieces(segments)
    grade, change = float(p.get("grade", 0.0)), float(p.get("grade_change", 0.0))
    bank, transition = float(p.get("bank", 0.0)), float(p.get("bank_transition", BANK_TRANSITION_M))
    if abs(bank) > MAX_BANK_DEG:
        raise InputError(f"bank {bank:g} deg", field="bank", allowed=f"within ±{MAX_BANK_DEG:g} deg")
    if bank and not transition > 0.0:
        raise InputError(f"bank transition {transition:g} m", field="bank_transition", allowed="> 0 m")
    vertex = sum(length for _, length, _, _ in pieces) / 2 + float(p.get("vertical_curve_shift", 0.0))
    try:
        changes = (VerticalCurve(s=vertex, grade=grade + change,
                                 radius=float(p.get("vertical_radius", VERTICAL_RADIUS_M))),) if change else ()
        profile = ReliefProfile(elevation=ElevationProfile(grade=grade, changes=changes),
                                superelevation=_banked_curves(pieces, bank, transition) if bank else ())
    except ValidationError as err:
        raise InputError(err.errors()[0]["msg"].removeprefix("Value error, "), field=VERTICAL_CURVE_FIELDS,
                         allowed=f"grades within ±{MAX_GRADE_PERCENT:g} %, a positive radius, and a vertical curve "
                                 "(vertical_radius x |grade_change| long) that begins on the road") from None
    return None if profile.flat else profile


def _banked_curves(pieces: list[tuple[SectionKind, float, float, float]], bank: float, transition: float) -> tuple[BankKnot, ...]:
    """Superelevation knots: ``bank`` on every arc, falling towards its inside (OpenDRIVE's sign: a
    left turn's road falls to the left, negative), none on the straights, linear in between — over
    the clothoids, or over ``transition`` of the straight next to an arc (less on a straight shorter
    than that), or, between two arcs that touch, over ``transition`` centred on the joint."""
    kinds = [kind for kind, _, _, _ in pieces]
    knots: list[BankKnot] = []
    s = 0.0
    for i, (kind, length, k0, _) in enumerate(pieces):
        start, end = s, s + length
        s = end
        if kind == "clothoid":
            continue
        before = i > 0 and kinds[i - 1] == "curve"
        after = i + 1 < len(kinds) and kinds[i + 1] == "curve"
        share = 0.5 if kind == "curve" else 1.0      # an arc gives half a transition to a touching arc
        value = -bank * math.copysign(1.0, k0) if kind == "curve" else 0.0   # a negative bank: against the turn
        start += share * transition if before else 0.0
        end -= share * transition if after else 0.0
        for at in (start, end):
            if end >= start and (not knots or at > knots[-1].s):
                knots.append(BankKnot(s=at, bank=value))
    return tuple(knots)


def road_scenario(name: str, logical: str, params: dict[str, Any], segments: list[Segment],
                  length_fields: str = "segments") -> ConcreteScenario:
    """A single road from ``segments``; one agent from 10 m in to 10 m before the end. A road longer
    than `MAX_ROAD_LENGTH_M` is refused naming ``length_fields``, the parameters its length is made of."""
    layout = _layout(params)
    _check_radii(segments, layout)
    length = sum(piece_length for _, piece_length, _, _ in curvature_pieces(segments))
    if length > MAX_ROAD_LENGTH_M:
        raise InputError(f"the road would be {length:.4g} m long", field=length_fields,
                         allowed=f"roads up to {MAX_ROAD_LENGTH_M:g} m")
    centre = centre_line(segments)
    if self_intersects(centre.xy) or any(
            self_intersects(centre.offset(d)) for d in (-layout.half_width_right, layout.half_width_left) if d):
        raise InputError("the road crosses itself", field="segments",
                         allowed="segment lists whose road does not overlap itself")
    road = build_road(centre, layout, LANELET_ID_START)
    dt = float(params.get("dt", DEFAULT_TIME_STEP_S))
    network = LaneletNetwork.create_from_lanelet_list(road.lanelets)
    scenario = scenario_of(name, dt, network)
    lane = road.forward[layout.lanes_per_direction - 1]       # the rightmost lane
    start_s = float(params.get("start_offset", 10.0))
    goal_before_end = float(params.get("goal_offset", 10.0))
    if start_s >= lane[0].distance[-1]:
        raise InputError(f"start offset {start_s} m lies beyond the first section", field="start_offset",
                         allowed=f"< {lane[0].distance[-1]:.0f} m")
    problem = planning_problem(
        1, (lane[0], start_s), (lane[-1], float(lane[-1].distance[-1]) - goal_before_end),
        initial_speed=float(params.get("initial_speed", 0.0)), dt=dt,
        time_limit_s=float(params.get("time_limit", 60.0)))
    blueprint = RoadBlueprint(segments=list(segments), lanes_per_direction=layout.lanes_per_direction,
                              lane_width=layout.lane_width, two_way=layout.two_way,
                              centre_marking=layout.centre_marking, first_id=LANELET_ID_START,
                              relief=_road_relief(params, segments))
    return ConcreteScenario(name, logical, params, scenario, PlanningProblemSet([problem]),
                            RoadSections(road.section_by_id), blueprint=blueprint)


CURVE_LENGTH_FIELDS = "straight_length, radius, angle, transition"


def curve(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    """The paper's: straight, a turn of ``radius`` and ``angle`` (positive = left), straight."""
    segments: list[Segment] = [Straight(length=p.get("straight_length", 100.0)),
                Arc(radius=p["radius"], angle=p["angle"], transition=p.get("transition", 0.0)),
                Straight(length=p.get("straight_length", 100.0))]
    return road_scenario(name, logical, p, segments, CURVE_LENGTH_FIELDS)


def s_curve(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    """Straight, a turn, the opposite turn, straight."""
    segments: list[Segment] = [Straight(length=p.get("straight_length", 50.0)),
                Arc(radius=p["radius"], angle=p["angle"], transition=p.get("transition", 0.0)),
                Arc(radius=p["radius"], angle=-p["angle"], transition=p.get("transition", 0.0)),
                Straight(length=p.get("straight_length", 50.0))]
    return road_scenario(name, logical, p, segments, CURVE_LENGTH_FIELDS)


def hairpins(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    """A mountain road: ``hairpins`` turns of 180 degrees and ``hairpin_radius``, alternately left
    and right, joined by straight legs of ``leg_length`` (and such a leg before the first and after
    the last), so the road zig-zags up a slope."""
    count = int(p.get("hairpins", 2))
    leg = Straight(length=p.get("leg_length", 60.0))
    segments: list[Segment] = [leg]
    for k in range(count):
        segments += [Arc(radius=p["hairpin_radius"], angle=180.0 if k % 2 == 0 else -180.0,
                         transition=p.get("transition", 0.0)), leg]
    return road_scenario(name, logical, p, segments, "leg_length, hairpins, hairpin_radius, transition")


_SEGMENTS = TypeAdapter(list[Straight | Arc])


def road(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    """Any road: ``segments`` is a list of {kind: straight, length} / {kind: arc, radius, angle}."""
    try:
        segments = _SEGMENTS.validate_python(p.get("segments") or [])
    except ValidationError as err:
        raise validation_error(err, prefix="segments",
                               allowed="{kind: straight, length} or {kind: arc, radius, angle[, transition]}") from None
    if not segments:
        raise InputError("no segments", field="segments", allowed="a non-empty list")
    return road_scenario(name, logical, p, segments)


# Routes through junctions, by arm index (arms listed in `arm_angles`): (from, to), in agent order.
T_JUNCTION_ARMS = [180.0, 0.0, 270.0]            # west, east, south (the stem)
T_JUNCTION_ROUTES = [(0, 1), (2, 0), (1, 2)]     # straight W→E, left S→W, left E→S: all cross agent 1
INTERSECTION_ARMS = [180.0, 270.0, 0.0, 90.0]    # west, south, east, north
INTERSECTION_ROUTES = [(0, 2), (1, 3), (2, 1), (3, 2)]  # W→E, S→N, left E→S, left N→E


def builtin_defaults(template: str) -> dict[str, Any]:
    """The defaults of ``template``, written once, in the built-in logical scenario of the same name
    (``scenario/builtin/<template>.yaml``): its fixed settings and each parameter's default."""
    text = (resources.files("simgap.scenario") / "builtin" / f"{template}.yaml").read_text()
    data = yaml.safe_load(text)
    return {n: par["default"] for n, par in data["parameters"].items()} | dict(data.get("fixed") or {})


def _junction_scenario(name: str, logical: str, p: dict[str, Any], template: str, arms: list[float],
                       routes: list[tuple[int, int]], max_agents: int) -> ConcreteScenario:
    """The junction of ``arms`` with an agent on each of the first ``agents`` ``routes``; what ``p``
    leaves out is ``template``'s `builtin_defaults`."""
    p = p | {k: v for k, v in builtin_defaults(template).items() if k not in p}
    agents = int(p["agents"])
    if not 2 <= agents <= max_agents:
        raise InputError(f"{agents} agents", field="agents", allowed=f"2 to {max_agents}")
    approach = float(p["approach_length"])
    blueprint = JunctionBlueprint(arm_angles=arms, approach_length=approach, lane_width=_lane_width(p),
                                  centre_marking=str(p.get("centre_marking", "solid")), first_id=LANELET_ID_START)
    junction = blueprint.rebuild()
    dt = float(p.get("dt", DEFAULT_TIME_STEP_S))
    scenario = scenario_of(name, dt, LaneletNetwork.create_from_lanelet_list(junction.lanelets))
    network = scenario.lanelet_network
    stagger = float(p["stagger"])
    problems = []
    for k, (src, dst) in enumerate(routes[:agents]):
        start = network.find_lanelet_by_id(junction.arms[src].incoming)
        goal = network.find_lanelet_by_id(junction.arms[dst].outgoing)
        to_junction = float(p["start_distance"]) + k * stagger
        if to_junction > approach:
            raise InputError(f"agent {k + 1} would start {to_junction:g} m before the junction, "
                             f"beyond the {approach:g} m approach", field="start_distance",
                             allowed="start_distance + (agents - 1) * stagger <= approach_length")
        problems.append(planning_problem(
            k + 1, (start, approach - to_junction),
            (goal, float(goal.distance[-1]) - 10.0),
            initial_speed=float(p["initial_speed"]), dt=dt,
            time_limit_s=float(p["time_limit"])))
    return ConcreteScenario(name, logical, p, scenario, PlanningProblemSet(problems), RoadSections(junction.section_by_id),
                            blueprint=blueprint)


def t_junction(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    return _junction_scenario(name, logical, p, "t-junction", T_JUNCTION_ARMS, T_JUNCTION_ROUTES, 3)


def intersection(name: str, logical: str, p: dict[str, Any]) -> ConcreteScenario:
    return _junction_scenario(name, logical, p, "intersection", INTERSECTION_ARMS, INTERSECTION_ROUTES, 4)


TEMPLATES: dict[str, Callable[[str, str, dict[str, Any]], ConcreteScenario]] = {
    "curve": curve, "s-curve": s_curve, "road": road, "hairpins": hairpins, "t-junction": t_junction,
    "intersection": intersection,
}
#: the templates that build one road along a centre line (a `RoadBlueprint`): the reference line a
#: tilt of the road lies along (`simgap.scenario.relief.RoadTilt`)
ONE_ROAD = frozenset({"curve", "s-curve", "road", "hairpins"})

# What the templates read from a logical scenario: the names each cannot do without (the others
# have defaults), and the kind of value each name must hold in ``fixed`` (a name means the same in
# every template; ``parameters`` always hold numbers)
REQUIRED: dict[str, tuple[str, ...]] = {"curve": ("radius", "angle"), "s-curve": ("radius", "angle"),
                                        "hairpins": ("hairpin_radius",), "road": ("segments",), "t-junction": (),
                                        "intersection": (), "opendrive": ("file", "start", "goal")}
_NUMBERS = ("radius", "angle", "transition", "straight_length", "leg_length", "hairpin_radius", "lane_width",
            "grade", "grade_change", "vertical_radius", "vertical_curve_shift", "bank", "bank_transition", "dt",
            "start_offset", "goal_offset", "initial_speed", "time_limit", "approach_length", "stagger",
            "start_distance")
KINDS: dict[str, str] = {name: "a finite number" for name in _NUMBERS} | {
    "lanes": "a whole number", "hairpins": "a whole number", "agents": "a whole number", "two_way": "true or false",
    "centre_marking": "text", "file": "text", "start": "text (quoted: a place such as \"2:-1:30\")",
    "goal": "text (quoted: a place such as \"2:-1:30\")"}


def _is(kind: str, value: Any) -> bool:
    number = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if kind == "a finite number":
        return number
    if kind == "a whole number":
        return number and float(value).is_integer()
    if kind == "true or false":
        return isinstance(value, bool)
    return isinstance(value, str)


def check_template_inputs(template: str, fixed: dict[str, Any], parameters: list[str]) -> None:
    """Refuse a logical scenario on ``template`` that leaves out a name the template needs, or whose
    ``fixed`` settings hold a value of the wrong kind (`REQUIRED`, `KINDS`)."""
    given = set(fixed) | set(parameters)
    missing = [name for name in REQUIRED.get(template, ()) if name not in given]
    if missing:
        raise InputError(f"the {template} template needs '{missing[0]}'", field=missing[0],
                         allowed=f"{', '.join(REQUIRED[template])} in fixed or parameters")
    for name, value in fixed.items():
        kind = KINDS.get(name)
        if kind is not None and not _is(kind, value):
            raise InputError(f"is {value!r}", field=f"fixed.{name}", allowed=kind)
