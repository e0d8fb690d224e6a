"""The vehicle's reference points: simgap's states describe the vehicle's centre, kinematic
planners and path trackers the rear axle (where the bicycle's path tangent is the heading). The
one conversion between them: a point moved along the heading."""

from __future__ import annotations

import math

import numpy as np


def along_heading(x, y, yaw, distance: float):
    """``(x, y)`` moved ``distance`` metres along the heading ``yaw`` (floats or arrays alike):
    the centre of a vehicle whose rear axle is at ``(x, y)`` with ``distance`` its
    ``rear_axle_to_center``; the rear axle of one centred there with ``-rear_axle_to_center``."""
    if np.ndim(yaw) == 0:
        return x + distance * math.cos(yaw), y + distance * math.sin(yaw)
    return x + distance * np.cos(yaw), y + distance * np.sin(yaw)
