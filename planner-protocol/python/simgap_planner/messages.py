"""What a planner behind the protocol is given and returns, as plain Python values.

These mirror simgap's own planner interface (`simgap.planning.protocol`) without simgap: a planner
class is built as ``cls(setup)`` and asked ``plan(observed, t, world)`` each cycle, and returns a
`Trajectory` (or any object with ``dt`` and the columns `STATE_FIELDS`) or None for no plan.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

from simgap_planner import simgap_planner_pb2 as pb

PROTOCOL_VERSION = "1.0"
STATE_FIELDS = ("t", "x", "y", "yaw", "v", "a", "yaw_rate", "steer")


@dataclass(frozen=True)
class State:
    """One state of a vehicle: centre position [m], heading [rad], speed [m/s], ... (SI units)."""

    t: float
    x: float
    y: float
    yaw: float
    v: float
    a: float = 0.0
    yaw_rate: float = 0.0
    steer: float = 0.0


class Trajectory:
    """States on the time grid ``t[k] = t[0] + k * dt``: one numpy array per field of `STATE_FIELDS`."""

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
class Vehicle:
    """The vehicle the planner assumes it drives; ``data`` holds every field of simgap's vehicle data."""

    name: str
    length: float
    width: float
    wheelbase: float
    rear_axle_to_center: float
    max_steer: float
    max_steer_rate: float
    max_accel: float
    max_speed: float
    v_switch: float
    commonroad_vehicle_type: Optional[int]
    data: Dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Setup:
    """What a planner is built from, once per agent: the CommonRoad XML holds the lanelet network
    and the planning problem set (the agent's problem has the id ``agent_id``); ``route`` is
    simgap's route centre line from the start to the goal, an (N, 2) array."""

    agent_id: int
    dt: float
    vehicle: Vehicle
    commonroad_xml: str
    route: np.ndarray
    settings: Dict[str, Any]


@dataclass(frozen=True)
class Participant:
    """Another road user: footprint [m] and predicted centre states on the scenario's grid."""

    id: int
    length: float
    width: float
    prediction: Trajectory


@dataclass(frozen=True)
class World:
    """What a planner sees each cycle besides its own state: the time step and the traffic."""

    dt: float
    traffic: Tuple[Participant, ...]


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
    vehicle = Vehicle(v.name, v.length, v.width, v.wheelbase, v.rear_axle_to_center, v.max_steer, v.max_steer_rate,
                      v.max_accel, v.max_speed, v.v_switch, v.commonroad_vehicle_type or None,
                      json.loads(v.json) if v.json else {})
    route = np.column_stack([column_of(message.route.x), column_of(message.route.y)])
    return Setup(message.agent_id, message.dt, vehicle, message.commonroad_xml, route,
                 json.loads(message.settings_json) if message.settings_json else {})


def world_of(message: pb.PlanRequest, dt: float) -> World:
    return World(dt, tuple(Participant(p.id, p.length, p.width, trajectory_of(p.prediction)) for p in message.traffic))
