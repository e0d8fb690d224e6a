"""Settings of the ``mujoco`` backend: the physics world (`WorldSettings`: rates, surface friction,
slope) and, on top, the tracking (`MujocoSettings`). Plain models, importable without MuJoCo."""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from simgap.errors import validated_settings
from simgap.sim.assumptions import Assumption, Restorations
from simgap.sim.rates import steps_per_tick
from simgap.sim.protocol import BackendEntry
from simgap.sim.settings import RoadFriction, RoadFrictionSettings, TrackingSettings

PHYSICS_HZ = 500.0      # the physics rate unless told otherwise


class WorldSettings(RoadFrictionSettings):
    """Settings of the physics world (``backend_settings`` of a run)."""

    # a flat twin of the road: no slope on top (the scenario's own relief is the run's ground,
    # `simgap.experiment.single_run.RunRequest.flat_road`)
    ASSUMPTIONS: ClassVar[Restorations] = {Assumption.RELIEF: {"road_bank": 0.0, "road_grade": 0.0}}

    physics_hz: float = Field(PHYSICS_HZ, ge=200.0, le=5000.0, description="physics rate [Hz]")
    offroad_friction: RoadFriction = Field(0.6, description="off-road (verge) friction, scales each tyre's [-]")
    road_bank: float = Field(0.0, ge=-15.0, le=15.0,
                             description="cross slope every car feels, through gravity, on top of the road's relief [deg]; "
                                         "positive: the road falls to the right of the way of travel")
    road_grade: float = Field(0.0, ge=-15.0, le=15.0,
                              description="grade every car feels, through gravity, on top of the road's relief [deg]; "
                                          "positive: uphill in the way of travel")


class MujocoSettings(TrackingSettings, WorldSettings):
    """Settings of the ``mujoco`` backend (``backend_settings`` of a run): the tracking and the world."""


def mujoco_settings(values: dict[str, Any]) -> MujocoSettings:
    """``values`` validated as the backend's settings (the physics rate a multiple of the controller's)."""
    cfg = validated_settings(MujocoSettings, values)
    steps_per_tick(cfg.physics_hz, cfg.controller_hz)
    return cfg


#: the mujoco backend, as the registry knows it (its physics imported when one is made)
BACKEND = BackendEntry("simgap.sim.mujoco.backend:MujocoBackend", mujoco_settings, "mujoco",
                       check="simgap.sim.mujoco.graphics:check_mujoco_gl")
