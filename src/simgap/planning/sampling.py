"""The sampling matrix: one row per candidate manoeuvre, in the frenetix core's layout.

Columns: t0, t1, s0, s_dot0, s_ddot0, s_dot1, s_ddot1, d0, d_dot0, d_ddot0, d1, d_dot1, d_ddot1.
Every candidate starts at the projected initial state and ends at time t1 with speed s_dot1 at
lateral offset d1 (at rest laterally, without longitudinal acceleration).
"""

from __future__ import annotations

import numpy as np

from simgap.planning.settings import SamplingSettings

# columns of the sampling matrix
START_TIME, END_TIME = 0, 1
LONGITUDINAL_START = slice(2, 5)      # s, s_dot, s_ddot at the start
END_SPEED = 5
LATERAL_START = slice(7, 10)          # d, d_dot, d_ddot at the start
END_OFFSET = 10
COLUMNS = 13

# the core counts the points of a plan as int(1 + t / dt): nudge times up so that a time on the
# grid keeps its last point
TIME_NUDGE = 1e-6


def steps_in_horizon(settings: SamplingSettings, dt: float) -> int:
    """Number of dt steps a plan covers (it has one state more)."""
    return max(1, int(round(settings.horizon_s / dt)))


def end_times(settings: SamplingSettings, dt: float) -> np.ndarray:
    """End times between t_min and the horizon, on the dt grid."""
    n = steps_in_horizon(settings, dt)
    times = np.linspace(settings.t_min_s, settings.horizon_s, settings.time_samples)
    steps = np.clip(np.round(times / dt), 1, n).astype(int)
    return np.unique(steps) * dt


# at speed the end speeds reach further down: this share of the current (or desired) speed, when
# more than speed_below_m_s (to fall in behind a vehicle in the next lane at 30 m/s, not only 4 m/s slower)
SPEED_BELOW_SHARE = 0.25


def end_speeds(settings: SamplingSettings, current: float, desired: float, max_speed: float) -> np.ndarray:
    """End speeds: standstill, the desired speed, and evenly between below the lower (by
    ``speed_below_m_s``, or `SPEED_BELOW_SHARE` of the speed when more) and a little above the higher
    of the current and the desired speed; with four or more, one of them halfway down to standstill
    (to fall in behind slower traffic from a high speed)."""
    current = max(current, 0.0)
    below = max(settings.speed_below_m_s, SPEED_BELOW_SHARE * max(current, desired))
    lo = max(0.0, min(current, desired) - below)
    hi = min(max_speed, max(current, desired) + settings.speed_above_m_s)
    n = settings.speed_samples
    if n == 1:
        speeds = np.array([desired])
    elif n == 2:
        speeds = np.array([0.0, desired])
    elif n == 3:
        speeds = np.concatenate([[0.0, desired], np.linspace(lo, hi, n - 2)])
    else:
        speeds = np.concatenate([[0.0, desired, 0.5 * lo], np.linspace(lo, hi, n - 3)])
    speeds = np.unique(np.round(speeds, 6))
    return speeds


def lateral_offsets(settings: SamplingSettings) -> np.ndarray:
    if settings.lateral_samples == 1:
        return np.zeros(1)
    return np.linspace(-settings.lateral_range_m, settings.lateral_range_m, settings.lateral_samples)


def sampling_matrix(x0_lon: np.ndarray, x0_lat: np.ndarray, times: np.ndarray, speeds: np.ndarray,
                    offsets: np.ndarray) -> np.ndarray:
    """All combinations of end time x end speed x lateral offset from one initial state."""
    t1, v1, d1 = (g.ravel() for g in np.meshgrid(times + TIME_NUDGE, speeds, offsets, indexing="ij"))
    matrix = np.zeros((len(t1), COLUMNS))
    matrix[:, END_TIME] = t1
    matrix[:, LONGITUDINAL_START] = x0_lon
    matrix[:, END_SPEED] = v1
    matrix[:, LATERAL_START] = x0_lat
    matrix[:, END_OFFSET] = d1
    return matrix
