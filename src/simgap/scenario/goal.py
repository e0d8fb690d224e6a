"""Goals as CommonRoad defines them: one or more goal states, any one of which counts.

A goal state may bound the time (the planning problem's deadline), the position (any shape, or a
set of lanelets), the orientation and the velocity. `Goal` reads them once from a CommonRoad
`GoalRegion`, checks simgap states against them (orientation compared on the circle, so an
unwrapped heading counts) and explains, after a run, why a goal was missed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from commonroad.geometry.shape import Shape, ShapeGroup
from commonroad.planning.goal import GoalRegion

from simgap.trajectory import State

_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Window:
    """A closed interval [lo, hi]; an unbounded side is +-inf."""

    lo: float
    hi: float

    def contains(self, value: float) -> bool:
        return self.lo - _TOLERANCE <= value <= self.hi + _TOLERANCE

    def describe(self, unit: str) -> str:
        return f"{self.lo:g}-{self.hi:g} {unit}"


def _window(interval) -> Window | None:
    if interval is None:
        return None
    if hasattr(interval, "start"):
        return Window(float(interval.start), float(interval.end))
    return Window(float(interval), float(interval))      # an exact value


def _heading_in(window: Window, yaw: float) -> bool:
    """Orientation on the circle: the heading or any turn of it lies in the window."""
    centre = 0.5 * (window.lo + window.hi)
    closest = yaw + 2 * math.pi * round((centre - yaw) / (2 * math.pi))
    return window.contains(closest)


@dataclass(frozen=True)
class GoalState:
    """One goal state's windows (None: not constrained). ``time`` is in seconds."""

    time: Window | None
    position: Shape | None
    orientation: Window | None
    velocity: Window | None

    def misses(self, state: State) -> list[str]:
        """The windows ``state`` is outside of (empty: this goal state is reached)."""
        out = []
        if self.position is not None and not self.position.contains_point(np.asarray(state.position)):
            out.append("position")
        if self.time is not None and not self.time.contains(state.t):
            out.append("time")
        if self.velocity is not None and not self.velocity.contains(state.v):
            out.append("velocity")
        if self.orientation is not None and not _heading_in(self.orientation, state.yaw):
            out.append("orientation")
        return out

    def centres(self) -> list[np.ndarray]:
        """Centre(s) of the position's shape(s) (empty when the position is free)."""
        if self.position is None:
            return []
        shapes = self.position.shapes if isinstance(self.position, ShapeGroup) else [self.position]
        return [np.asarray(s.center, dtype=float) for s in shapes]


@dataclass(frozen=True)
class Goal:
    """A planning problem's goal: reached when any of its goal states is."""

    states: tuple[GoalState, ...]

    @classmethod
    def of(cls, region: GoalRegion, dt: float) -> "Goal":
        states = []
        for gs in region.state_list:
            time = _window(getattr(gs, "time_step", None))
            states.append(GoalState(
                time=None if time is None else Window(time.lo * dt, time.hi * dt),
                position=getattr(gs, "position", None) if gs.has_value("position") else None,
                orientation=_window(getattr(gs, "orientation", None)) if gs.has_value("orientation") else None,
                velocity=_window(getattr(gs, "velocity", None)) if gs.has_value("velocity") else None))
        return cls(tuple(states))

    def is_reached(self, state: State) -> bool:
        return any(not gs.misses(state) for gs in self.states)

    @property
    def deadline_s(self) -> float | None:
        """The latest end of the goal states' time windows (None: no time bound)."""
        ends = [gs.time.hi for gs in self.states if gs.time is not None]
        if not ends or len(ends) < len(self.states):
            return None
        return max(ends)

    def velocity_window(self) -> Window | None:
        """The first goal state's velocity window (what a planner aims its speed at)."""
        return next((gs.velocity for gs in self.states if gs.velocity is not None), None)

    def time_window(self) -> Window | None:
        return next((gs.time for gs in self.states if gs.time is not None), None)

    def miss_reason(self, driven: Sequence[State]) -> str:
        """Why ``driven`` did not reach the goal, in a user's words: never in the goal's position,
        or there but outside its time / velocity / orientation window (the closest attempt)."""
        best: tuple[int, State, list[str]] | None = None
        for gs in self.states:
            for st in driven:
                missed = gs.misses(st)
                if "position" in missed:
                    continue
                if best is None or len(missed) < len(best[2]):
                    best = (len(missed), st, missed)
        if best is None:
            return "never inside the goal position"
        _, st, missed = best
        parts = []
        for gs in self.states:
            for name, window, value, unit in (("time", gs.time, st.t, "s"), ("velocity", gs.velocity, st.v, "m/s"),
                                              ("orientation", gs.orientation, st.yaw, "rad")):
                if name in missed and window is not None and name not in {p.split(" ")[0] for p in parts}:
                    parts.append(f"{name} {value:.2f} {unit} outside {window.describe(unit)}")
        return f"inside the goal position at t = {st.t:.1f} s but " + ", ".join(parts)
