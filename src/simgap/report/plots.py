"""Line plots of one scenario across fidelities: lateral offset d over arc length s, and speed v
over time t (the paper's two line plots), with the road sections shaded; on d over s the lane
and road edges and every event of each run (goal, off road, collision, ...) where it happened."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from simgap.evaluate.route_edges import EventPlace, RouteEdges  # noqa: E402
from simgap.trajectory import Trajectory  # noqa: E402

# Okabe–Ito colours, plus distinct line styles so the plots read in grayscale too
COLOURS = ["#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00"]
STYLES = ["-", "--", "-.", ":", (0, (5, 1)), (0, (3, 1, 1, 1))]
SECTION_SHADES = {"curve": "#d9d9d9", "clothoid": "#efefef", "junction": "#bdbdbd"}
# a marker per kind of event (the run's colour says whose)
EVENT_MARKERS = {"goal_reached": "*", "off_road": "X", "collision": "P", "planner_failure": "v", "timeout": "s",
                 "diverged": "D", "planner_no_solution": "1", "damage": "d"}
EDGE_STYLES = {"lane": dict(color="#7f7f7f", lw=0.8, ls="--"), "road": dict(color="#3f3f3f", lw=1.4, ls="-")}


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
                  section_kinds: tuple[np.ndarray, np.ndarray] | None = None, edges: RouteEdges | None = None,
                  events: Mapping[str, Sequence[EventPlace]] | None = None) -> Path:
    """``curves``: label -> (s, d). ``section_kinds``: (s grid, kind per s) for shading. ``edges``:
    the route's lane and road edges; ``events``: label -> the run's events of this agent, marked
    where they happened (in the label's colour)."""
    fig, ax = plt.subplots(figsize=(8, 3.6))
    if section_kinds is not None:
        _shade_sections(ax, *section_kinds)
    for i, (label, (s, d)) in enumerate(curves.items()):
        ax.plot(s, d, linestyle=STYLES[i % 6], color=COLOURS[i % 6], lw=1.6, label=label)
    ax.axhline(0.0, color="grey", lw=0.6)
    if edges is not None:
        _draw_edges(ax, edges, curves, events or {})
    for i, (label, places) in enumerate((events or {}).items()):
        colour = COLOURS[list(curves).index(label) % 6] if label in curves else COLOURS[i % 6]
        for place in places:
            if place.s is None or place.d is None:
                continue
            kind = place.event.kind.value
            ax.plot(place.s, place.d, marker=EVENT_MARKERS.get(kind, "o"), color=colour, ms=11, mec="white",
                    mew=0.8, ls="none", zorder=5)
            ax.annotate(f"{kind.replace('_', ' ')} {place.event.t:.1f} s", (place.s, place.d), xytext=(4, 6 + 10 * i),
                        textcoords="offset points", fontsize=7, color=colour)
    return _finish(fig, ax, path, "arc length s along the route centre line [m]", "lateral offset d [m]", title)


def _draw_edges(ax, edges: RouteEdges, curves: Mapping[str, tuple[np.ndarray, np.ndarray]],
                events: Mapping[str, Sequence[EventPlace]]) -> None:
    """Lane edges dashed, road edges solid, over the stretch of s of the curves and events; the d
    axis spans the curves, the events and the edges."""
    reached = [float(np.nanmax(s)) for s, _ in curves.values() if len(s)]
    reached += [p.s for ps in events.values() for p in ps if p.s is not None]
    s_max = max(reached, default=float(edges.s[-1]))
    keep = edges.s <= s_max + 5.0
    for kind, (left, right) in (("lane", (edges.lane_left, edges.lane_right)),
                                ("road", (edges.road_left, edges.road_right))):
        style = EDGE_STYLES[kind]
        ax.plot(edges.s[keep], left[keep], label=f"{kind} edges", **style)
        ax.plot(edges.s[keep], right[keep], **style)
    shown = [d for _, d in curves.values() if len(d)] + [edges.road_left[keep], edges.road_right[keep]]
    shown += [np.array([p.d for ps in events.values() for p in ps if p.d is not None])]
    values = np.concatenate([np.asarray(v, dtype=float) for v in shown])
    values = values[np.isfinite(values)]
    if len(values):
        ax.set_ylim(float(values.min()) - 0.4, float(values.max()) + 0.4)


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


def plot_waterfall(steps: Sequence[tuple[str, float, bool]], total: float, path: Path, title: str,
                   unit: str = "m") -> Path:
    """A waterfall of shares that add up to ``total``: each step (name, share, whether restoring it
    alone fixes the outcome) a bar from where the shares before it ended, the total a bar from 0."""
    fig, ax = plt.subplots(figsize=(8, 0.55 * (len(steps) + 1) + 1.2))
    start = 0.0
    names = [name for name, _, _ in steps] + ["gap"]
    for i, (_, share, fixes) in enumerate(steps):
        colour = "#d55e00" if share >= 0 else "#009e73"
        ax.barh(i, share, left=start, color=colour, hatch="//" if fixes else None, edgecolor="black", lw=0.6)
        ax.text(max(start, start + share), i, f" {share:+.3f} {unit}" + ("  restoring it alone fixes the outcome"
                                                                         if fixes else ""), va="center", fontsize=8)
        start += share
    ax.barh(len(steps), total, color="#0072b2", edgecolor="black", lw=0.6)
    ax.text(max(total, 0.0), len(steps), f" {total:.3f} {unit}", va="center", fontsize=8)
    ax.set_yticks(range(len(names)), names)
    ax.invert_yaxis()
    ax.axvline(0.0, color="black", lw=0.8)
    lo, hi = ax.get_xlim()
    ax.set_xlim(lo, hi + 0.6 * (hi - lo))        # room for the labels
    ax.set_xlabel(f"share of the gap [{unit}]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
