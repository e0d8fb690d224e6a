"""3D pictures of a finished run, rendered offscreen on the CPU with MuJoCo: a chase camera and a
bird's-eye view at the run's most demanding instant, a chase-camera animation, and the 3D and
the 2D CommonRoad scene side by side at that instant (the paper's Figure 1).

The world is rebuilt from the run's ``driven.xml`` (lanelets and recorded traffic; the agents,
stored there as obstacles, are taken out) and every car is posed on its driven trajectory: a
replay, whatever backend produced the run.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import imageio.v2 as imageio
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from commonroad.visualization.mp_renderer import MPRenderer  # noqa: E402

from simgap.cosim.driven_scenario import AGENT_ID_OFFSET  # noqa: E402
from simgap.cosim.record import Run  # noqa: E402
from simgap.report.scene2d import _draw, _load  # noqa: E402
from simgap.scenario.preview import figure_size, plot_limits  # noqa: E402
from simgap.sim.mujoco.world import World, build_world  # noqa: E402
from simgap.sim.protocol import Agent  # noqa: E402

STILL = (1280, 720)
ANIMATION = (640, 360)
PICTURES = ("scene3d_chase.png", "scene3d_birdseye.png", "scene3d.gif", "side_by_side.png")   # what it writes


def _replay_world(scenario, run: Run) -> World:
    scene = copy.deepcopy(scenario)
    for obstacle in list(scene.dynamic_obstacles):
        if obstacle.obstacle_id >= AGENT_ID_OFFSET:
            scene.remove_obstacle(obstacle)
    agents = [Agent(a.id, run.vehicle_of(a.id), run.driven[a.id][0]) for a in run.agents]
    world = build_world(scene, agents)
    world.model.vis.global_.offwidth = max(STILL[0], world.model.vis.global_.offwidth)
    world.model.vis.global_.offheight = max(STILL[1], world.model.vis.global_.offheight)
    return world


def _pose(world: World, run: Run, step: int) -> None:
    """Every car at its driven state of ``step`` (held at its last one when it finished early)."""
    for agent in run.agents:
        driven = run.driven[agent.id]
        world.place(agent.id, driven[min(step, len(driven) - 1)])
    world.move_traffic(step * run.dt)
    mujoco.mj_forward(world.model, world.data)


def _chase(world: World, run: Run, step: int, agent_id: int) -> mujoco.MjvCamera:
    driven = run.driven[agent_id]
    state = driven[min(step, len(driven) - 1)]
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = [state.x + 4.0 * math.cos(state.yaw), state.y + 4.0 * math.sin(state.yaw), 0.8]
    cam.azimuth = math.degrees(state.yaw)
    cam.elevation = -16.0
    cam.distance = 13.0
    return cam


def _birdseye(world: World, run: Run, step: int) -> mujoco.MjvCamera:
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    x0, y0, x1, y1 = world.road_bounds
    cam.lookat[:] = [(x0 + x1) / 2, (y0 + y1) / 2, 0.0]
    cam.azimuth = 90.0
    cam.elevation = -65.0
    # fit the larger side of the road's bounding box into the 45 deg vertical field of view
    cam.distance = 1.25 * max(x1 - x0, (y1 - y0) * 16 / 9) / 2 / math.tan(math.radians(22.5)) / (16 / 9) + 10.0
    return cam


def _options() -> mujoco.MjvOption:
    opt = mujoco.MjvOption()
    opt.geomgroup[3] = 0          # tyre contact spheres
    return opt


def _instant(run: Run) -> int:
    """The step at which the first agent turns hardest (largest |yaw rate|)."""
    driven = run.driven[run.agents[0].id]
    return int(np.argmax(np.abs(driven.yaw_rate))) if len(driven) else 0


def render_run_3d(run_dir: str | Path, out_dir: str | Path | None = None, frame_every: int = 3) -> list[Path]:
    """Write ``scene3d_chase.png``, ``scene3d_birdseye.png``, ``scene3d.gif`` and
    ``side_by_side.png`` into ``out_dir`` (default: the run directory)."""
    run_dir = Path(run_dir)
    out_dir = Path(out_dir or run_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scenario, problems, run = _load(run_dir)
    world = _replay_world(scenario, run)
    first = run.agents[0].id
    step = _instant(run)
    opt = _options()
    written = []

    _pose(world, run, step)
    with mujoco.Renderer(world.model, STILL[1], STILL[0]) as renderer:
        renderer.update_scene(world.data, camera=_chase(world, run, step, first), scene_option=opt)
        chase = renderer.render().copy()
        renderer.update_scene(world.data, camera=_birdseye(world, run, step), scene_option=opt)
        birdseye = renderer.render().copy()
    for name, image in zip(PICTURES[:2], (chase, birdseye)):
        imageio.imwrite(out_dir / name, image)
        written.append(out_dir / name)

    last = max(len(t) for t in run.driven.values()) - 1
    frames = []
    with mujoco.Renderer(world.model, ANIMATION[1], ANIMATION[0]) as renderer:
        for k in range(0, last + 1, frame_every):
            _pose(world, run, k)
            renderer.update_scene(world.data, camera=_chase(world, run, k, first), scene_option=opt)
            frames.append(renderer.render().copy())
    gif = out_dir / PICTURES[2]
    imageio.mimsave(gif, frames, duration=1000 * frame_every * run.dt, loop=0)
    written.append(gif)

    written.append(_side_by_side(out_dir / PICTURES[3], chase, scenario, problems, run, step))
    return written


def _side_by_side(path: Path, image: np.ndarray, scenario, problems, run: Run, step: int) -> Path:
    limits = plot_limits(scenario, margin=10.0)
    width, height = figure_size(limits, width=7.0)
    fig = plt.figure(figsize=(7.0 + 7.0 * image.shape[1] / image.shape[0] * 0.6, max(height, 4.5)))
    ax3d = fig.add_axes([0.0, 0.08, 0.55, 0.84])
    ax3d.imshow(image)
    ax3d.set_axis_off()
    ax3d.set_title(f"3D ({run.backend}), t = {step * run.dt:.1f} s")
    ax2d = fig.add_axes([0.58, 0.12, 0.40, 0.78])
    rnd = MPRenderer(plot_limits=limits, ax=ax2d)
    _draw(rnd, scenario, problems, run, step, f"2D CommonRoad scene, t = {step * run.dt:.1f} s")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
