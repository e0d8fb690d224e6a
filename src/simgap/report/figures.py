"""Figures of a study: the heatmap of a metric over two scenario parameters, the scenario from
above with the planned and driven paths of every fidelity, error box plots, and the runtime
table. Colour maps are perceptually uniform and readable in grayscale (cividis); line plots use
distinct line styles as well as colours."""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from commonroad.visualization.draw_params import MPDrawParams  # noqa: E402
from commonroad.visualization.mp_renderer import MPRenderer  # noqa: E402

from simgap.report.plots import COLOURS, STYLES  # noqa: E402
from simgap.scenario.preview import figure_size, plot_limits  # noqa: E402

if TYPE_CHECKING:
    from simgap.cosim.history import History

HEATMAP_CMAP = "cividis"
PHASE_ORDER = ("planning", "execution", "control", "physics", "monitoring", "io")


def heatmap_grid(points: Sequence[tuple[float, float, float]]) -> tuple[list[float], list[float], np.ndarray]:
    """(x values, y values, grid[y, x]) from (x, y, value) points; missing cells are NaN; several
    values in one cell keep the largest."""
    xs = sorted({p[0] for p in points})
    ys = sorted({p[1] for p in points})
    grid = np.full((len(ys), len(xs)), np.nan)
    for x, y, v in points:
        i, j = ys.index(y), xs.index(x)
        if math.isfinite(v) and not grid[i, j] >= v:
            grid[i, j] = v
    return xs, ys, grid


def plot_heatmap(points: Sequence[tuple[float, float, float]], path: Path, title: str, xlabel: str, ylabel: str,
                 value_label: str, scale: tuple[float, float] | None = None) -> Path:
    """``scale``: (low, high) of the colour map (default: the values' range)."""
    xs, ys, grid = heatmap_grid(points)
    fig, ax = plt.subplots(figsize=(max(5.0, 0.7 * len(xs) + 2.5), max(3.5, 0.45 * len(ys) + 1.8)))
    lo, hi = scale if scale else (None, None)
    image = ax.imshow(grid, cmap=HEATMAP_CMAP, origin="lower", aspect="auto", vmin=lo, vmax=hi)
    ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs])
    ax.set_yticks(range(len(ys)), [f"{y:g}" for y in ys])
    finite = grid[np.isfinite(grid)]
    threshold = (sum(scale) / 2 if scale else (finite.min() + finite.max()) / 2) if len(finite) else 0.0
    for i in range(len(ys)):
        for j in range(len(xs)):
            if np.isfinite(grid[i, j]):
                ax.text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", fontsize=7,
                        color="black" if grid[i, j] > threshold else "white")
    fig.colorbar(image, ax=ax, label=value_label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def heatmap_colour(value: float, lo: float, hi: float) -> tuple[str, str]:
    """Background and text colour of a heatmap cell (cividis), for HTML tables."""
    if not math.isfinite(value):
        return "#ffffff", "#000000"
    u = 0.5 if hi <= lo else (value - lo) / (hi - lo)
    r, g, b, _ = plt.get_cmap(HEATMAP_CMAP)(u)
    text = "#000000" if 0.299 * r + 0.587 * g + 0.114 * b > 0.5 else "#ffffff"
    return f"#{int(r * 255):02x}{int(g * 255):02x}{int(b * 255):02x}", text


def plot_paths_from_above(scenario, runs: Mapping[str, History], path: Path, title: str) -> Path:
    """The road from above with, per fidelity, every agent's driven path (solid, thick) and the
    first plan of every tenth planning cycle (thin)."""
    limits = plot_limits(scenario, margin=8.0)
    width, height = figure_size(limits, width=8.0)
    rnd = MPRenderer(plot_limits=limits, figsize=(width, height))
    params = MPDrawParams()
    params.dynamic_obstacle.draw_icon = False
    params.time_begin = 0
    scenario.lanelet_network.draw(rnd, draw_params=params)
    rnd.render()
    ax = rnd.ax
    for i, (label, run) in enumerate(runs.items()):
        colour, style = COLOURS[i % len(COLOURS)], STYLES[i % len(STYLES)]
        for aid, driven in sorted(run.driven.items()):
            ax.plot(driven.x, driven.y, linestyle=style, color=colour, lw=2.0, zorder=60,
                    label=f"{label}: driven" if aid == min(run.driven) else None)
            for k, plan in enumerate(run.plans.get(aid, [])):
                if k % 10 == 0:
                    ax.plot(plan.x, plan.y, color=colour, lw=0.6, alpha=0.6, zorder=55,
                            label=f"{label}: plans (every 10th)" if aid == min(run.driven) and k == 0 else None)
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=7, frameon=False)
    rnd.f.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(rnd.f)
    return path


def plot_error_boxes(samples: Mapping[str, np.ndarray], path: Path, title: str, ylabel: str) -> Path:
    """Box plots of one error's samples, one box per label (fidelity)."""
    labels = [k for k, v in samples.items() if len(v)]
    fig, ax = plt.subplots(figsize=(max(4.5, 1.4 * len(labels) + 1.5), 3.4))
    if labels:
        ax.boxplot([np.abs(samples[k]) for k in labels], tick_labels=labels, showfliers=True,
                   medianprops={"color": "black"}, flierprops={"markersize": 3})
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    plt.setp(ax.get_xticklabels(), rotation=15, ha="right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def runtime_table(wall_times: Mapping[str, Sequence[float]], phases: Mapping[str, Sequence[Mapping[str, float]]]
                  ) -> list[dict]:
    """Per fidelity: runs, min, max, mean, median, standard deviation of the wall time [s] (the
    paper's Table I), and the mean time of every phase."""
    seen = {p for runs in phases.values() for t in runs for p in t}
    phase_names = [p for p in PHASE_ORDER if p in seen] + sorted(seen - set(PHASE_ORDER))
    rows = []
    for label, times in wall_times.items():
        row = {"fidelity": label, "runs": len(times), "min [s]": min(times), "max [s]": max(times),
               "mean [s]": statistics.fmean(times), "median [s]": statistics.median(times),
               "std [s]": statistics.stdev(times) if len(times) > 1 else 0.0}
        for phase in phase_names:
            values = [t.get(phase, 0.0) for t in phases[label]]
            row[f"{phase} [s]"] = statistics.fmean(values) if values else 0.0
        rows.append(row)
    return rows
