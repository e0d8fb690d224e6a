"""The frenetix core's cost order, evaluated lazily: the core fills, checks and costs only the
samples a cycle looks at.

A cycle looks at a handful of samples in cost order (the first that passes the road, traffic and
limit checks wins), yet the core fills Cartesian coordinates for every sample before it can sort
them, and filling is four fifths of its work. `cost_floor` computes, from the sampling matrix
alone, a lower bound of each sample's cost: the core's own cost terms (`CostWeights`) on the
same polynomials and the same points, with the reference curvature interpolated the way the core
does, less a rounding margin. `CostOrder` hands out the feasible samples in the core's order
(cheapest first) by evaluating them in the core in growing batches, cheapest floor first: a sample
is handed out once its cost is at most the floor of every sample not yet evaluated, so no
unevaluated sample can come before it. The order is the core's, sample for sample (equal costs
aside); only the work changes. Terms the floor leaves out (orientation offset, acceleration) are
non-negative, which keeps it a lower bound; a sample whose cost comes out below its floor
(`CostOrder.floor_misses`) means the replica is wrong, and every remaining sample is evaluated.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from simgap.planning.sampling import END_OFFSET, END_SPEED, END_TIME, LATERAL_START, LONGITUDINAL_START
from simgap.planning.settings import CostWeights

# the core's thresholds (FillCoordinates): below _EPS a speed is zero; at or below _MOVING a
# sample is taken as standing (heading held, speed at most _STANDING_SPEED for our bound)
_EPS, _MOVING, _STANDING_SPEED = 1e-5, 1e-3, 1e-2
# relative and absolute margin of the floor below the replicated cost (rounding)
_MARGIN_REL, _MARGIN_ABS = 1e-7, 1e-9
FIRST_BATCH = 16


@dataclass(frozen=True)
class CoreReference:
    """The core's reference tables: arc length of its vertices and curvature there."""

    pos: np.ndarray
    kappa: np.ndarray


def _longitudinal(matrix: np.ndarray) -> np.ndarray:
    """Quartic coefficients (n, 5): start position, speed, acceleration; end speed and
    acceleration at the end time."""
    s0, v0, a0 = matrix[:, LONGITUDINAL_START].T
    v1, a1 = matrix[:, END_SPEED], matrix[:, END_SPEED + 1]
    T = matrix[:, END_TIME]
    c2 = 0.5 * a0
    A = v1 - v0 - 2 * c2 * T
    B = a1 - 2 * c2
    c4 = (0.5 * B * T - A) / (2 * T**3)
    c3 = (B - 12 * c4 * T**2) / (6 * T)
    return np.stack([s0, v0, c2, c3, c4], axis=1)


def _lateral(matrix: np.ndarray, duration: np.ndarray) -> np.ndarray:
    """Quintic coefficients (n, 6) from the start state to the end offset at rest."""
    d0, dd0, ddd0 = matrix[:, LATERAL_START].T
    d1, dd1, ddd1 = matrix[:, END_OFFSET], matrix[:, END_OFFSET + 1], matrix[:, END_OFFSET + 2]
    T = duration
    c2 = 0.5 * ddd0
    h = d1 - (d0 + dd0 * T + c2 * T**2)
    hv = dd1 - (dd0 + 2 * c2 * T)
    ha = ddd1 - 2 * c2
    c3 = 10 * h / T**3 - 4 * hv / T**2 + ha / (2 * T)
    c4 = -15 * h / T**4 + 7 * hv / T**3 - ha / T**2
    c5 = 6 * h / T**5 - 3 * hv / T**4 + ha / (2 * T**3)
    return np.stack([d0, dd0, c2, c3, c4, c5], axis=1)


def _polyval(c: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Value and first derivative of polynomials ``c`` (n, k) at times ``t`` (n, m)."""
    value = np.zeros_like(t) + c[:, -1:]
    slope = np.zeros_like(t)
    for k in range(c.shape[1] - 2, -1, -1):
        slope = slope * t + value
        value = value * t + c[:, k:k + 1]
    return value, slope


def _jerk_cost(c: np.ndarray, dt: float) -> np.ndarray:
    """The core's jerk term: the root of the squared jerk integrated over the first ``dt``."""
    c3, c4 = c[:, 3], c[:, 4]
    integral = 36 * c3 * c3 * dt + 144 * c3 * c4 * dt**2 + 192 * c4 * c4 * dt**3
    if c.shape[1] > 5:
        c5 = c[:, 5]
        integral = integral + 240 * c3 * c5 * dt**3 + 720 * c4 * c5 * dt**4 + 720 * c5 * c5 * dt**5
    return np.sqrt(np.maximum(integral, 0.0))


def _on_grid(c: np.ndarray, dt: float, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Value and first derivative of polynomials ``c`` (n, k) at 0, dt, ..., (points - 1) dt."""
    k = c.shape[1]
    t = dt * np.arange(points)
    powers = t[None, :] ** np.arange(k)[:, None]                        # (k, points)
    slopes = np.zeros_like(powers)
    slopes[1:] = np.arange(1, k)[:, None] * powers[:-1]
    return c @ powers, c @ slopes


def _profiles(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``matrix`` with the longitudinal profile of the row before them share it: (the first
    row of each run of equal profiles, each row's run)."""
    columns = [0, END_TIME, *range(LONGITUDINAL_START.start, LONGITUDINAL_START.stop), END_SPEED, END_SPEED + 1]
    lon = matrix[:, columns]
    new = np.ones(len(matrix), dtype=bool)
    new[1:] = (lon[1:] != lon[:-1]).any(axis=1)
    return np.flatnonzero(new), np.cumsum(new) - 1


def cost_floor(matrix: np.ndarray, dt: float, points: int, low_velocity: bool, desired_speed: float,
               weights: CostWeights, reference: CoreReference) -> np.ndarray:
    """Per row of the sampling ``matrix``: a lower bound of the cost the core gives the sample
    (``points`` states from the start time, the core's ``FillCoordinates`` in ``low_velocity``
    mode and its cost functions at ``weights``, the velocity offset towards ``desired_speed``).
    Rows the replica does not cover get 0. The longitudinal profile (and the reference curvature
    along it) is computed once for rows in a run that share it (the lateral offsets of one end time
    and speed, as `sampling_matrix` orders them)."""
    n = len(matrix)
    T = matrix[:, END_TIME] - matrix[:, 0]
    actual = np.floor(1 + T / dt).astype(int)        # the core's int(1 + horizon / dt)
    covered = (matrix[:, 0] == 0.0) & (actual >= 2) & (actual <= points)
    first, run = _profiles(matrix)
    last = np.clip(actual[first] - 1, 0, points - 1)[:, None]
    beyond = np.arange(points)[None, :] - last           # > 0: the core holds the end speed and offset
    held = beyond > 0
    lon = _longitudinal(matrix[first])
    s, ss = _on_grid(lon, dt, points)
    s_last, ss_last = np.take_along_axis(s, last, 1), np.take_along_axis(ss, last, 1)
    ss_last = np.where(np.abs(ss_last) < _EPS, 0.0, ss_last)
    if held.any():
        s = np.where(held, s_last + beyond * dt * ss_last, s)
        ss = np.where(held, ss_last, ss)
    k_r = np.interp(s, reference.pos, reference.kappa)[run]
    if low_velocity:                       # the lateral polynomial runs over arc length
        s_end, _ = _polyval(lon, T[first][:, None])
        duration = (s_end[:, 0] - lon[:, 0])[run]
        duration = np.where(duration > 0.0, duration, T)
        lat = _lateral(matrix, duration)
        d, dd = _polyval(lat, (s - s[:, :1])[run])
    else:
        lat = _lateral(matrix, T)
        d, dd = _on_grid(lat, dt, points)
    held, ss = held[run], ss[run]
    if held.any():
        d = np.where(held, np.take_along_axis(d, last[run], 1), d)
        dd = np.where(held, 0.0, dd)
    if low_velocity:
        standing = None
        slope = dd
    else:
        standing = ss <= _MOVING
        slope = dd / np.where(standing, 1.0, ss)
    v = np.abs(ss * (1.0 - k_r * d)) * np.sqrt(1.0 + slope * slope)
    gap = v - desired_speed
    if standing is not None and standing.any():
        gap = np.where(standing, np.maximum(desired_speed - _STANDING_SPEED, 0.0), gap)
    floor = np.zeros(n)
    if weights.velocity_offset > 0:
        floor += weights.velocity_offset * np.sqrt(np.einsum("ij,ij->i", gap, gap))
    if weights.distance_to_reference_path > 0:
        tail = d[:, points - points // 2:]
        floor += weights.distance_to_reference_path * np.sqrt(np.einsum("ij,ij->i", tail, tail))
    if weights.longitudinal_jerk > 0:
        floor += weights.longitudinal_jerk * _jerk_cost(lon, dt)[run]
    if weights.lateral_jerk > 0:
        floor += weights.lateral_jerk * _jerk_cost(lat, dt)
    floor = floor * (1.0 - _MARGIN_REL) - _MARGIN_ABS
    return np.where(covered & np.isfinite(floor), np.maximum(floor, 0.0), 0.0)


# evaluate(rows) -> the feasible samples among those rows of the matrix: (cost, row, sample)
Evaluate = Callable[[np.ndarray], list[tuple[float, int, object]]]


class CostOrder:
    """The feasible samples in the core's cost order, evaluated by ``evaluate`` in batches
    (from `FIRST_BATCH`, doubling) in the order of their ``floor``."""

    def __init__(self, floor: np.ndarray, evaluate: Evaluate):
        self._floor = floor
        self._order = np.argsort(floor, kind="stable")
        self._evaluate = evaluate
        self._next = 0
        self._batch = FIRST_BATCH
        self._ready: list[tuple[float, int, object]] = []
        self.evaluated = 0
        self.feasible = 0
        self.floor_misses = 0

    @property
    def _next_floor(self) -> float:
        return float(self._floor[self._order[self._next]]) if self._next < len(self._order) else math.inf

    def take(self, n: int) -> list[object]:
        """The next ``n`` feasible samples in cost order (fewer when none are left)."""
        out: list[object] = []
        while len(out) < n:
            while self._next < len(self._order) and (not self._ready or self._ready[0][0] > self._next_floor
                                                     or self.floor_misses):
                self._evaluate_batch()
            if not self._ready:
                break
            out.append(heapq.heappop(self._ready)[2])
        return out

    def _evaluate_batch(self) -> None:
        rows = self._order[self._next:self._next + self._batch]
        self._next += len(rows)
        self._batch *= 2
        self.evaluated += len(rows)
        for cost, row, sample in self._evaluate(rows):
            self.feasible += 1
            if cost < self._floor[row]:
                self.floor_misses += 1
                self._batch = len(self._order)      # the floor is wrong here: the rest is evaluated at once
            heapq.heappush(self._ready, (cost, int(row), sample))
