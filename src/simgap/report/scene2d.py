"""The 2D CommonRoad picture of a run: the final scene with every agent's driven path, and an
animation of the run, drawn with commonroad-io's renderer from the run's ``driven.xml``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import imageio.v2 as imageio  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from commonroad.common.file_reader import CommonRoadFileReader  # noqa: E402
from commonroad.visualization.draw_params import MPDrawParams  # noqa: E402
from commonroad.visualization.mp_renderer import MPRenderer  # noqa: E402

from simgap.errors import InputError  # noqa: E402
from simgap.files import atomic_write, atomic_write_bytes  # noqa: E402
from simgap.record import RunRecord, read_run  # noqa: E402
from simgap.scenario.preview import figure_size, plot_limits  # noqa: E402

# colour-blind-safe (Okabe–Ito), distinguishable in grayscale by line style as well
AGENT_COLOURS = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9"]
LINE_STYLES = ["-", "--", "-.", ":"]
PICTURES = ("scene.png", "run.gif")          # what `render_run` writes (the GIF with its animation)


def load_driven(run_dir: Path):
    """The driven scenario of a run (``driven.xml``), its planning problems, and the run."""
    xml = run_dir / "driven.xml"
    if not xml.exists():
        raise InputError("run has no driven.xml to draw", file=run_dir)
    scenario, problems = CommonRoadFileReader(str(xml)).open()
    return scenario, problems, read_run(run_dir)


def draw_scene(rnd: MPRenderer, scenario, problems, run: RunRecord, step: int, title: str) -> None:
    params = MPDrawParams()
    params.time_begin = step
    params.dynamic_obstacle.draw_icon = True
    params.dynamic_obstacle.show_label = False
    params.dynamic_obstacle.trajectory.draw_trajectory = False
    scenario.draw(rnd, draw_params=params)
    problems.draw(rnd)
    rnd.render()
    ax = rnd.ax
    for i, (aid, traj) in enumerate(sorted(run.history.driven.items())):
        k = min(step + 1, len(traj))
        ax.plot(traj.x[:k], traj.y[:k], LINE_STYLES[i % 4], color=AGENT_COLOURS[i % 6], lw=2.0,
                zorder=60, label=f"agent {aid} ({run.history.agents[i].outcome})")
        ax.annotate(str(aid), (traj.x[k - 1], traj.y[k - 1]), xytext=(5, 5), textcoords="offset points",
                    fontsize=9, fontweight="bold", color=AGENT_COLOURS[i % 6], zorder=70)
    ax.set_title(title)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3, fontsize=8, frameon=False)


def render_run(run_dir: str | Path, out_dir: str | Path | None = None, frame_every: int = 3,
               animation: bool = True, on_frame: Callable[[int, int], None] = lambda done, total: None) -> list[Path]:
    """Write ``scene.png`` (final scene and driven paths) and, with ``animation``, ``run.gif``
    (real time, one frame every ``frame_every`` steps) into ``out_dir``; ``on_frame(done, total)``
    after each frame of the animation."""
    run_dir = Path(run_dir)
    out_dir = Path(out_dir or run_dir)
    scenario, problems, run = load_driven(run_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    limits = plot_limits(scenario, margin=10.0)
    size = figure_size(limits, width=10.0)
    last = max(len(t) for t in run.history.driven.values()) - 1

    rnd = MPRenderer(plot_limits=limits, figsize=size)
    draw_scene(rnd, scenario, problems, run, last,
          f"{run.scenario_id} — {run.history.backend}: driven paths, t = {last * run.history.dt:.1f} s")
    png = atomic_write(out_dir / PICTURES[0], lambda tmp: rnd.f.savefig(tmp, dpi=110, bbox_inches="tight"),
                       keep_suffix=True)                # whole or not at all (a kill, a full disk)
    plt.close(rnd.f)
    if not animation:
        return [png]

    gif = out_dir / PICTURES[1]
    frames = []
    steps = list(range(0, last, frame_every)) + [last]
    for step in steps:
        rnd = MPRenderer(plot_limits=limits, figsize=(size[0] * 0.7, size[1] * 0.7))
        draw_scene(rnd, scenario, problems, run, step, f"{run.scenario_id} — {run.history.backend}, t = {step * run.history.dt:.1f} s")
        rnd.f.canvas.draw()
        frames.append(np.asarray(rnd.f.canvas.buffer_rgba())[..., :3].copy())
        plt.close(rnd.f)
        on_frame(len(frames), len(steps))
    # encoded in memory, then written: imageio's writer flushes a file as it closes and, on a full disk,
    # again as it is collected, where the error reaches the user as a traceback after simgap's own line
    data = imageio.mimwrite("<bytes>", frames, format="GIF", duration=1000.0 * frame_every * run.history.dt, loop=0)
    atomic_write_bytes(gif, data)
    return [png, gif]
