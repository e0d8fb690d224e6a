"""nuPlan's comfort check (``ego_is_comfortable``) on a driven trajectory: six signals, each
filtered and differentiated as nuPlan's state extractors do
(``nuplan/planning/metrics/utils/state_extractors.py``), against the bounds of `ComfortBounds`.

- longitudinal acceleration: the state's ``a``, smoothed (Savitzky-Golay, window 8, order 2);
- lateral acceleration: ``v x yaw rate`` of the states, smoothed the same way;
- jerk: the derivative (window 15, order 2) of the smoothed magnitude of the acceleration;
- longitudinal jerk: the derivative (window 15, order 2) of the smoothed longitudinal acceleration;
- yaw rate and yaw acceleration: the first (window 5, order 2) and second (window 5, order 3)
  derivatives of the unwrapped heading.

Windows shrink to the trajectory's length; a signal whose window cannot hold its polynomial (a
run of a few steps) is not checked. A bound holds when every sample lies strictly inside it.
"""

from __future__ import annotations

import numpy as np

from simgap.evaluate.settings import ComfortBounds
from simgap.trajectory import Trajectory


def _smooth(values: np.ndarray, window: int = 8, order: int = 2) -> np.ndarray | None:
    from scipy.signal import savgol_filter  # slow to import (about a second): not at the CLI's start

    window = min(window, len(values))
    return savgol_filter(values, window, order) if order < window else None


def _derivative(values: np.ndarray | None, dt: float, window: int, order: int, deriv: int = 1) -> np.ndarray | None:
    from scipy.signal import savgol_filter

    if values is None:
        return None
    window = min(window, len(values))
    return savgol_filter(values, window, order, deriv=deriv, delta=dt) if order < window else None


def comfort_signals(driven: Trajectory) -> dict[str, np.ndarray | None]:
    """The six filtered signals (None: too short to filter)."""
    dt = driven.dt
    lon = _smooth(driven.a)
    lat = _smooth(driven.v * driven.yaw_rate)
    magnitude = _smooth(np.hypot(driven.a, driven.v * driven.yaw_rate))
    heading = np.unwrap(driven.yaw)
    return {"lon_accel": lon, "lat_accel": lat, "jerk": _derivative(magnitude, dt, 15, 2),
            "lon_jerk": _derivative(lon, dt, 15, 2), "yaw_rate": _derivative(heading, dt, 5, 2),
            "yaw_accel": _derivative(heading, dt, 5, 3, deriv=2)}


def _bounds(bounds: ComfortBounds) -> dict[str, tuple[float, float]]:
    return {"lon_accel": (bounds.min_lon_accel, bounds.max_lon_accel),
            "lat_accel": (-bounds.max_abs_lat_accel, bounds.max_abs_lat_accel),
            "jerk": (-bounds.max_abs_jerk, bounds.max_abs_jerk),
            "lon_jerk": (-bounds.max_abs_lon_jerk, bounds.max_abs_lon_jerk),
            "yaw_rate": (-bounds.max_abs_yaw_rate, bounds.max_abs_yaw_rate),
            "yaw_accel": (-bounds.max_abs_yaw_accel, bounds.max_abs_yaw_accel)}


def comfort_check(driven: Trajectory, bounds: ComfortBounds) -> tuple[dict[str, bool], dict[str, float]]:
    """Per signal: whether it stayed inside its bound, and its peak (the largest |value|; for the
    longitudinal acceleration the most negative and the most positive, as ``min_``/``max_``)."""
    within, peaks = {}, {}
    for name, signal in comfort_signals(driven).items():
        if signal is None:
            continue
        lo, hi = _bounds(bounds)[name]
        within[name] = bool(np.all((signal > lo) & (signal < hi)))
        if name == "lon_accel":
            peaks["min_lon_accel"], peaks["max_lon_accel"] = float(signal.min()), float(signal.max())
        else:
            peaks[f"max_abs_{name}"] = float(np.abs(signal).max())
    return within, peaks
