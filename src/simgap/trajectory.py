"""The shared vocabulary of motion: one vehicle's `State` at an instant and a `Trajectory` of them.

Conventions (CommonRoad's): the reference point is the vehicle's centre, yaw is measured
counter-clockwise from +x, all units SI. Conversions to a rear-axle or a simulator frame
happen at the edge that needs them (the planner, a backend), never here.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

#: a scenario's time step (dt) where it names none [s], and so the time grid of its trajectories
DEFAULT_TIME_STEP_S = 0.1
STATE_FIELDS = ("t", "x", "y", "yaw", "v", "a", "yaw_rate", "steer")
ATTITUDE_FIELDS = ("z", "pitch", "roll")


def wrap_angle(angle):
    """Wrap an angle (scalar or array) to (-pi, pi]."""
    wrapped = np.mod(np.asarray(angle, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    wrapped = np.where(wrapped <= -np.pi, wrapped + 2.0 * np.pi, wrapped)
    if np.ndim(angle) == 0:
        return float(wrapped)
    return wrapped



def _column(holder, name: str) -> np.ndarray:
    """A column of a `Trajectory` or `ControlTrace` by its name."""
    if name.startswith("__") or name == "_data":      # (copy and pickle look for these before _data is set)
        raise AttributeError(name)
    try:
        return holder._data[name]
    except KeyError:
        raise AttributeError(name) from None


@dataclass(frozen=True)
class State:
    """One vehicle at one instant: time [s], centre position [m], yaw [rad], speed [m/s],
    longitudinal acceleration [m/s^2], yaw rate [rad/s], road-wheel steering angle [rad]."""

    t: float
    x: float
    y: float
    yaw: float
    v: float
    a: float = 0.0
    yaw_rate: float = 0.0
    steer: float = 0.0

    @property
    def position(self) -> np.ndarray:
        return np.array([self.x, self.y])

    def replace(self, **changes: float) -> State:
        return dataclasses.replace(self, **changes)

    def as_tuple(self) -> tuple[float, ...]:
        return tuple(getattr(self, f) for f in STATE_FIELDS)


@dataclass(frozen=True)
class Attitude:
    """What a world with a third dimension adds to a vehicle's `State` (the planner's world is a
    plane): the height of its centre of gravity [m], its pitch [rad, positive nose up] and roll
    [rad, positive right side down] — a road's grade and superelevation have the same signs."""

    z: float
    pitch: float
    roll: float


class Trajectory:
    """States of one vehicle on a fixed time grid ``t[k] = t0 + k * dt``.

    Immutable: the arrays are read-only views. Index with ``traj[k]`` for a `State`,
    ``traj.at(t)`` for a state interpolated in time (yaw interpolated on the circle).
    """

    __slots__ = ("dt", "_data")
    if TYPE_CHECKING:               # the columns, read by __getattr__ (one per STATE_FIELDS)
        t: np.ndarray
        x: np.ndarray
        y: np.ndarray
        yaw: np.ndarray
        v: np.ndarray
        a: np.ndarray
        yaw_rate: np.ndarray
        steer: np.ndarray

    def __init__(self, dt: float, **columns: Iterable[float]):
        data = _read_only_columns(STATE_FIELDS, columns, "trajectory")
        if not len(data["t"]):
            raise ValueError("a trajectory needs at least one state")
        self.dt = float(dt)
        self._data = data

    @classmethod
    def from_states(cls, states: Sequence[State], dt: float) -> Trajectory:
        return cls(dt, **{f: [getattr(s, f) for s in states] for f in STATE_FIELDS})

    __getattr__ = _column

    def __len__(self) -> int:
        return len(self._data["t"])

    def __getitem__(self, k: int) -> State:
        return State(*(float(self._data[f][k]) for f in STATE_FIELDS))

    def __iter__(self):
        for k in range(len(self)):
            yield self[k]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Trajectory):
            return NotImplemented
        return self.dt == other.dt and all(
            np.array_equal(self._data[f], other._data[f]) for f in STATE_FIELDS
        )

    def __repr__(self) -> str:
        return f"Trajectory(n={len(self)}, t=[{self.t[0]:.2f}, {self.t[-1]:.2f}], dt={self.dt})"

    @property
    def t_end(self) -> float:
        return float(self._data["t"][-1])

    def at(self, t: float) -> State:
        """The state at time ``t``, linearly interpolated; clamped to the ends."""
        ts = self._data["t"]
        if t <= ts[0]:
            return self[0]
        if t >= ts[-1]:
            return self[len(self) - 1]
        k = int(min(math.floor((t - ts[0]) / self.dt), len(ts) - 2))
        w = (t - ts[k]) / (ts[k + 1] - ts[k])
        vals = {f: (1 - w) * self._data[f][k] + w * self._data[f][k + 1] for f in STATE_FIELDS}
        dyaw = wrap_angle(self._data["yaw"][k + 1] - self._data["yaw"][k])
        vals["yaw"] = self._data["yaw"][k] + w * dyaw
        vals["t"] = t
        return State(**{f: float(v) for f, v in vals.items()})

    def path_length(self) -> float:
        return float(np.sum(np.hypot(np.diff(self._data["x"]), np.diff(self._data["y"]))))


CONTROL_FIELDS = ("t", "steer_requested", "steer_at_wheels", "accel_requested", "accel_achieved")


class ControlTrace:
    """What one car's controller asked and what the car did, per control tick (at the
    controller's rate, not the scenario's): ``t`` [s]; ``steer_requested``, the road-wheel angle
    the controller asked for [rad]; ``steer_at_wheels``, the road wheels' angle the car had then
    [rad] (after its actuators' dead time and lag and its steering's rate and angle limits);
    ``accel_requested``, the acceleration the controller's pedal positions ask for at the car's
    speed, through the vehicle's pedal map [m/s^2]; ``accel_achieved``, the car's measured
    longitudinal acceleration [m/s^2]. A world whose plans are executed exactly has none.

    Immutable like a `Trajectory`: the arrays are read-only."""

    __slots__ = ("_data",)
    if TYPE_CHECKING:               # the columns, read by __getattr__ (one per CONTROL_FIELDS)
        t: np.ndarray
        steer_requested: np.ndarray
        steer_at_wheels: np.ndarray
        accel_requested: np.ndarray
        accel_achieved: np.ndarray

    def __init__(self, **columns: Iterable[float]):
        self._data = _read_only_columns(CONTROL_FIELDS, columns, "control trace")

    __getattr__ = _column

    def __len__(self) -> int:
        return len(self._data["t"])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ControlTrace):
            return NotImplemented
        return all(np.array_equal(self._data[f], other._data[f]) for f in CONTROL_FIELDS)

    def __repr__(self) -> str:
        return f"ControlTrace(n={len(self)})"

    def until(self, t: float) -> ControlTrace:
        """The ticks up to ``t`` (inclusive)."""
        keep = self._data["t"] <= t + 1e-9
        return ControlTrace(**{f: a[keep] for f, a in self._data.items()})


def _read_only_columns(fields: Sequence[str], columns: dict, what: str) -> dict[str, np.ndarray]:
    """``columns`` (each of ``fields``, of one length) as read-only float arrays."""
    missing = [f for f in fields if f not in columns]
    if missing:
        raise ValueError(f"{what} is missing columns {missing}")
    data: dict[str, np.ndarray] = {}
    for name in fields:
        arr = np.array(columns[name], dtype=float).reshape(-1)
        if data and len(arr) != len(data[fields[0]]):
            raise ValueError(f"column {name!r} has {len(arr)} entries, expected {len(data[fields[0]])}")
        arr.flags.writeable = False
        data[name] = arr
    return data
