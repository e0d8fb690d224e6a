"""A run's timeline, one agent: why it parted from its plan, against time — lateral and heading
tracking error, steering requested against at the road wheels, acceleration requested against
achieved, each plan's latency, and the sensing error (observed against true position), with every
event of the agent (goal, off road, collision, ...) marked on each panel. It draws what
`simgap.evaluate.timeline.agent_timeline` reads from the record."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from simgap.cosim.history import Event  # noqa: E402
from simgap.evaluate.timeline import AgentTimeline  # noqa: E402
from simgap.report.plots import COLOURS  # noqa: E402

EVENT_COLOURS = {"goal_reached": "#009E73", "off_road": "#D55E00", "collision": "#CC0000", "timeout": "#E69F00",
                 "planner_failure": "#CC79A7", "planner_no_solution": "#CC79A7", "diverged": "#000000"}
NO_CONTROLLER = "no controller: the plans were executed exactly"


def plot_timeline(timeline: AgentTimeline, events: Sequence[Event], path: Path, title: str) -> Path:
    """Five panels over a shared time axis; ``events``: the agent's, drawn as vertical lines."""
    fig, axes = plt.subplots(5, 1, figsize=(8, 9.6), sharex=True)
    tracking, steering, accel, planning, sensing = axes
    _tracking(tracking, timeline)
    _commands(steering, timeline, "steer_requested", "steer_at_wheels", "steering [deg]",
              ("requested (controller)", "at the road wheels"), math.degrees(1.0))
    _commands(accel, timeline, "accel_requested", "accel_achieved", "acceleration [m/s²]",
              ("requested (pedals)", "achieved"), 1.0)
    _planning(planning, timeline)
    _sensing(sensing, timeline)
    for ax in axes:
        ax.grid(alpha=0.3)
        for e in events:
            ax.axvline(e.t, color=EVENT_COLOURS.get(e.kind.value, "#555555"), lw=1.2, ls=":", zorder=1)
    t_end = max([float(timeline.heading_error.t[-1]) if len(timeline.heading_error) else 0.0]
                + [e.t for e in events])
    for e in events:        # named above the top panel, left of the line near the end
        late = e.t > 0.8 * t_end
        tracking.annotate(f"{e.kind.value.replace('_', ' ')} {e.t:.1f} s", (e.t, 1.0),
                          xycoords=("data", "axes fraction"), xytext=(-3 if late else 3, 3),
                          textcoords="offset points", fontsize=7, ha="right" if late else "left",
                          color=EVENT_COLOURS.get(e.kind.value, "#555555"))
    sensing.set_xlabel("time t [s]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _tracking(ax, tl: AgentTimeline) -> None:
    if len(tl.lateral_error):
        ax.plot(tl.lateral_error.t, tl.lateral_error.values, color=COLOURS[1], lw=1.4, label="lateral [m]")
    ax.set_ylabel("lateral error [m]", color=COLOURS[1], fontsize=8)
    twin = ax.twinx()
    if len(tl.heading_error):
        twin.plot(tl.heading_error.t, np.degrees(tl.heading_error.values), color=COLOURS[2], lw=1.2, ls="--",
                  label="heading [deg]")
    twin.set_ylabel("heading [deg]", color=COLOURS[2], fontsize=8)
    handles = ax.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
    if handles:
        ax.legend(handles=handles, fontsize=7, loc="best")
    ax.set_title("driven against the plan in force", fontsize=8, loc="left", pad=12)


def _commands(ax, tl: AgentTimeline, asked: str, had: str, ylabel: str, labels: tuple[str, str],
              scale: float) -> None:
    ax.set_ylabel(ylabel, fontsize=8)
    trace = tl.controls
    if trace is None:
        ax.text(0.5, 0.5, NO_CONTROLLER, transform=ax.transAxes, ha="center", va="center", fontsize=8, color="#555555")
        ax.set_yticks([])
        return
    ax.plot(trace.t, scale * getattr(trace, asked), color=COLOURS[0], lw=1.0, label=labels[0])
    ax.plot(trace.t, scale * getattr(trace, had), color=COLOURS[1], lw=1.4, ls="--", label=labels[1])
    ax.legend(fontsize=7, loc="best")


def _planning(ax, tl: AgentTimeline) -> None:
    ax.set_ylabel("planning [s]", fontsize=8)
    if len(tl.plan_latency):
        ax.step(tl.plan_latency.t, tl.plan_latency.values, where="post", color=COLOURS[2], lw=1.4,
                label="plan latency (until the plan reaches the car)")
    if len(tl.planning_call):
        ax.plot(tl.planning_call.t, tl.planning_call.values, color=COLOURS[0], lw=0.8, marker=".", ms=3,
                label="planning call wall time")
    if len(tl.plan_latency) or len(tl.planning_call):
        ax.legend(fontsize=7, loc="best")
        ax.set_ylim(bottom=0.0)


def _sensing(ax, tl: AgentTimeline) -> None:
    ax.set_ylabel("sensing error [m]", fontsize=8)
    if len(tl.sensing_error):
        ax.plot(tl.sensing_error.t, tl.sensing_error.values, color=COLOURS[3], lw=1.4,
                label="|observed - true| position")
        ax.legend(fontsize=7, loc="best")
        ax.set_ylim(bottom=0.0)
