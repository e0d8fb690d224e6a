"""Settings of the ``dynamic`` backend: the tracking (`TrackingSettings`), the CommonRoad vehicle
model and parameter set, its integration step and the road's friction."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from simgap.errors import InputError, validated_settings
from simgap.sim.protocol import BackendEntry
from simgap.sim.settings import RoadFrictionSettings, TrackingSettings

VEHICLE_MODELS = ("st", "mb")       # CommonRoad's single-track and multi-body models


class DynamicSettings(TrackingSettings, RoadFrictionSettings):
    """Settings of the ``dynamic`` world (``backend_settings`` of a run)."""

    params_id: int = Field(2, ge=1, le=3, description="CommonRoad vehicle parameter set")
    model: str = Field("st", description=f"vehicle model: {', '.join(VEHICLE_MODELS)}")
    integration_step: float = Field(0.001, gt=0, le=0.01, description="RK4 sub-step of the vehicle model [s]")


def dynamic_settings(values: dict[str, Any]) -> DynamicSettings:
    """``values`` validated as the backend's settings."""
    cfg = validated_settings(DynamicSettings, values)
    if cfg.model not in VEHICLE_MODELS:
        raise InputError(f"unknown vehicle model '{cfg.model}'", field="backend_settings.model",
                         allowed=", ".join(VEHICLE_MODELS))
    return cfg


#: the dynamic backend, as the registry knows it (its physics imported when one is made)
BACKEND = BackendEntry("simgap.sim.dynamic.backend:DynamicBackend", dynamic_settings, "simgap.sim.dynamic.backend")
