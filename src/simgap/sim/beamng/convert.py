"""BeamNG's messages in simgap's conventions, and back.

BeamNG: a vehicle's ``pos`` is its reference node (not the body's centre); its local forward
axis is -y, so the rotation quaternion (x, y, z, w) of a car facing +x is a quarter turn about z;
the advanced IMU reports acceleration and angular velocity along its own axes (``dirX``,
``dirY``, ``dirZ``, world-space); ``electrics.steering_input`` is the steering input in [-1, 1],
positive to the right. simgap (`State`): the body's centre, yaw from +x counter-clockwise, signed
speed along the heading, longitudinal acceleration, yaw rate, and the road-wheel angle of the
single-track model, positive to the left.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from simgap.sim.beamng.catalogue import STEERING_SIGN
from simgap.trajectory import State

FORWARD_LOCAL = np.array([0.0, -1.0, 0.0])     # a BeamNG vehicle's forward axis in its own frame
DAMAGE_COLLISION = 50.0                        # damage rise in one step read as a collision [-]


def quat_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """BeamNG rotation (x, y, z, w) of a vehicle upright and facing ``yaw``."""
    half = 0.5 * (yaw + math.pi / 2)
    return (0.0, 0.0, math.sin(half), math.cos(half))


def rotate(quat: Sequence[float], v: np.ndarray) -> np.ndarray:
    x, y, z, w = (float(c) for c in quat)
    u = np.array([x, y, z])
    return 2.0 * np.dot(u, v) * u + (w * w - np.dot(u, u)) * v + 2.0 * w * np.cross(u, v)


def forward_of(quat: Sequence[float]) -> np.ndarray:
    return rotate(quat, FORWARD_LOCAL)


def yaw_of(quat: Sequence[float]) -> float:
    f = forward_of(quat)
    return math.atan2(f[1], f[0])


def bbox_centre(bbox: Mapping[str, Sequence[float]]) -> np.ndarray:
    """Centre of the vehicle's bounding box (the mean of its eight corners)."""
    return np.mean(np.array([bbox[k] for k in bbox], dtype=float), axis=0)


def latest_reading(readings: Any) -> Mapping[str, Any] | None:
    """The newest advanced-IMU reading of a poll (a reading, a list, or readings by index)."""
    if not readings:
        return None
    if isinstance(readings, Mapping) and "accSmooth" in readings:
        return readings
    if isinstance(readings, Mapping):
        return readings[max(readings, key=lambda k: int(k))]
    return readings[-1]


def _world(reading: Mapping[str, Any], key: str) -> np.ndarray:
    values = reading[key]
    axes = [np.asarray(reading[d], dtype=float) for d in ("dirX", "dirY", "dirZ")]
    return sum(float(values[i]) * axes[i] for i in range(3))


def to_state(t: float, state: Mapping[str, Any], centre: np.ndarray, electrics: Mapping[str, Any],
             imu: Any, steer_lock: float) -> State:
    """A simgap `State` from one poll of the vehicle: ``state`` (the vehicle's state message),
    ``centre`` (of the bounding box), ``electrics`` and ``imu`` (the advanced IMU's readings).
    Without an IMU reading the acceleration is NaN (the caller knows the speed's history) and
    the yaw rate 0."""
    forward = forward_of(state["rotation"])
    heading = forward[:2] / max(float(np.linalg.norm(forward[:2])), 1e-12)
    vel = np.asarray(state["vel"], dtype=float)
    speed = float(np.dot(vel[:2], heading))
    reading = latest_reading(imu)
    if reading is not None:
        accel = float(np.dot(_world(reading, "accSmooth")[:2], heading))
        yaw_rate = float(_world(reading, "angVelSmooth")[2])
    else:
        accel, yaw_rate = math.nan, 0.0
    steer = STEERING_SIGN * float(electrics.get("steering_input", 0.0)) * steer_lock
    return State(t=t, x=float(centre[0]), y=float(centre[1]), yaw=math.atan2(heading[1], heading[0]),
                 v=speed, a=accel, yaw_rate=yaw_rate, steer=steer)


def steering_input(steer: float, steer_lock: float) -> float:
    """BeamNG steering input in [-1, 1] for a road-wheel angle ``steer`` [rad]."""
    return max(-1.0, min(1.0, STEERING_SIGN * steer / steer_lock))


def reference_offset(state: Mapping[str, Any], centre: np.ndarray) -> np.ndarray:
    """Where the reference node sits relative to the body's centre, in the vehicle's own frame
    (forward, left, up): measured once after spawning, used to place a centre."""
    forward = forward_of(state["rotation"])
    up = rotate(state["rotation"], np.array([0.0, 0.0, 1.0]))
    left = np.cross(up, forward)
    d = np.asarray(state["pos"], dtype=float) - centre
    return np.array([np.dot(d, forward), np.dot(d, left), np.dot(d, up)])


def reference_position(x: float, y: float, z: float, yaw: float, offset: np.ndarray) -> tuple[float, float, float]:
    """Reference-node position that puts the body's centre at (x, y, z) facing ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + offset[0] * c - offset[1] * s, y + offset[0] * s + offset[1] * c, z + offset[2])
