"""Goals as CommonRoad defines them: one or more goal states, any one of which counts.

A goal state may bound the time (the planning problem's deadline), the position (any shape, or a
set of lanelets), the orientation and the velocity. `Goal` reads them once from a CommonRoad
`GoalRegion`, checks simgap states against them (orientation compared on the circle, so an
unwrapped heading counts) and explains, after a run, why a goal was missed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely
from commonroad.geometry.shape import Circle, Shape, ShapeGroup
from commonroad.planning.goal import GoalRegion
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

from simgap.trajectory import State

_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Window:
    """A closed interval [lo, hi]; an unbounded side is +-inf."""

    lo: float
    hi: float

    def contains(self, value):
        """``value`` (a number or an array of them) inside the window, within a tolerance."""
        return (value >= self.lo - _TOLERANCE) & (value <= self.hi + _TOLERANCE)

    def describe(self, unit: str) -> str:
        return f"{self.lo:g}-{self.hi:g} {unit}"


def _window(interval) -> Window | None:
    if interval is None:
        return None
    if hasattr(interval, "start"):
        return Window(float(interval.start), float(interval.end))
    return Window(float(interval), float(interval))      # an exact value


def area_of(shape: Shape) -> BaseGeometry:
    """``shape`` as a shapely geometry (a circle as its disc, a shape group as the union)."""
    if isinstance(shape, ShapeGroup):
        return shapely.union_all([area_of(s) for s in shape.shapes])
    if isinstance(shape, Circle):
        return Point(*np.asarray(shape.center, dtype=float)).buffer(float(shape.radius))
    return shape.shapely_object


def _heading_in(window: Window, yaw):
    """Orientation on the circle: the heading (or each of an array of them) or any turn of it lies
    in the window."""
    centre = 0.5 * (window.lo + window.hi)
    closest = yaw + 2 * math.pi * np.round((centre - yaw) / (2 * math.pi))
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

    def reached_at(self, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray,
                   v: np.ndarray) -> np.ndarray:
        """`misses` for many states at once (arrays of one shape: time, centre, heading, speed):
        True where every window holds (the position's boundary does not count)."""
        ok = np.ones(np.shape(x), dtype=bool)
        for window, value in ((self.time, t), (self.velocity, v)):
            if window is not None:
                ok &= window.contains(value)
        if self.orientation is not None:
            ok &= _heading_in(self.orientation, yaw)
        if self.position is not None and ok.any():
            ok[ok] = shapely.contains_xy(self._area, x[ok], y[ok])
        return ok

    @cached_property
    def _area(self) -> BaseGeometry:
        area = area_of(self.position)
        shapely.prepare(area)
        return area

    def distance_from_position(self, x: float, y: float) -> float:
        """How far [m] the point (x, y) lies from the goal position (0 inside, or when it is free)."""
        if self.position is None:
            return 0.0
        return float(self._area.distance(Point(x, y)))

    def describe_misses(self, state: State, missed: list[str]) -> str:
        """The windows in ``missed`` with ``state``'s values, in a user's words."""
        parts = []
        if "position" in missed:
            parts.append(f"position {self.distance_from_position(state.x, state.y):.1f} m from the goal area")
        for name, window, value, unit in (("velocity", self.velocity, state.v, "m/s"),
                                          ("orientation", self.orientation, state.yaw, "rad"),
                                          ("time", self.time, state.t, "s")):
            if name in missed and window is not None:
                parts.append(f"{name} {value:.2f} {unit} outside {window.describe(unit)}")
        return ", ".join(parts)

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
    def of(cls, region: GoalRegion, dt: float) -> Goal:
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

    def reached_at(self, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray,
                   v: np.ndarray) -> np.ndarray:
        """`is_reached` for many states at once (see `GoalState.reached_at`)."""
        ok = np.zeros(np.shape(x), dtype=bool)
        for gs in self.states:
            ok |= gs.reached_at(t, x, y, yaw, v)
        return ok

    def distance_from_position(self, x: float, y: float) -> float | None:
        """How far [m] the point (x, y) lies from the nearest goal state's position (None: no goal
        state bounds the position)."""
        distances = [gs.distance_from_position(x, y) for gs in self.states if gs.position is not None]
        return min(distances) if distances else None

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
        """Why ``driven`` did not reach the goal, in a user's words, judged where it counts: for a
        goal state with a time window, at the window (the state in it that came closest, and the
        position, velocity or orientation that failed there, with its value); without one, at the
        closest attempt inside the goal position. Of several goal states, the closest miss."""
        best: tuple[tuple[int, float], str] | None = None
        for gs in self.states:
            judged = _judged(gs, driven)
            if judged is not None and (best is None or judged[0] < best[0]):
                best = judged
        return best[1] if best is not None else "never inside the goal position"


def _judged(gs: GoalState, driven: Sequence[State]) -> tuple[tuple[int, float], str] | None:
    """(rank, reason) of ``driven``'s closest miss of ``gs`` (lower rank: closer; None: nothing to say)."""
    def closest(states: Sequence[State], ignore: str) -> tuple[tuple[int, float], State, list[str]]:
        scored = []
        for st in states:
            missed = [m for m in gs.misses(st) if m != ignore]
            scored.append(((len(missed), gs.distance_from_position(st.x, st.y)), st, missed))
        return min(scored, key=lambda item: item[0])

    if gs.time is not None:
        in_window = [st for st in driven if gs.time.contains(st.t)]
        window = gs.time.describe("s")
        if not in_window:
            if not driven or driven[-1].t >= gs.time.lo:
                return None
            ended = f"the run ended at t = {driven[-1].t:.1f} s, before the time window {window} opened"
            inside = next((st for st in driven if "position" not in gs.misses(st)), None)
            if inside is None:
                return (9, math.inf), f"never inside the goal position; {ended}"
            return (1, 0.0), f"inside the goal position at t = {inside.t:.1f} s but {ended}"
        rank, st, missed = closest(in_window, "time")
        if "position" in missed and all("position" in gs.misses(other) for other in driven):
            # the closest approach, whatever else it missed there
            gap, t = min((gs.distance_from_position(other.x, other.y), other.t) for other in in_window)
            return (rank[0], gap), (f"never inside the goal position ({gap:.1f} m from it at t = {t:.1f} s, "
                                    f"in the time window {window})")
        where = "outside the goal position:" if "position" in missed else "inside the goal position but"
        return rank, f"in the time window {window} at t = {st.t:.1f} s {where} {gs.describe_misses(st, missed)}"
    in_position = [st for st in driven if "position" not in gs.misses(st)]
    if not in_position:
        return None
    rank, st, missed = closest(in_position, "")
    return rank, f"inside the goal position at t = {st.t:.1f} s but {gs.describe_misses(st, missed)}"
