"""A stand-in for a BeamNG.tech server, for tests without one.

It speaks beamngpy's message formats (vehicle state with the reference node's position and a
quaternion whose local forward axis is -y, an eight-corner bounding box, electrics with the
steering input positive to the right, advanced-IMU readings along the sensor's axes, damage)
and moves every car as a kinematic single-track vehicle whose reference node sits off its
centre, so every conversion the backend makes is exercised. Its physics is deliberately simple:
it tests the backend's plumbing, not BeamNG's vehicle dynamics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simgap.sim.beamng.catalogue import MODELS, STEERING_SIGN
from simgap.sim.beamng.convert import quat_from_yaw
from simgap.sim.beamng.session import Poll

REF_OFFSET = np.array([1.1, 0.05, 0.45])    # reference node from the centre: forward, left, up [m]
WHEELBASE = 2.7


@dataclass
class Car:
    model: str
    x: float            # centre
    y: float
    yaw: float
    v: float = 0.0
    a: float = 0.0
    yaw_rate: float = 0.0
    steer_input: float = 0.0      # BeamNG convention: positive right
    throttle: float = 0.0
    brake: float = 0.0
    damage: float = 0.0
    target_speed: tuple[float, float] | None = None     # set_velocity: (speed, time left)
    script: list[dict] | None = None
    script_t: float = 0.0

    @property
    def lock(self) -> float:
        return MODELS[self.model].steer_lock

    def ref_pos(self) -> tuple[float, float, float]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (self.x + REF_OFFSET[0] * c - REF_OFFSET[1] * s, self.y + REF_OFFSET[0] * s + REF_OFFSET[1] * c,
                REF_OFFSET[2])


class FakeServer:
    def __init__(self, settings, fail_on: str | None = None):
        self.settings = settings
        self.hz = settings.physics_hz
        self.cars: dict[str, Car] = {}
        self.roads = []
        self.steps = 0
        self.calls: dict[str, int] = {}
        self.scripts: list[tuple[str, list[dict]]] = []
        self.closed = False
        self.fail_on = fail_on

    def _count(self, name: str) -> None:
        self.calls[name] = self.calls.get(name, 0) + 1
        if name == self.fail_on:
            raise ConnectionResetError(f"fake server dropped the connection during {name}")

    # --- the Session methods --------------------------------------------------------------
    def build(self, name, roads, spawns, sensors) -> None:
        self._count("build")
        self.roads = list(roads)
        for s in spawns:        # spawned with its centre at the given position; cling puts it on the ground
            self.cars[s.vid] = Car(s.model, s.pos[0], s.pos[1], _yaw(s.rot_quat))
        self.sensors = set(sensors)

    def step(self, physics_steps: int) -> None:
        self._count("step")
        for _ in range(physics_steps):
            self._physics(1.0 / self.hz)
        self.steps += physics_steps

    def poll(self, vid: str) -> Poll:
        self._count("poll")
        car = self.cars[vid]
        quat = quat_from_yaw(car.yaw)
        fwd = np.array([math.cos(car.yaw), math.sin(car.yaw), 0.0])
        up = np.array([0.0, 0.0, 1.0])
        right = np.cross(fwd, up)
        spec = MODELS[car.model]
        corners = {}
        for fb, sl in (("front", 0.5), ("rear", -0.5)):
            for lr, sw in (("left", 0.5), ("right", -0.5)):
                for bt, z in (("bottom", 0.1), ("top", 1.4)):
                    p = np.array([car.x, car.y, 0.0]) + sl * spec.length * fwd - sw * spec.width * right
                    corners[f"{fb}_{bt}_{lr}"] = (float(p[0]), float(p[1]), z)
        imu = None
        if vid in self.sensors:
            accel = car.a * fwd + car.v * car.yaw_rate * np.cross(up, fwd)
            # sensor axes: forward, up, and their cross product (right); readings along them
            imu = {0: {"time": self.steps / self.hz, "accSmooth": [float(accel @ fwd), float(accel @ up),
                                                                    float(accel @ right)],
                       "angVelSmooth": [0.0, car.yaw_rate, 0.0], "dirX": fwd.tolist(), "dirY": up.tolist(),
                       "dirZ": right.tolist()}}
        velocity = car.v * fwd + car.yaw_rate * 0.5 * WHEELBASE * np.cross(up, fwd)    # of the centre
        return Poll(state={"pos": car.ref_pos(), "dir": fwd.tolist(), "up": up.tolist(),
                           "vel": velocity.tolist(), "rotation": quat},
                    bbox=corners, electrics={"steering_input": car.steer_input, "wheelspeed": abs(car.v)},
                    imu=imu, damage={"damage": car.damage})

    def control(self, vid, steering, throttle, brake) -> None:
        self._count("control")
        assert -1.0 <= steering <= 1.0 and 0.0 <= throttle <= 1.0 and 0.0 <= brake <= 1.0
        car = self.cars[vid]
        car.steer_input, car.throttle, car.brake = steering, throttle, brake

    def set_script(self, vid, script) -> None:
        self._count("set_script")
        assert len(script) >= 3 and all(set(n) == {"x", "y", "z", "t"} for n in script)
        self.scripts.append((vid, script))
        self.cars[vid].script, self.cars[vid].script_t = script, 0.0

    def teleport(self, vid, pos, rot_quat, reset) -> None:
        self._count("teleport")
        car = self.cars[vid]
        car.yaw = _yaw(rot_quat)
        c, s = math.cos(car.yaw), math.sin(car.yaw)
        car.x = pos[0] - (REF_OFFSET[0] * c - REF_OFFSET[1] * s)
        car.y = pos[1] - (REF_OFFSET[0] * s + REF_OFFSET[1] * c)
        if reset:
            car.v = car.a = car.yaw_rate = 0.0

    def set_velocity(self, vid, speed, over_s) -> None:
        self._count("set_velocity")
        self.cars[vid].target_speed = (speed, over_s)

    def close(self) -> None:
        self.closed = True

    # --- the fake's physics -----------------------------------------------------------------
    def _physics(self, h: float) -> None:
        for car in self.cars.values():
            if car.script is not None:
                self._script_driver(car)
            if car.target_speed is not None:
                speed, left = car.target_speed
                car.a = (speed - car.v) / max(left, h)
                car.target_speed = (speed, left - h) if left - h > 1e-9 else None
            else:
                car.a = 6.0 * car.throttle - 9.0 * car.brake
                if car.v <= 0.0 and car.a < 0.0:
                    car.a = 0.0
            delta = STEERING_SIGN * car.steer_input * car.lock
            car.v = max(0.0, car.v + car.a * h)
            car.yaw_rate = car.v * math.tan(delta) / WHEELBASE
            # kinematic single track: the rear axle (half a wheelbase behind the centre) rolls along the heading
            rx = car.x - 0.5 * WHEELBASE * math.cos(car.yaw) + car.v * math.cos(car.yaw) * h
            ry = car.y - 0.5 * WHEELBASE * math.sin(car.yaw) + car.v * math.sin(car.yaw) * h
            car.yaw += car.yaw_rate * h
            car.x = rx + 0.5 * WHEELBASE * math.cos(car.yaw)
            car.y = ry + 0.5 * WHEELBASE * math.sin(car.yaw)
            if car.script is not None:
                car.script_t += h
        cars = list(self.cars.values())
        for i, a in enumerate(cars):
            for b in cars[i + 1:]:
                if math.hypot(a.x - b.x, a.y - b.y) < 0.5 * (MODELS[a.model].width + MODELS[b.model].width):
                    a.damage += 500.0
                    b.damage += 500.0

    def _script_driver(self, car: Car) -> None:
        """Pure pursuit on the script's positions, speed from its time stamps (the ref node drives)."""
        nodes = car.script
        t = car.script_t + 0.6
        ts = [n["t"] for n in nodes]
        tx, ty = (float(np.interp(t, ts, [n[k] for n in nodes])) for k in ("x", "y"))
        rx, ry, _ = car.ref_pos()
        angle = math.atan2(ty - ry, tx - rx) - car.yaw
        angle = math.atan2(math.sin(angle), math.cos(angle))
        dist = max(math.hypot(tx - rx, ty - ry), 1.0)
        delta = math.atan2(2 * WHEELBASE * math.sin(angle), dist)
        car.steer_input = max(-1.0, min(1.0, STEERING_SIGN * delta / car.lock))
        t_now = car.script_t
        k = int(np.searchsorted(ts, t_now + 0.3))
        k = min(max(k, 1), len(nodes) - 1)
        seg = math.hypot(nodes[k]["x"] - nodes[k - 1]["x"], nodes[k]["y"] - nodes[k - 1]["y"])
        want = seg / max(ts[k] - ts[k - 1], 1e-3)
        err = want - car.v
        car.throttle, car.brake = (min(1.0, 0.5 * err), 0.0) if err > 0 else (0.0, min(1.0, -0.5 * err))


def _yaw(quat) -> float:
    """Heading of an upright car from its BeamNG rotation (x, y, z, w): a turn about z whose
    local forward is -y (decoded here independently of `simgap.sim.beamng.convert`)."""
    return math.atan2(2 * quat[3] * quat[2], 1 - 2 * quat[2] ** 2) - math.pi / 2
