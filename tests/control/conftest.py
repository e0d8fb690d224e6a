"""Shared fixtures of the controller tests: the catalogue sedan and a closed loop on the
single-track plant (CommonRoad parameter set 2) fed with receding windows of a manoeuvre."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from simgap.control import make_controller
from simgap.sim.dynamic import SingleTrackPlant, track_plans
from simgap.vehicles import load_vehicle


@pytest.fixture(scope="session")
def sedan():
    return load_vehicle("sedan")


@dataclass
class Drive:
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    v: np.ndarray
    steer: np.ndarray
    lateral: np.ndarray      # signed lateral error of the centre from the manoeuvre's path
    states: list

    def window(self, t_from: float) -> np.ndarray:
        return self.t >= t_from - 1e-9


@pytest.fixture(scope="session")
def drive(sedan):
    """``drive(controller_name, manoeuvre, horizon=3.0, plan_at=None, **gains)``."""

    def run(name, manoeuvre, *, horizon=3.0, plan_at=None, rate_hz=100.0, vehicle=None, **gains):
        veh = vehicle or sedan
        controller = make_controller(name, veh, rate_hz=rate_hz, overrides=gains or None)
        plant = SingleTrackPlant(veh)
        if plan_at is None:
            def plan_at(t, observed):
                return manoeuvre.plan(t, horizon)
        states = track_plans(plant, controller, plan_at, manoeuvre.initial_state(),
                             manoeuvre.duration)
        arr = {f: np.array([getattr(s, f) for s in states]) for f in ("t", "x", "y", "v", "steer")}
        lateral = np.array([manoeuvre.lateral_error(s.x, s.y) for s in states])
        return Drive(lateral=lateral, states=states, **arr)

    return run
