"""Grip use on a road's relief: the share of the road's friction a driven (or planned) motion
needs on the 3D surface, where `run_metrics`' ``peak_grip_use`` divides the 2D accelerations by
μ·g as on a plane.

On a 3D road the tyres carry the contact force m·(a − g⃗): on a crest its normal part falls by
m·v²/R (and with it the friction μ·N there is), up or down a grade gravity's share along the road
adds to or takes from what braking needs, and a bank turns part of gravity into a side force
(with a curve banked into it, against it without). Per driven state, with ψ its heading, h and
l the horizontal unit vectors ahead and to the left, ẑ up and n the surface's unit normal under
the car:

    f = a·h + v·ψ̇·l + (z̈ + g)·ẑ        (contact force per mass; z̈ = d/dt(v · dz/ds) along the path)
    N = f·n,  T = |f − N·n|,  use = T / (μ·N)   (N ≤ 0: the car lifts off, use = inf)

with z and dz/ds (the slope along the heading) from the surface at (x, y). The horizontal motion
is the record's (its 2D states: longitudinal a, lateral v·ψ̇) — for a flat world's run, the motion
the flat plan promised, so the figure is what the flat plan asks of the real road. On a flat
surface n = ẑ, z̈ = 0, N = g and the figure is ``peak_grip_use``'s (to the bit without a surface,
to rounding on a level one).
"""

from __future__ import annotations

import numpy as np

from simgap.vehicles.constants import GRAVITY


def grip_use_on_surface(driven, surface, road_friction: float) -> np.ndarray:
    """Grip use (see the module doc) of each state of the trajectory ``driven`` on ``surface`` (an
    object with ``surface(x, y)`` -> height and unit normal, e.g. a `RoadRelief`; None: flat) of
    friction ``road_friction``."""
    x, y, yaw = driven.x, driven.y, driven.yaw
    a_long, a_lat = driven.a, driven.v * driven.yaw_rate
    if surface is None:
        return np.hypot(a_long, a_lat) / (road_friction * GRAVITY)
    ch, sh = np.cos(yaw), np.sin(yaw)
    normal = np.asarray(surface.surface(x, y).normal, dtype=float).reshape(len(x), 3)
    slope = -(normal[:, 0] * ch + normal[:, 1] * sh) / normal[:, 2]     # dz/ds along the heading
    climb = driven.v * slope                                            # dz/dt
    a_up = np.gradient(climb, driven.dt) if len(x) > 1 else np.zeros(len(x))
    force = np.column_stack([a_long * ch - a_lat * sh, a_long * sh + a_lat * ch, a_up + GRAVITY])
    load = np.einsum("ij,ij->i", force, normal)
    friction = np.linalg.norm(force - load[:, None] * normal, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.where(load > 0.0, friction / (road_friction * load), np.inf)
    return use
