"""Line plots of one scenario across fidelities: lateral offset d over arc length s, and speed v
over time t (the paper's two line plots), with the road sections shaded."""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from simgap.trajectory import Trajectory  # noqa: E402

# Okabe–Ito colours, plus distinct line styles so the plots read in grayscale too
COLOURS = ["#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00"]
STYLES = ["-", "--", "-.", ":", (0, (5, 1)), (0, (3, 1, 1, 1))]
SECTION_SHADES = {"curve": "#d9d9d9", "clothoid": "#efefef", "junction": "#bdbdbd"}


def _shade_sections(ax, s: np.ndarray, kinds: np.ndarray | None) -> None:
    if kinds is None or len(s) == 0:
        return
    start = 0
    labelled = set()
    for i in range(1, len(s) + 1):
        if i == len(s) or kinds[i] != kinds[start]:
            kind = str(kinds[start])
            if kind in SECTION_SHADES:
                ax.axvspan(s[start], s[i - 1], color=SECTION_SHADES[kind], zorder=0,
                           label=f"{kind} section" if kind not in labelled else None)
                labelled.add(kind)
            start = i


def plot_d_over_s(curves: Mapping[str, tuple[np.ndarray, np.ndarray]], path: Path, title: str,
                  section_kinds: tuple[np.ndarray, np.ndarray] | None = None) -> Path:
    """``curves``: label -> (s, d). ``section_kinds``: (s grid, kind per s) for shading."""
    fig, ax = plt.subplots(figsize=(8, 3.6))
    if section_kinds is not None:
        _shade_sections(ax, *section_kinds)
    for i, (label, (s, d)) in enumerate(curves.items()):
        ax.plot(s, d, linestyle=STYLES[i % 6], color=COLOURS[i % 6], lw=1.6, label=label)
    ax.axhline(0.0, color="grey", lw=0.6)
    return _finish(fig, ax, path, "arc length s along the route centre line [m]", "lateral offset d [m]", title)


def plot_v_over_t(trajectories: Mapping[str, Trajectory], path: Path, title: str) -> Path:
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for i, (label, traj) in enumerate(trajectories.items()):
        ax.plot(traj.t, traj.v, linestyle=STYLES[i % 6], color=COLOURS[i % 6], lw=1.6, label=label)
    return _finish(fig, ax, path, "time t [s]", "speed v [m/s]", title)


def _finish(fig, ax, path: Path, xlabel: str, ylabel: str, title: str) -> Path:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
