"""What a planner is given and returns: the planner SDK's types, as plain Python values.

A planner class is built as ``cls(setup)`` and asked ``plan(observed, t, world)`` each cycle, and
returns a `Trajectory` (or any object with ``dt`` and the columns `STATE_FIELDS`) or None for no
plan (its ``failure_reason``, when it has one, says why). simgap's own types
(`simgap.planning.protocol`) carry the same field names, so a planner written against these runs
unchanged in simgap's process (``--planner file.py:Class``) and served from its own
(``--planner 'exec:python file.py'``, the file ending in ``serve(Class)``).

Every field a planner may use is documented with ``metadata={"doc": ...}`` (simgap's reference
page is generated from it). The lanelet network, the planning problem and the goal are read from
the CommonRoad XML on first use, which needs ``commonroad-io`` in the planner's environment.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Dict, Optional, Sequence, Tuple

import numpy as np

from simgap_planner import simgap_planner_pb2 as pb

if TYPE_CHECKING:       # commonroad-io: needed only by a planner that reads the road or the goal
    from commonroad.planning.goal import GoalRegion
    from commonroad.planning.planning_problem import PlanningProblem
    from commonroad.scenario.lanelet import LaneletNetwork

PROTOCOL_VERSION = "1.0"
STATE_FIELDS = ("t", "x", "y", "yaw", "v", "a", "yaw_rate", "steer")


def _doc(text: str, **kwargs: Any) -> Any:
    """A dataclass field documented for the reference page."""
    return field(metadata={"doc": text}, **kwargs)


@dataclass(frozen=True)
class State:
    """One state of a vehicle (SI units; the centre's position, CommonRoad's conventions)."""

    t: float = _doc("time [s]")
    x: float = _doc("centre position [m]")
    y: float = _doc("centre position [m]")
    yaw: float = _doc("heading, counter-clockwise from the x axis [rad]")
    v: float = _doc("speed [m/s]")
    a: float = _doc("longitudinal acceleration [m/s^2]", default=0.0)
    yaw_rate: float = _doc("yaw rate [rad/s]", default=0.0)
    steer: float = _doc("road-wheel steering angle [rad]", default=0.0)


class Trajectory:
    """States on the time grid ``t[k] = t[0] + k * dt``: one numpy array per field of `STATE_FIELDS`
    (``Trajectory(dt, t=..., x=..., ...)``; a column left out is zeros), or
    ``Trajectory.from_states(states, dt)``."""

    def __init__(self, dt: float, **columns: Sequence[float]):
        n = len(columns["t"])
        self.dt = float(dt)
        for name in STATE_FIELDS:
            values = np.asarray(columns.get(name, np.zeros(n)), dtype=float).reshape(-1)
            if len(values) != n:
                raise ValueError(f"column {name!r} has {len(values)} values, t has {n}")
            setattr(self, name, values)

    @classmethod
    def from_states(cls, states: Sequence[State], dt: float) -> "Trajectory":
        return cls(dt, **{f: [getattr(s, f) for s in states] for f in STATE_FIELDS})

    def __len__(self) -> int:
        return len(self.t)


@dataclass(frozen=True)
class VehicleLimits:
    """What the vehicle can do."""

    max_steer: float = _doc("largest road-wheel steering angle [rad]")
    max_steer_rate: float = _doc("largest steering rate [rad/s]")
    max_accel: float = _doc("largest longitudinal acceleration, a magnitude [m/s^2]")
    max_speed: float = _doc("top speed [m/s]")
    v_switch: float = _doc("speed above which acceleration is power-limited [m/s]")


@dataclass(frozen=True)
class Vehicle:
    """The vehicle the planner assumes it drives (not necessarily the simulated car)."""

    name: str = _doc("the vehicle's name in simgap's catalogue (or its file's)")
    length: float = _doc("body length [m]")
    width: float = _doc("body width [m]")
    wheelbase: float = _doc("front to rear axle [m]")
    rear_axle_to_center: float = _doc("rear axle to the vehicle's centre [m]")
    limits: VehicleLimits = _doc("what it can do: steering angle and rate, acceleration, speed")
    commonroad_vehicle_type: Optional[int] = _doc("CommonRoad's parameter set it is (1, 2 or 3), or None")
    data: Dict[str, Any] = _doc("every field of simgap's vehicle data (a JSON object)", default_factory=dict)

    # the limits' names as the SDK 1.0 had them, on the vehicle itself (kept for planners written then)
    max_steer = property(lambda self: self.limits.max_steer)
    max_steer_rate = property(lambda self: self.limits.max_steer_rate)
    max_accel = property(lambda self: self.limits.max_accel)
    max_speed = property(lambda self: self.limits.max_speed)
    v_switch = property(lambda self: self.limits.v_switch)


@dataclass(frozen=True)
class Setup:
    """What a planner is built from, once per agent, before its first cycle."""

    agent_id: int = _doc("the agent's planning problem id")
    dt: float = _doc("the scenario's time step: the grid of every trajectory [s]")
    vehicle: Vehicle = _doc("the vehicle the planner assumes it drives")
    commonroad_xml: str = _doc("CommonRoad XML of the lanelet network and the agent's planning problem")
    route: np.ndarray = _doc("simgap's route centre line from the start to the goal, an (N, 2) array [m] "
                             "(no rows when the goal cannot be reached on the lanelets)")
    settings: Dict[str, Any] = _doc("the planner's settings as the user gave them, a JSON object")

    @cached_property
    def _scenario(self) -> Tuple[Any, Any]:
        from commonroad.common.file_reader import CommonRoadFileReader

        handle, path = tempfile.mkstemp(suffix=".xml")
        try:
            with os.fdopen(handle, "w") as out:
                out.write(self.commonroad_xml)
            return CommonRoadFileReader(path).open()
        finally:
            os.unlink(path)

    @property
    def lanelet_network(self) -> LaneletNetwork:
        """The road: a commonroad-io ``LaneletNetwork`` (read from ``commonroad_xml`` on first use)."""
        return self._scenario[0].lanelet_network

    @property
    def planning_problem(self) -> PlanningProblem:
        """The agent's commonroad-io ``PlanningProblem``: its initial state and goal."""
        return self._scenario[1].planning_problem_dict[self.agent_id]


@dataclass(frozen=True)
class Participant:
    """Another road user: its footprint and where it will be."""

    id: int = _doc("its id in the scenario")
    length: float = _doc("body length [m]")
    width: float = _doc("body width [m]")
    prediction: Trajectory = _doc("another agent's latest plan, or a recorded road user's trajectory: centre "
                                  "states on the scenario's time grid")


@dataclass(frozen=True)
class World:
    """What a planner sees each cycle besides its own state."""

    dt: float = _doc("the scenario's time step [s]")
    traffic: Tuple[Participant, ...] = _doc("the other road users")
    setup: Optional[Setup] = field(default=None, repr=False, compare=False)    # whence the road and the goal

    @property
    def lanelet_network(self) -> Optional[LaneletNetwork]:
        """The road: the setup's ``lanelet_network``."""
        return self.setup.lanelet_network if self.setup is not None else None

    @property
    def goal(self) -> Optional[GoalRegion]:
        """The agent's goal: its planning problem's commonroad-io ``GoalRegion``."""
        return self.setup.planning_problem.goal if self.setup is not None else None


FLOAT64 = np.dtype("<f8")       # every numeric column on the wire: little-endian IEEE-754 float64


def column_bytes(values: Any) -> bytes:
    """A numeric column as the protocol carries it."""
    return np.ascontiguousarray(values, dtype=FLOAT64).tobytes()


def column_of(data: bytes) -> np.ndarray:
    """A column from the wire (a ValueError when its length is not a whole number of float64s)."""
    if len(data) % FLOAT64.itemsize:
        raise ValueError(f"a column of {len(data)} bytes, not a whole number of 8-byte float64 values")
    return np.frombuffer(data, dtype=FLOAT64).astype(float)


def trajectory_message(trajectory: Any, out: pb.Trajectory) -> pb.Trajectory:
    """Fill ``out`` from any object with ``dt`` and the columns of `STATE_FIELDS`."""
    out.dt = float(trajectory.dt)
    for name in STATE_FIELDS:
        setattr(out, name, column_bytes(getattr(trajectory, name)))
    return out


def trajectory_columns(message: pb.Trajectory) -> Dict[str, np.ndarray]:
    return {name: column_of(getattr(message, name)) for name in STATE_FIELDS}


def trajectory_of(message: pb.Trajectory) -> Trajectory:
    return Trajectory(message.dt, **trajectory_columns(message))


def state_message(state: Any, out: pb.State) -> pb.State:
    for name in STATE_FIELDS:
        setattr(out, name, float(getattr(state, name)))
    return out


def state_of(message: pb.State) -> State:
    return State(*(getattr(message, name) for name in STATE_FIELDS))


def setup_of(message: pb.Initialize) -> Setup:
    v = message.vehicle
    limits = VehicleLimits(v.max_steer, v.max_steer_rate, v.max_accel, v.max_speed, v.v_switch)
    vehicle = Vehicle(v.name, v.length, v.width, v.wheelbase, v.rear_axle_to_center, limits,
                      v.commonroad_vehicle_type or None, json.loads(v.json) if v.json else {})
    route = np.column_stack([column_of(message.route.x), column_of(message.route.y)])
    return Setup(message.agent_id, message.dt, vehicle, message.commonroad_xml, route,
                 json.loads(message.settings_json) if message.settings_json else {})


def world_of(message: pb.PlanRequest, dt: float, setup: Optional[Setup] = None) -> World:
    return World(dt, tuple(Participant(p.id, p.length, p.width, trajectory_of(p.prediction)) for p in message.traffic),
                 setup)
