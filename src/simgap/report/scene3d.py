"""3D pictures of a finished run: a chase camera and a bird's-eye view at the run's most
demanding instant, a chase-camera animation, and the 3D and the 2D CommonRoad scene side by side
at that instant (the paper's Figure 1).

The 3D world is a replay: rebuilt from the run's ``driven.xml`` (lanelets and recorded traffic;
the agents, stored there as obstacles, are taken out) with every car posed on its driven
trajectory, whatever backend produced the run. Which world draws it is the one seam between the
pictures and a backend (`Replay3D`): the caller hands it over — the command line gives
`simgap.sim.mujoco.replay.MujocoReplay` — so this package imports no backend.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Callable, Mapping, Protocol, Sequence

import imageio.v2 as imageio
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from commonroad.scenario.scenario import Scenario  # noqa: E402
from commonroad.visualization.mp_renderer import MPRenderer  # noqa: E402

from simgap.cosim.record import AGENT_ID_OFFSET, Run  # noqa: E402
from simgap.report.scene2d import draw_scene, load_driven  # noqa: E402
from simgap.scenario.preview import figure_size, plot_limits  # noqa: E402
from simgap.trajectory import Trajectory  # noqa: E402
from simgap.vehicles import Vehicle  # noqa: E402

STILL = (1280, 720)
ANIMATION = (640, 360)
PICTURES = ("scene3d_chase.png", "scene3d_birdseye.png", "scene3d.gif", "side_by_side.png")   # what it writes


class Replay3D(Protocol):
    """A recorded run in a 3D world: each agent's car on its driven trajectory."""

    def stills(self, step: int, agent_id: int, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(chase camera behind ``agent_id``, bird's-eye view) at ``step``, ``size`` = (width, height)."""
        ...

    def frames(self, steps: Sequence[int], agent_id: int, size: tuple[int, int]) -> list[np.ndarray]:
        """The chase camera behind ``agent_id`` at each of ``steps``."""
        ...


#: builds a `Replay3D` from the scenario without the agents, each agent's vehicle and driven
#: trajectory, and the time step
ReplayWorld = Callable[[Scenario, Mapping[int, Vehicle], Mapping[int, Trajectory], float], Replay3D]


def _replay(scenario: Scenario, run: Run, world: ReplayWorld) -> Replay3D:
    scene = copy.deepcopy(scenario)
    for obstacle in list(scene.dynamic_obstacles):
        if obstacle.obstacle_id >= AGENT_ID_OFFSET:
            scene.remove_obstacle(obstacle)
    return world(scene, {a.id: run.vehicle_of(a.id) for a in run.agents},
                 {a.id: run.driven[a.id] for a in run.agents}, run.dt)


def _instant(run: Run) -> int:
    """The step at which the first agent turns hardest (largest |yaw rate|)."""
    driven = run.driven[run.agents[0].id]
    return int(np.argmax(np.abs(driven.yaw_rate))) if len(driven) else 0


def render_run_3d(run_dir: str | Path, out_dir: str | Path | None, frame_every: int, world: ReplayWorld) -> list[Path]:
    """Write ``scene3d_chase.png``, ``scene3d_birdseye.png``, ``scene3d.gif`` and
    ``side_by_side.png`` into ``out_dir`` (None: the run directory), the run replayed in ``world``."""
    run_dir = Path(run_dir)
    out_dir = Path(out_dir or run_dir)
    scenario, problems, run = load_driven(run_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    replay = _replay(scenario, run, world)
    first = run.agents[0].id
    step = _instant(run)
    written = []

    chase, birdseye = replay.stills(step, first, STILL)
    for name, image in zip(PICTURES[:2], (chase, birdseye)):
        imageio.imwrite(out_dir / name, image)
        written.append(out_dir / name)

    last = max(len(t) for t in run.driven.values()) - 1
    frames = replay.frames(range(0, last + 1, frame_every), first, ANIMATION)
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
    draw_scene(rnd, scenario, problems, run, step, f"2D CommonRoad scene, t = {step * run.dt:.1f} s")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
