"""The observation-noise knob: what a planner sees, not where the car is."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from simgap.cosim import CosimSettings
from simgap.cosim.loop import ObservationNoise
from simgap.trajectory import State

TRUE = State(t=1.0, x=10.0, y=-2.0, yaw=3.1, v=0.2, a=0.0, yaw_rate=0.0, steer=0.0)


def test_no_noise_returns_the_true_state():
    assert ObservationNoise().observe(TRUE, np.random.default_rng(0)) is TRUE


def test_noise_has_the_asked_spread_and_is_seeded():
    noise = ObservationNoise(position_m=0.3, yaw_deg=2.0, speed_mps=0.5)
    seen = [noise.observe(TRUE, rng) for rng in [np.random.default_rng(1)] for _ in range(4000)]
    dx = np.array([s.x - TRUE.x for s in seen])
    assert abs(dx.std() - 0.3) < 0.02 and abs(dx.mean()) < 0.02
    assert all(-math.pi <= s.yaw <= math.pi for s in seen)          # wrapped
    assert all(s.v >= 0.0 for s in seen)                             # a speed is never negative
    a = noise.observe(TRUE, np.random.default_rng(7))
    b = noise.observe(TRUE, np.random.default_rng(7))
    assert a == b


def test_bad_noise_is_refused_with_its_field():
    with pytest.raises(ValidationError, match="position_m"):
        CosimSettings(observation_noise={"position_m": -1})
