"""3D pictures of a finished run: a chase camera and a bird's-eye view at the run's most
demanding instant, a chase-camera video of the whole run (MP4, H.264, encoded by the ffmpeg that
the imageio-ffmpeg wheel carries), and the 3D and the 2D CommonRoad scene side by side at that
instant (the paper's Figure 1).

The 3D world is a replay: rebuilt from the run's ``driven.xml`` (lanelets and recorded traffic;
the agents, stored there as obstacles, are taken out) with every car posed on its driven
trajectory, whatever backend produced the run. Which world draws it is the one seam between the
pictures and a backend (`Replay3D`): the caller hands it over — the command line gives
`simgap.sim.mujoco.replay.MujocoReplay` — so this package imports no backend.
"""

from __future__ import annotations

import copy
import errno
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Protocol

import imageio.v2 as imageio
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from commonroad.scenario.scenario import Scenario  # noqa: E402
from commonroad.visualization.mp_renderer import MPRenderer  # noqa: E402

from simgap.cosim.history import AGENT_ID_OFFSET  # noqa: E402
from simgap.files import atomic_write, atomic_write_bytes  # noqa: E402
from simgap.record import RunRecord  # noqa: E402
from simgap.report.scene2d import draw_scene, load_driven  # noqa: E402
from simgap.scenario.ground import ground_of_file  # noqa: E402
from simgap.scenario.preview import figure_size, plot_limits  # noqa: E402
from simgap.scenario.relief import Surface, road_tilt  # noqa: E402
from simgap.trajectory import Trajectory  # noqa: E402
from simgap.vehicles import Vehicle  # noqa: E402

STILL = (1280, 720)
VIDEO = (1280, 720)
VIDEO_FPS = 25
VIDEO_QUALITY = 23        # x264's constant rate factor: lower is better and larger
PICTURES = ("scene3d_chase.png", "scene3d_birdseye.png", "scene3d.mp4", "side_by_side.png")   # what it writes


class Replay3D(Protocol):
    """A recorded run in a 3D world: each agent's car on its driven trajectory."""

    def stills(self, step: int, agent_id: int, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(chase camera behind ``agent_id``, bird's-eye view) at ``step``, ``size`` = (width, height)."""
        ...

    def chase_frames(self, times: Sequence[float], agent_id: int, size: tuple[int, int]) -> Iterator[np.ndarray]:
        """The chase camera behind ``agent_id`` at each of ``times`` (seconds from the run's first
        state, evenly spaced), one frame at a time."""
        ...


#: builds a `Replay3D` from the scenario without the agents, each agent's vehicle and driven
#: trajectory, the time step and the road's relief (None: flat)
ReplayWorld = Callable[[Scenario, Mapping[int, Vehicle], Mapping[int, Trajectory], float, Surface | None],
                       Replay3D]


def _replay(scenario: Scenario, run: RunRecord, world: ReplayWorld, relief: Surface | None) -> Replay3D:
    scene = copy.deepcopy(scenario)
    for obstacle in list(scene.dynamic_obstacles):
        if obstacle.obstacle_id >= AGENT_ID_OFFSET:
            scene.remove_obstacle(obstacle)
    return world(scene, {a.id: run.history.vehicle_of(a.id) for a in run.history.agents},
                 {a.id: run.history.driven[a.id] for a in run.history.agents}, run.history.dt, relief)


def _instant(run: RunRecord) -> int:
    """The step at which the first agent turns hardest (largest |yaw rate|)."""
    driven = run.history.driven[run.history.agents[0].id]
    return int(np.argmax(np.abs(driven.yaw_rate))) if len(driven) else 0


def render_run_3d(run_dir: str | Path, out_dir: str | Path | None, world: ReplayWorld, fps: int = VIDEO_FPS,
                  on_frame: Callable[[int, int], None] | None = None) -> list[Path]:
    """Write ``scene3d_chase.png``, ``scene3d_birdseye.png``, ``scene3d.mp4`` (``fps`` frames a
    second of the run) and ``side_by_side.png`` into ``out_dir`` (None: the run directory), the run
    replayed in ``world``; ``on_frame(done, total)`` after each frame of the video."""
    run_dir = Path(run_dir)
    out_dir = Path(out_dir or run_dir)
    scenario, problems, run = load_driven(run_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ground = ground_of_file(run_dir / "driven.xml", scenario.lanelet_network, road_tilt(run.settings.backend))
    replay = _replay(scenario, run, world, ground)
    first = run.history.agents[0].id
    step = _instant(run)
    written = []

    chase, birdseye = replay.stills(step, first, STILL)
    for name, image in zip(PICTURES[:2], (chase, birdseye)):      # each whole or not at all (a kill, a full disk)
        data: bytes = imageio.imwrite("<bytes>", image, format="PNG")      # in memory: see `scene2d.render_run`
        written.append(atomic_write_bytes(out_dir / name, data))

    duration = (max(len(t) for t in run.history.driven.values()) - 1) * run.history.dt
    times = np.arange(0.0, duration + 0.5 / fps, 1.0 / fps)
    frames = replay.chase_frames(times, first, VIDEO)
    if on_frame is not None:
        frames = _counted(frames, len(times), on_frame)
    written.append(write_video(out_dir / PICTURES[2], frames, fps))

    written.append(_side_by_side(out_dir / PICTURES[3], chase, scenario, problems, run, step))
    return written


def _counted(frames: Iterator[np.ndarray], total: int, on_frame: Callable[[int, int], None]) -> Iterator[np.ndarray]:
    for done, frame in enumerate(frames, 1):
        yield frame
        on_frame(done, total)


def write_video(path: Path, frames: Iterator[np.ndarray], fps: int) -> Path:
    """An MP4 (H.264, yuv420p: what browsers play) of ``frames``, written whole or not at all.
    ffmpeg says nothing (simgap says what failed); imageio does not look at how ffmpeg ended, so
    the file is read back: a file ffmpeg could not finish (a full disk) raises `OSError`."""
    def encode(tmp: Path) -> None:
        try:
            with imageio.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264", quality=None,
                                    pixelformat="yuv420p", macro_block_size=16, ffmpeg_log_level="quiet",
                                    output_params=["-crf", str(VIDEO_QUALITY), "-preset", "veryfast",
                                                   "-movflags", "+faststart"]) as video:
                for frame in frames:
                    video.append_data(frame)
            finished = _whole_mp4(tmp)
        except OSError as exc:
            if exc.errno is not None:
                raise
            finished = False             # imageio's own: ffmpeg ended before it had every frame
        if not finished:
            space = os.statvfs(tmp.parent)
            full = space.f_bavail * space.f_frsize < 1 << 20
            raise OSError(errno.ENOSPC if full else errno.EIO, "ffmpeg did not finish the video", str(path))

    return atomic_write(path, encode, keep_suffix=True)


def _whole_mp4(path: Path) -> bool:
    """The file is a sequence of MP4 boxes that ends where the file does and holds the movie's
    index (``moov``) and its media (``mdat``): what a finished ffmpeg leaves."""
    names, size, at = set(), path.stat().st_size, 0
    with path.open("rb") as fh:
        while at < size:
            fh.seek(at)
            head = fh.read(16)
            if len(head) < 8:
                return False
            length, name = int.from_bytes(head[:4], "big"), head[4:8]
            if length == 1 and len(head) == 16:          # a 64-bit size follows the name
                length = int.from_bytes(head[8:16], "big")
            if length < 8:
                return False
            names.add(name)
            at += length
    return at == size and {b"moov", b"mdat"} <= names


def _side_by_side(path: Path, image: np.ndarray, scenario, problems, run: RunRecord, step: int) -> Path:
    limits = plot_limits(scenario, margin=10.0)
    width, height = figure_size(limits, width=7.0)
    fig = plt.figure(figsize=(7.0 + 7.0 * image.shape[1] / image.shape[0] * 0.6, max(height, 4.5)))
    ax3d = fig.add_axes([0.0, 0.08, 0.55, 0.84])
    ax3d.imshow(image)
    ax3d.set_axis_off()
    ax3d.set_title(f"3D ({run.history.backend}), t = {step * run.history.dt:.1f} s")
    ax2d = fig.add_axes([0.58, 0.12, 0.40, 0.78])
    rnd = MPRenderer(plot_limits=limits, ax=ax2d)
    draw_scene(rnd, scenario, problems, run, step, f"2D CommonRoad scene, t = {step * run.history.dt:.1f} s")
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110), keep_suffix=True)
    plt.close(fig)
    return path

