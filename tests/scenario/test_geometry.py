"""Road geometry: arc length, heading continuity, curvature."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simgap.scenario.geometry import Arc, Straight, centre_line


@given(radius=st.floats(8, 200), angle=st.floats(-180, 180).filter(lambda a: abs(a) > 1),
       length=st.floats(5, 150))
@settings(max_examples=40, deadline=None)
def test_arc_length_heading_and_curvature_are_exact(radius, angle, length):
    line = centre_line([Straight(length=length), Arc(radius=radius, angle=angle), Straight(length=length)])
    arc = math.radians(abs(angle)) * radius
    assert line.length == pytest.approx(2 * length + arc, rel=1e-9)
    steps = np.hypot(*np.diff(line.xy, axis=0).T)
    assert steps.max() <= 1.0 + 1e-9                                   # sampled at <= 1 m
    assert np.sum(steps) == pytest.approx(line.length, rel=1e-3)       # chords ≈ arc length
    assert line.heading[-1] == pytest.approx(math.radians(angle), abs=1e-9)
    assert np.abs(np.diff(line.heading)).max() <= 1.0 / radius + 1e-9  # no jumps
    curve = [s for s in line.sections if s.kind == "curve"][0]
    end = np.argmin(np.abs(line.s - curve.s_end))   # samples carry the curvature of the step before
    assert line.curvature[end] == pytest.approx(math.copysign(1 / radius, angle))


def test_quarter_circle_ends_where_geometry_says():
    line = centre_line([Arc(radius=20, angle=90)])
    assert line.xy[-1] == pytest.approx([20.0, 20.0], abs=1e-6)


def test_clothoid_transitions_make_curvature_continuous():
    line = centre_line([Straight(length=20), Arc(radius=30, angle=90, transition=15), Straight(length=20)])
    assert [s.kind for s in line.sections] == ["straight", "clothoid", "curve", "clothoid", "straight"]
    assert np.abs(np.diff(line.curvature)).max() < 1 / 30 / 15 * 1.01 + 1e-12   # linear ramp, 1 m steps
    assert line.heading[-1] == pytest.approx(math.pi / 2, abs=1e-9)
    clothoid = line.sections[1]
    inside = (line.s > clothoid.s_start + 1e-6) & (line.s < clothoid.s_end - 1e-6)
    expected = (line.s[inside] - clothoid.s_start) / (30 * 15)
    assert line.curvature[inside] == pytest.approx(expected, abs=1e-9)
