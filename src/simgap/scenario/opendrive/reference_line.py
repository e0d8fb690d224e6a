"""A road's reference line evaluated at stations s: position, heading and curvature.

Lines and arcs in closed form, spirals (clothoids: curvature linear in s) with pyclothoids, poly3
and paramPoly3 by their polynomials, parametrised by arc length (the station along the curve, as
OpenDRIVE defines s): the curve's length is tabulated over its parameter and inverted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pyclothoids import Clothoid

from simgap.scenario.opendrive.document import Geometry

_ARC_TABLE_STEP_M = 0.02      # parameter table of a polynomial curve: one entry per this many metres


@dataclass(frozen=True)
class Poses:
    """Reference line samples: x, y, heading [rad] and signed curvature [1/m] at each station."""

    x: np.ndarray
    y: np.ndarray
    hdg: np.ndarray
    curvature: np.ndarray


def _arc(g: Geometry, u: np.ndarray, k: float) -> Poses:
    hdg = g.hdg + k * u
    if k == 0.0:
        x, y = g.x + u * np.cos(g.hdg), g.y + u * np.sin(g.hdg)
    else:
        x = g.x + (np.sin(hdg) - np.sin(g.hdg)) / k
        y = g.y - (np.cos(hdg) - np.cos(g.hdg)) / k
    return Poses(x, y, hdg, np.full_like(u, k))


def _spiral(g: Geometry, u: np.ndarray) -> Poses:
    k0, k1 = g.values
    rate = (k1 - k0) / g.length
    clothoid = Clothoid.StandardParams(g.x, g.y, g.hdg, k0, rate, g.length)
    x = np.array([clothoid.X(v) for v in u])
    y = np.array([clothoid.Y(v) for v in u])
    hdg = np.array([clothoid.Theta(v) for v in u])
    return Poses(x, y, hdg, k0 + rate * u)


def _coefficients(g: Geometry) -> tuple[tuple[float, ...], tuple[float, ...], float]:
    """The u and v cubics of a poly3 or paramPoly3 in its parameter, and where the parameter ends."""
    if g.kind == "poly3":       # the parameter is the local u, at most the geometry's length where it ends
        return (0.0, 1.0, 0.0, 0.0), g.values, g.length
    return g.values[0:4], g.values[4:8], (1.0 if g.values[8] else g.length)


def _derivative(c: tuple[float, ...], t: np.ndarray) -> np.ndarray:
    return c[1] + t * (2 * c[2] + 3 * t * c[3])


def _length_table(g: Geometry) -> tuple[np.ndarray, np.ndarray]:
    """Parameter values of a poly3 or paramPoly3 and the curve's length up to each."""
    cu, cv, p_end = _coefficients(g)
    n = max(64, int(np.ceil(g.length / _ARC_TABLE_STEP_M)))
    p = np.linspace(0.0, p_end, n + 1)
    speed = np.hypot(_derivative(cu, p), _derivative(cv, p))
    return p, np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(p))])


def polynomial_length(g: Geometry) -> float:
    """The length of a poly3's or paramPoly3's curve over its whole parameter range [m]."""
    return float(_length_table(g)[1][-1])


def _polynomial(g: Geometry, u: np.ndarray) -> Poses:
    """poly3 (v a cubic in the local u axis) and paramPoly3 (u and v cubics in a parameter p), both
    in the frame of the geometry's start, evaluated where their arc length is ``u``."""
    cu, cv, _ = _coefficients(g)
    p, length = _length_table(g)
    # a poly3 ends where it is as long as the geometry; a paramPoly3 ends with its parameter range, a
    # small difference between its length and the geometry's spread over the curve
    t = np.interp(u if g.kind == "poly3" else u * length[-1] / g.length, length, p)
    lu = cu[0] + t * (cu[1] + t * (cu[2] + t * cu[3]))
    lv = cv[0] + t * (cv[1] + t * (cv[2] + t * cv[3]))
    du, dv = _derivative(cu, t), _derivative(cv, t)
    ddu, ddv = 2 * cu[2] + 6 * cu[3] * t, 2 * cv[2] + 6 * cv[3] * t
    cos, sin = np.cos(g.hdg), np.sin(g.hdg)
    curvature = (du * ddv - dv * ddu) / np.maximum(np.hypot(du, dv), 1e-12) ** 3
    return Poses(g.x + cos * lu - sin * lv, g.y + sin * lu + cos * lv, g.hdg + np.arctan2(dv, du), curvature)


def geometry_poses(g: Geometry, u: np.ndarray) -> Poses:
    """Poses at distances ``u`` (0 to ``g.length``) along one geometry."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, g.length)
    if g.kind in ("line", "arc"):
        return _arc(g, u, g.values[0] if g.values else 0.0)
    if g.kind == "spiral":
        return _spiral(g, u)
    return _polynomial(g, u)


def reference_poses(geometries: tuple[Geometry, ...], s: np.ndarray) -> Poses:
    """Poses of the reference line at stations ``s`` (each in the geometry that starts last at or
    before it)."""
    s = np.asarray(s, dtype=float)
    starts = np.array([g.s for g in geometries])
    index = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(geometries) - 1)
    out = {name: np.empty_like(s) for name in ("x", "y", "hdg", "curvature")}
    for k in np.unique(index):
        mask = index == k
        poses = geometry_poses(geometries[k], s[mask] - geometries[k].s)
        for name in out:
            out[name][mask] = getattr(poses, name)
    return Poses(**out)
