"""A recorded run replayed in the MuJoCo world, for pictures: the world built from the scenario
(lanelets and recorded traffic) with a car for each agent, every car posed on its driven
trajectory (between two steps, on the state interpolated), its front wheels steered and every
wheel rolled by the distance it has covered; rendered offscreen on the CPU — a chase camera behind
one agent, a bird's-eye view of the road, and the chase camera's video frames. It replays the run
whatever backend produced it. `simgap.report.scene3d` draws the pictures with it (through the seam
it declares, `Replay3D`: the command line hands this class over, so the report imports no backend).

The chase camera follows the car's body as the world poses it — its position, height and
heading, and its pitch on a grade — never the ground plane: where the road climbs, the camera
climbs with the car. It follows smoothly (`chase_cameras`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence

import mujoco
import numpy as np
from commonroad.scenario.scenario import Scenario
from scipy.ndimage import gaussian_filter1d

from simgap.scenario.relief import Surface
from simgap.sim.mujoco.car import COLLISION_GROUP
from simgap.sim.mujoco.world import World, build_world
from simgap.sim.protocol import Agent
from simgap.trajectory import State, Trajectory
from simgap.vehicles import Vehicle

CHASE_DISTANCE = 11.0     # m from the camera to the point it looks at
CHASE_ELEVATION = -14.0   # deg: the camera looks down so much on a level road
CHASE_AHEAD = 1.0         # m ahead of the car's centre, where the camera looks
CHASE_ABOVE = 0.4         # m above the car's centre of gravity, where the camera looks
CHASE_SIDE = 20.0         # deg round to the car's left from straight behind, so that its wheels show
CHASE_SMOOTHING = 0.4     # s: the time over which the camera averages the car's heading, pitch and height
# anti-aliasing samples per pixel: a still gets MuJoCo's default; a video frame none, which
# renders it 2-3 times faster on the CPU (the H.264 encoding softens its edges)
STILL_MULTISAMPLES, VIDEO_MULTISAMPLES = 4, 0


class MujocoReplay:
    """The MuJoCo world of ``scenario`` on the road's ``relief`` (None: flat) with each agent's car
    (``vehicles``) on its ``driven`` trajectory (time step ``dt``). Times are seconds from the run's
    first state."""

    def __init__(self, scenario: Scenario, vehicles: Mapping[int, Vehicle], driven: Mapping[int, Trajectory],
                 dt: float, relief: Surface | None = None):
        self.driven, self.dt = driven, dt
        self.world: World = build_world(scenario, [Agent(aid, vehicles[aid], driven[aid][0]) for aid in driven],
                                        relief=relief)
        self._rolled = {aid: self._roll_angles(aid) for aid in driven}
        self._options = mujoco.MjvOption()
        self._options.geomgroup[COLLISION_GROUP] = 0          # the cars' collision boxes

    def pose(self, t: float) -> None:
        """Every car at its driven state ``t`` after the start, its wheels rolled; the traffic where it was then."""
        q = self.world.data.qpos
        for aid, driven in self.driven.items():
            self.world.place(aid, self._state(aid, t))
            angles = self._rolled[aid]
            for k, adr in enumerate(self.world.cars[aid].spin_qpos):
                q[adr] = np.interp(driven.t[0] + t, driven.t, angles[:, k])
        self.world.move_traffic(t)
        mujoco.mj_forward(self.world.model, self.world.data)

    def stills(self, step: int, agent_id: int, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(chase camera behind ``agent_id``, bird's-eye view) at ``step``, ``size`` = (width, height)."""
        steps = len(self.driven[agent_id])
        chase = self.chase_cameras([k * self.dt for k in range(steps)], agent_id)[min(step, steps - 1)]
        self.pose(step * self.dt)
        with self._renderer(size, STILL_MULTISAMPLES) as renderer:
            renderer.update_scene(self.world.data, camera=chase, scene_option=self._options)
            picture = renderer.render().copy()
            renderer.update_scene(self.world.data, camera=self._birdseye(), scene_option=self._options)
            return picture, renderer.render().copy()

    def chase_frames(self, times: Sequence[float], agent_id: int, size: tuple[int, int]) -> Iterator[np.ndarray]:
        """The chase camera behind ``agent_id`` at each of ``times`` (evenly spaced), one frame at a time."""
        cameras = self.chase_cameras(times, agent_id)
        with self._renderer(size, VIDEO_MULTISAMPLES) as renderer:
            for t, camera in zip(times, cameras):
                self.pose(t)
                renderer.update_scene(self.world.data, camera=camera, scene_option=self._options)
                yield renderer.render().copy()

    def chase_cameras(self, times: Sequence[float], agent_id: int) -> list[mujoco.MjvCamera]:
        """A camera behind and above ``agent_id``'s car at each of ``times`` (evenly spaced): it looks
        at a point ahead of the car's body, along the body's heading and pitch, from behind; heading,
        pitch and height averaged over `CHASE_SMOOTHING` so that the picture does not shake with
        the body's sideslip and pitching."""
        body = self.world.cars[agent_id].chassis_body
        position, forward = np.zeros((len(times), 3)), np.zeros((len(times), 3))
        for i, t in enumerate(times):
            self.pose(t)
            position[i] = self.world.data.xpos[body]
            forward[i] = self.world.data.xmat[body].reshape(3, 3)[:, 0]
        heading = np.unwrap(np.arctan2(forward[:, 1], forward[:, 0]))
        pitch = np.arcsin(np.clip(forward[:, 2], -1.0, 1.0))
        height = position[:, 2]
        if len(times) > 1:
            sigma = CHASE_SMOOTHING / (times[1] - times[0])
            heading, pitch, height = (gaussian_filter1d(a, sigma, mode="nearest") for a in (heading, pitch, height))
        cameras = []
        for (x, y, _), h, p, z in zip(position, heading, pitch, height):
            cam = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_FREE
            ahead = CHASE_AHEAD * np.array([math.cos(p) * math.cos(h), math.cos(p) * math.sin(h), math.sin(p)])
            cam.lookat[:] = np.array([x, y, z + CHASE_ABOVE]) + ahead
            cam.azimuth = math.degrees(h) - CHASE_SIDE
            cam.elevation = CHASE_ELEVATION + math.degrees(p)
            cam.distance = CHASE_DISTANCE
            cameras.append(cam)
        return cameras

    def _renderer(self, size: tuple[int, int], multisamples: int) -> mujoco.Renderer:
        visual = self.world.model.vis.global_
        visual.offwidth, visual.offheight = max(size[0], visual.offwidth), max(size[1], visual.offheight)
        self.world.model.vis.quality.offsamples = multisamples
        return mujoco.Renderer(self.world.model, size[1], size[0])

    def _state(self, agent_id: int, t: float) -> State:
        """The agent's driven state ``t`` after its first (held at its last one when it finished early)."""
        driven = self.driven[agent_id]
        return driven.at(driven.t[0] + t)

    def _roll_angles(self, agent_id: int) -> np.ndarray:
        """How far each wheel has turned at each driven state [rad] (steps x CORNERS): a wheel rolls
        at its corner's forward speed, v - yaw rate * its offset to the left."""
        car, driven = self.world.cars[agent_id], self.driven[agent_id]
        left = np.array([y for _, y in car.corners])
        rate = (driven.v[:, None] - driven.yaw_rate[:, None] * left) / car.physics.wheel_radius
        turned = np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(driven.t)[:, None], axis=0)
        return np.vstack([np.zeros((1, len(left))), turned])

    def _birdseye(self) -> mujoco.MjvCamera:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        x0, y0, x1, y1 = self.world.road_bounds
        cam.lookat[:] = [(x0 + x1) / 2, (y0 + y1) / 2, 0.0]
        cam.azimuth = 90.0
        cam.elevation = -65.0
        # fit the larger side of the road's bounding box into the 45 deg vertical field of view
        cam.distance = 1.25 * max(x1 - x0, (y1 - y0) * 16 / 9) / 2 / math.tan(math.radians(22.5)) / (16 / 9) + 10.0
        return cam
