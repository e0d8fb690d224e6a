"""Smoothing a route's centre line into a reference path (`smooth_centre_line`): extended
straight beyond both ends, Gaussian-smoothed, more widely where that keeps it near the centre line
(`_widened_smoothing`), and resampled with its heading and curvature; and the centre line moved
over onto a goal area beside it (`towards_goal`). `planning.reference_path` makes the result a
`ReferencePath`."""

from __future__ import annotations

import math

import numpy as np
import shapely
from commonroad.planning.planning_problem import PlanningProblem
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from simgap.planning.lane_change import lane_change_length
from simgap.polyline import Polyline, arc_length, heading_and_curvature, nearest, resample, without_duplicates
from simgap.scenario.goal import area_of

_FINE_STEP_M = 0.1
# the path is smoothed more widely (these multiples of the smoothing) where that keeps it within
# DEVIATION_TOLERANCE_M of the route's centre line (`_widened_smoothing`)
WIDER_SMOOTHING = (1.0, 2.0, 4.0, 8.0, 16.0)
DEVIATION_TOLERANCE_M = 0.1
# ... and within KINK_DEVIATION_TOLERANCE_M where the curvature changes faster than KINK_RAMP [1/m^2]
KINK_RAMP = 0.03
KINK_DEVIATION_TOLERANCE_M = 0.4
LEVEL_BLEND_M = 4.0
# a goal area the route's centre line passes less deep inside than this is aimed at (`towards_goal`),
# when its centre lies this far beside the line; the move over takes at least this long [m]
GOAL_DEPTH_M = 0.5
GOAL_BESIDE_MIN_M = 0.3
GOAL_BESIDE_MAX_M = 2.5
GOAL_SHIFT_MIN_RAMP_M = 10.0
GOAL_SHIFT_MAX_TURN_RAD = 0.2       # ... along a line that turns at most this much over the move
# ... arriving with the goal's heading when it turns at most this from the line's (a lane change),
# the sideways slope easing out over this distance beyond the goal [rad], [m]
GOAL_HEADING_MAX_RAD = 0.3
GOAL_RUN_OUT_M = 10.0


def _end_direction(xy: np.ndarray, at_end: bool, over_m: float = 2.0) -> np.ndarray:
    """Unit direction of the first (last) ``over_m`` metres of a polyline."""
    s = arc_length(xy)
    if at_end:
        k = int(np.searchsorted(s, s[-1] - over_m, side="right")) - 1
        vec = xy[-1] - xy[max(0, min(k, len(xy) - 2))]
    else:
        k = int(np.searchsorted(s, over_m))
        vec = xy[min(max(k, 1), len(xy) - 1)] - xy[0]
    return vec / np.linalg.norm(vec)


def _extend(xy: np.ndarray, back_m: float, forward_m: float, step: float) -> np.ndarray:
    parts = []
    if back_m > 0:
        d = _end_direction(xy, at_end=False)
        dist = np.arange(np.ceil(back_m / step), 0, -1) * step
        parts.append(xy[0] - dist[:, None] * d)
    parts.append(xy)
    if forward_m > 0:
        d = _end_direction(xy, at_end=True)
        dist = np.arange(1, np.ceil(forward_m / step) + 1) * step
        parts.append(xy[-1] + dist[:, None] * d)
    return np.vstack(parts)


def _gaussian_smooth(xy: np.ndarray, sigma_samples: float) -> np.ndarray:
    """Gaussian smoothing along the polyline; the ends are padded by point reflection so that
    straight ends stay straight (a Gaussian keeps linear functions unchanged)."""
    if sigma_samples <= 0:
        return xy
    half = int(np.ceil(4 * sigma_samples))
    half = min(half, len(xy) - 1)
    k = np.arange(-half, half + 1)
    kernel = np.exp(-0.5 * (k / sigma_samples) ** 2)
    kernel /= kernel.sum()
    head = 2 * xy[0] - xy[half:0:-1]
    tail = 2 * xy[-1] - xy[-2:-half - 2:-1]
    padded = np.vstack([head, xy, tail])
    return np.stack([np.convolve(padded[:, j], kernel, mode="valid") for j in range(2)], axis=1)


def _widened_smoothing(xy: np.ndarray, sigma_m: float, tolerance_m: float, kink_tolerance_m: float) -> np.ndarray:
    """``xy`` (a polyline `_FINE_STEP_M` apart) Gaussian-smoothed with ``sigma_m``, and more widely
    (`WIDER_SMOOTHING`) wherever the wider smoothing stays within ``tolerance_m`` of the polyline
    — ``kink_tolerance_m`` where the narrow smoothing's curvature changes faster than `KINK_RAMP`.

    Lanelets of recorded maps meet at small angles (a degree or two where two centre lines join);
    smoothed over a metre such a kink asks for a steering rate that only a slow car has, and the
    speed profile would brake for it on a straight highway. A driver rounds it off over tens of
    metres within a hand's breadth of the lane centre, as this does; a curve's real shape keeps
    the narrow smoothing (a wide one would cut it by more than the tolerance). Where a turn's
    curvature sets in within a metre or two (faster than `KINK_RAMP`: a recorded turn drawn with a
    few chords, a tight arc joined to a straight without a transition), which the steering rate
    follows only below about 4 m/s, the driver eases the bend over a few metres, up to
    ``kink_tolerance_m`` off the centre line."""
    sigmas = [sigma_m * factor for factor in WIDER_SMOOTHING]
    levels = [_gaussian_smooth(xy, s / _FINE_STEP_M) for s in sigmas]
    ramp = np.abs(np.gradient(heading_and_curvature(levels[0])[2], _FINE_STEP_M))
    reach = 2 * int(np.ceil(2 * sigmas[-1] / _FINE_STEP_M)) + 1
    tolerance = np.where(maximum_filter1d(ramp, size=reach, mode="nearest") > KINK_RAMP, kink_tolerance_m, tolerance_m)
    allowed = np.zeros(len(xy))
    ok = np.ones(len(xy), dtype=bool)
    for j in range(1, len(sigmas)):
        deviation = np.hypot(*(levels[j] - xy).T)
        reach = 2 * int(np.ceil(2 * sigmas[j] / _FINE_STEP_M)) + 1
        ok &= maximum_filter1d(deviation, size=reach, mode="nearest") <= tolerance
        allowed[ok] = j
    if not allowed.any():
        return levels[0]
    # the level changes gradually along the path (over `LEVEL_BLEND_M`), never above what is allowed:
    # narrowed first by the blend's reach, then smoothed
    reach = int(np.ceil(3 * LEVEL_BLEND_M / _FINE_STEP_M))
    narrowed = minimum_filter1d(allowed, size=2 * reach + 1, mode="nearest")
    blend = _gaussian_smooth(np.stack([narrowed, np.zeros_like(narrowed)], 1), LEVEL_BLEND_M / _FINE_STEP_M)[:, 0]
    blend = np.clip(np.minimum(blend, allowed), 0.0, len(sigmas) - 1)
    low = np.floor(blend).astype(int)
    high = np.minimum(low + 1, len(sigmas) - 1)
    share = (blend - low)[:, None]
    stack = np.stack(levels)
    rows = np.arange(len(xy))
    return (1.0 - share) * stack[low, rows] + share * stack[high, rows]


def smooth_centre_line(centre: np.ndarray, spacing: float, smoothing: float, extension_back: float,
                       extension_forward: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[float, float]]:
    """A centre line extended straight by ``extension_back`` and ``extension_forward`` metres,
    smoothed (`_widened_smoothing` with a Gaussian of ``smoothing`` metres; none at 0) and resampled
    about ``spacing`` apart: its points, their arc length, heading and curvature, and the arc-length
    interval of the centre line itself (a `planning.reference_path.ReferencePath`'s fields)."""
    centre = without_duplicates(np.asarray(centre, dtype=float))
    if len(centre) < 2:
        raise ValueError("a centre line needs at least two distinct points")
    fine = resample(centre, _FINE_STEP_M)
    route_length = arc_length(fine)[-1]
    fine = _extend(fine, extension_back, extension_forward, _FINE_STEP_M)
    fine = _widened_smoothing(fine, smoothing, DEVIATION_TOLERANCE_M, KINK_DEVIATION_TOLERANCE_M) \
        if smoothing > 0 else fine
    s_fine, theta_fine, kappa_fine = heading_and_curvature(fine)
    line = Polyline(fine, s_fine)
    n = max(3, int(np.ceil(s_fine[-1] / spacing)) + 1)
    s = np.linspace(0.0, s_fine[-1], n)
    xy = np.stack(line.point_at(s), axis=1)
    # arc length of the coarse polyline (chords are a little shorter than the arc)
    s_poly = arc_length(xy)
    theta = line.interpolate(theta_fine, s)
    kappa = line.interpolate(kappa_fine, s)
    start = float(np.ceil(extension_back / _FINE_STEP_M) * _FINE_STEP_M) if extension_back > 0 else 0.0
    scale = s_poly[-1] / s_fine[-1]
    return xy, s_poly, theta, kappa, (start * scale, (start + route_length) * scale)


def towards_goal(centre: np.ndarray, planning_problem: PlanningProblem) -> np.ndarray:
    """``centre`` moved over to the goal where the goal is an area beside it.

    A recorded scenario's goal is often a small rectangle around where the human driver was at the
    end, a metre off the lane's centre: a car on the centre line passes beside it. When the line
    passes less than `GOAL_DEPTH_M` inside the first goal area and the area's centre lies beside
    the line (between `GOAL_BESIDE_MIN_M` and `GOAL_BESIDE_MAX_M`; farther is another lane, the
    route's business), the line moves sideways onto that centre before it, as gently as a lane
    change at the initial speed (`lane_change_length`; less when the start is nearer), arriving
    with the heading the goal's orientation window asks for when that is a lane change's
    (`GOAL_HEADING_MAX_RAD`; a recording's window is often +-5 deg around a driver changing
    lanes), the sideways slope easing out beyond. A goal on the line whose orientation window
    the line's heading misses (by a lane change's turn at most) is passed at that heading. Only
    where the line runs nearly straight before the goal (`GOAL_SHIFT_MAX_TURN_RAD`): in a turn
    the move would change its radius."""
    area = next((area_of(st.position) for st in planning_problem.goal.state_list
                 if getattr(st, "position", None) is not None), None)
    if area is None or area.is_empty:
        return centre
    fine = resample(without_duplicates(np.asarray(centre, dtype=float)), _FINE_STEP_M)
    if len(fine) < 3:
        return centre
    target = np.asarray(area.centroid.coords[0], dtype=float)
    k = nearest(fine, target)
    if k == 0 or k == len(fine) - 1:               # the goal's centre lies beyond an end of the line
        return centre
    s = arc_length(fine)
    tangent = np.gradient(fine, s, axis=0)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1) / np.hypot(*tangent.T)[:, None]
    # the goal's heading relative to the line's there: the recorded driver may have been changing lanes
    turn, misses = _goal_heading_offset(planning_problem, math.atan2(tangent[k, 1], tangent[k, 0]))
    inside = shapely.contains_xy(area, fine[:, 0], fine[:, 1])
    deep = inside.any() and shapely.distance(area.boundary, shapely.points(fine[inside])).max() >= GOAL_DEPTH_M
    if deep and not misses:
        return centre
    offset = float(np.dot(target - fine[k], normal[k]))
    start = float(s[nearest(fine, np.asarray(planning_problem.initial_state.position, dtype=float))])
    speed = float(getattr(planning_problem.initial_state, "velocity", 0.0) or 0.0)
    ramp = min(lane_change_length(speed), s[k] - start)
    if abs(offset) > GOAL_BESIDE_MAX_M or ramp < GOAL_SHIFT_MIN_RAMP_M:
        return centre
    if abs(offset) < GOAL_BESIDE_MIN_M or deep:
        if not misses:
            return centre
        offset = 0.0                # on the line, but the line misses the goal's heading: only turn to it
    heading = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
    if abs(heading[k] - np.interp(s[k] - ramp, s, heading)) > GOAL_SHIFT_MAX_TURN_RAD:
        return centre               # a turn before the goal: moving over there would tighten or widen it
    slope = math.tan(turn)
    u = np.clip((s - (s[k] - ramp)) / ramp, 0.0, 1.0)
    lateral = offset * u * u * (3.0 - 2.0 * u) + slope * ramp * u * u * (u - 1.0)      # cubic Hermite
    beyond = np.clip(s - s[k], 0.0, GOAL_RUN_OUT_M)                # then the slope eases out
    lateral += slope * beyond * (1.0 - beyond / (2.0 * GOAL_RUN_OUT_M))
    return fine + lateral[:, None] * normal


def _goal_heading_offset(planning_problem: PlanningProblem, heading: float) -> tuple[float, bool]:
    """How far the middle of the first goal state's orientation window turns from ``heading``
    (wrapped; 0 without a window, or when it turns more than `GOAL_HEADING_MAX_RAD`: a turn, not
    a lane change), and whether ``heading`` lies outside the window (False in both those cases)."""
    window = next((st.orientation for st in planning_problem.goal.state_list
                   if getattr(st, "orientation", None) is not None), None)
    if window is None or not hasattr(window, "start"):
        return 0.0, False
    middle = 0.5 * (float(window.start) + float(window.end))
    turn = math.remainder(middle - heading, 2.0 * math.pi)
    if abs(turn) > GOAL_HEADING_MAX_RAD:
        return 0.0, False
    return turn, abs(turn) > 0.5 * (float(window.end) - float(window.start))
