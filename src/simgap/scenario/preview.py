"""A PNG preview of a scenario: the lanelet network and every planning problem."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from commonroad.planning.planning_problem import PlanningProblemSet  # noqa: E402
from commonroad.scenario.scenario import Scenario  # noqa: E402
from commonroad.visualization.mp_renderer import MPRenderer  # noqa: E402


def plot_limits(scenario: Scenario, margin: float = 8.0) -> list[float]:
    pts = np.concatenate([np.vstack([l.left_vertices, l.right_vertices])
                          for l in scenario.lanelet_network.lanelets])
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    return [float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])]


def figure_size(limits: list[float], width: float = 9.0) -> tuple[float, float]:
    aspect = (limits[3] - limits[2]) / max(limits[1] - limits[0], 1e-6)
    return width, float(np.clip(width * aspect, 2.5, 12.0))


def draw_preview(scenario: Scenario, problems: PlanningProblemSet, path: Path, title: str) -> None:
    limits = plot_limits(scenario)
    rnd = MPRenderer(plot_limits=limits, figsize=figure_size(limits))
    scenario.draw(rnd)
    problems.draw(rnd)
    rnd.render()
    for pid, pp in problems.planning_problem_dict.items():
        rnd.ax.annotate(f"agent {pid}", pp.initial_state.position, xytext=(6, 6), textcoords="offset points",
                        fontsize=9, zorder=100, color="black")
    rnd.ax.set_title(title)
    rnd.ax.set_xlabel("x [m]")
    rnd.ax.set_ylabel("y [m]")
    rnd.f.savefig(path, dpi=90, bbox_inches="tight", format="png")
    plt.close(rnd.f)
