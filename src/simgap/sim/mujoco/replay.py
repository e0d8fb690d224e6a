"""A recorded run replayed in the MuJoCo world, for pictures: the world built from the scenario
(lanelets and recorded traffic) with a car for each agent, every car posed on its driven
trajectory at a step, rendered offscreen on the CPU — a chase camera behind one agent, a
bird's-eye view of the road, and the chase camera's animation frames. It replays the run whatever
backend produced it. `simgap.report.scene3d` draws the pictures with it (through the seam it
declares, `Replay3D`: the command line hands this class over, so the report imports no backend).
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import mujoco
import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.sim.mujoco.car import COLLISION_GROUP
from simgap.sim.mujoco.world import World, build_world
from simgap.sim.protocol import Agent
from simgap.trajectory import State, Trajectory
from simgap.vehicles import Vehicle


class MujocoReplay:
    """The MuJoCo world of ``scenario`` with each agent's car (``vehicles``) on its ``driven``
    trajectory (time step ``dt``)."""

    def __init__(self, scenario: Scenario, vehicles: Mapping[int, Vehicle], driven: Mapping[int, Trajectory],
                 dt: float):
        self.driven, self.dt = driven, dt
        self.world: World = build_world(scenario, [Agent(aid, vehicles[aid], driven[aid][0]) for aid in driven])
        self._options = mujoco.MjvOption()
        self._options.geomgroup[COLLISION_GROUP] = 0          # the cars' collision boxes

    def stills(self, step: int, agent_id: int, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(chase camera behind ``agent_id``, bird's-eye view) at ``step``, ``size`` = (width, height)."""
        self._pose(step)
        with self._renderer(size) as renderer:
            renderer.update_scene(self.world.data, camera=self._chase(step, agent_id), scene_option=self._options)
            chase = renderer.render().copy()
            renderer.update_scene(self.world.data, camera=self._birdseye(), scene_option=self._options)
            return chase, renderer.render().copy()

    def frames(self, steps: Sequence[int], agent_id: int, size: tuple[int, int]) -> list[np.ndarray]:
        """The chase camera behind ``agent_id`` at each of ``steps``."""
        out = []
        with self._renderer(size) as renderer:
            for k in steps:
                self._pose(k)
                renderer.update_scene(self.world.data, camera=self._chase(k, agent_id), scene_option=self._options)
                out.append(renderer.render().copy())
        return out

    def _renderer(self, size: tuple[int, int]) -> mujoco.Renderer:
        visual = self.world.model.vis.global_
        visual.offwidth, visual.offheight = max(size[0], visual.offwidth), max(size[1], visual.offheight)
        return mujoco.Renderer(self.world.model, size[1], size[0])

    def _state(self, agent_id: int, step: int) -> State:
        """The agent's driven state at ``step`` (held at its last one when it finished early)."""
        driven = self.driven[agent_id]
        return driven[min(step, len(driven) - 1)]

    def _pose(self, step: int) -> None:
        """Every car at its driven state of ``step``, the traffic where it was then."""
        for aid in self.driven:
            self.world.place(aid, self._state(aid, step))
        self.world.move_traffic(step * self.dt)
        mujoco.mj_forward(self.world.model, self.world.data)

    def _chase(self, step: int, agent_id: int) -> mujoco.MjvCamera:
        state = self._state(agent_id, step)
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = [state.x + 4.0 * math.cos(state.yaw), state.y + 4.0 * math.sin(state.yaw), 0.8]
        cam.azimuth = math.degrees(state.yaw)
        cam.elevation = -16.0
        cam.distance = 13.0
        return cam

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
