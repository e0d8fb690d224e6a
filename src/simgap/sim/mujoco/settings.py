"""Settings of the ``mujoco`` backend: the physics world (`WorldSettings`: rates, surface friction,
the tilt of the road it builds: `RoadFrictionSettings`, `RoadTiltSettings`) and, on top, the tracking
(`MujocoSettings`). Plain models, importable without MuJoCo."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from simgap.errors import validated_settings
from simgap.sim.protocol import BackendEntry
from simgap.sim.rates import steps_per_tick
from simgap.sim.settings import RoadFriction, RoadFrictionSettings, RoadTiltSettings, TrackingSettings

PHYSICS_HZ = 500.0      # the physics rate unless told otherwise


class WorldSettings(RoadFrictionSettings, RoadTiltSettings):
    """Settings of the physics world (``backend_settings`` of a run)."""

    physics_hz: float = Field(PHYSICS_HZ, ge=200.0, le=5000.0, description="physics rate [Hz]")
    offroad_friction: RoadFriction = Field(0.6, description="off-road (verge) friction, scales each tyre's [-]")


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
