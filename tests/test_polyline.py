"""The one polyline (`simgap.polyline`): arc length, projection onto (s, d), resampling, heading
and curvature, points and values at s; and the path classes built on it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.polyline import Polyline, arc_length, heading_and_curvature, nearest, resample, without_duplicates
from simgap.scenario.road_frame import PathFrame


def _arc(radius: float = 20.0, n: int = 400) -> np.ndarray:
    phi = np.linspace(0.0, math.pi / 2, n)
    return np.stack([radius * np.sin(phi), radius - radius * np.cos(phi)], axis=1)


def test_arc_length_is_the_sum_of_the_segments_and_the_polylines():
    xy = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 10.0]])
    assert arc_length(xy).tolist() == [0.0, 5.0, 11.0]
    line = Polyline(xy)
    assert np.array_equal(line.s, arc_length(xy)) and line.length == 11.0 and len(line) == 3
    assert line.seg_len.tolist() == [5.0, 6.0]
    assert Polyline(xy[:1]).length == 0.0                   # one point: no segment


def test_by_norm_measures_as_the_drawn_roads_always_did():
    xy = np.cumsum(np.random.default_rng(3).normal(size=(200, 2)), axis=0)
    old = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    assert np.array_equal(arc_length(xy, by_norm=True), old)
    assert np.allclose(arc_length(xy), old, rtol=1e-14, atol=0.0)


def test_projection_gives_s_and_a_signed_d_and_extends_beyond_the_ends():
    line = Polyline(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]))
    s, d = line.project(np.array([[5.0, 1.0], [5.0, -2.0], [-3.0, 0.5], [11.0, 14.0], [12.0, 5.0]]))
    assert s.tolist() == pytest.approx([5.0, 5.0, -3.0, 24.0, 15.0])
    assert d.tolist() == pytest.approx([1.0, -2.0, 0.5, -1.0, -2.0])


def test_a_point_or_a_value_at_s_is_interpolated_and_clamped():
    line = Polyline(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]))
    x, y = line.point_at(np.array([-1.0, 5.0, 15.0, 30.0]))
    assert x.tolist() == [0.0, 5.0, 10.0, 10.0] and y.tolist() == [0.0, 0.0, 5.0, 10.0]
    assert line.interpolate(np.array([0.0, 1.0, 3.0]), 15.0) == 2.0
    assert nearest(line.xy, np.array([9.0, 8.0])) == 2 == line.nearest(np.array([9.0, 8.0]))


def test_resampling_keeps_the_ends_and_spaces_the_points_evenly():
    xy = _arc(n=37)
    fine = resample(xy, 0.5)
    step = np.diff(arc_length(xy)[[0, -1]])[0] / (len(fine) - 1)
    assert step <= 0.5 and np.array_equal(fine[[0, -1]], xy[[0, -1]])
    assert np.array_equal(Polyline(xy).resampled(0.5).xy, fine)
    assert len(without_duplicates(np.vstack([xy[:3], xy[2:3], xy[3:]]))) == len(xy)


def test_heading_and_curvature_of_an_arc():
    xy = _arc(radius=20.0)
    s, theta, kappa = heading_and_curvature(xy)
    assert np.array_equal(s, arc_length(xy))
    assert theta[0] == pytest.approx(0.0, abs=5e-3) and theta[-1] == pytest.approx(math.pi / 2, abs=5e-3)
    assert np.allclose(kappa[2:-2], 1.0 / 20.0, rtol=1e-3)
    line_theta, line_kappa = Polyline(xy).heading_and_curvature()
    assert np.array_equal(line_theta, theta) and np.array_equal(line_kappa, kappa)


def test_the_road_frame_is_a_polyline_without_repeated_points():
    xy = np.array([[0.0, 0.0], [0.0, 0.0], [10.0, 0.0], [10.0, 1e-12], [20.0, 0.0]])
    frame = PathFrame(xy)
    assert isinstance(frame, Polyline) and len(frame.xy) == 3 and frame.length == pytest.approx(20.0)
    with pytest.raises(ValueError):
        PathFrame(np.array([[1.0, 1.0], [1.0, 1.0]]))
