"""Settings of the ``beamng`` backend (``backend_settings`` of a run, or a ``--backend-config``
file). Where to find the server comes from the settings, else from the environment
(``SIMGAP_BEAMNG_HOST``, ``SIMGAP_BEAMNG_PORT``, ``SIMGAP_BEAMNG_HOME``), else the defaults.
"""

from __future__ import annotations

import os
from typing import ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from simgap.control.tracking import MIN_RATE_HZ
from simgap.errors import InputError, validated_settings
from simgap.sim.protocol import BackendEntry
from simgap.sim.rates import steps_per_tick
from simgap.sim.settings import TrackingSettings
from simgap.vehicles.channels import timing_knobs

ENV = {"host": "SIMGAP_BEAMNG_HOST", "port": "SIMGAP_BEAMNG_PORT", "home": "SIMGAP_BEAMNG_HOME"}


class Materials(BaseModel):
    """BeamNG material names of the decal roads (they must exist in the level)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    road: str = Field("road_rubber_sticky", description="asphalt of every lanelet")
    solid: str = Field("line_white", description="solid line markings")
    dashed: str = Field("line_dashed_short", description="dashed line markings")
    curb: str = Field("curb_concrete", description="kerbs")


class BeamngSettings(TrackingSettings):
    """The server, the level, the driver and the tracking of the ``beamng`` backend."""

    # the actuators' lags are left to BeamNG's own vehicle physics: no reality knob varies them here
    NOT_KNOBS: ClassVar[tuple[str, ...]] = tuple(pair.lag for pair in timing_knobs())

    host: str = Field("localhost", description="BeamNG.tech server host (env SIMGAP_BEAMNG_HOST)")
    port: int = Field(25252, ge=1, le=65535, description="server port (env SIMGAP_BEAMNG_PORT)")
    home: str | None = Field(None, description="BeamNG.tech installation folder (env SIMGAP_BEAMNG_HOME)")
    level: str = Field("smallgrid", description="flat level the roads are laid on")
    connect_timeout: float = Field(5.0, gt=0, description="seconds to wait for the server [s]")
    physics_hz: int = Field(60, ge=20, le=2000, description="deterministic physics rate [Hz] (the paper: 60)")
    driver: Literal["controller", "script_ai"] = Field(
        "controller", description="simgap's tracking controller, or BeamNG's script AI on the plan's waypoints")
    controller_hz: float = Field(60.0, ge=MIN_RATE_HZ, description="controller rate [Hz], divides physics_hz")
    vehicle_models: dict[str, str] = Field(default_factory=dict, description="simgap vehicle → BeamNG model")
    steer_locks: dict[str, float] = Field(default_factory=dict, description="BeamNG model → road-wheel lock [rad]")
    materials: Materials = Materials()
    shape_tolerance: float = Field(0.02, gt=0, le=0.5, description="largest gap between a road's chords and its "
                                   "lanelet [m]")
    node_spacing: tuple[float, float] = Field((1.0, 10.0), description="smallest and largest node spacing [m]")
    run_up_s: float = Field(1.0, gt=0, le=10, description="time to bring a moving start up to speed [s]")


def load_settings(values: dict) -> BeamngSettings:
    """Validated settings: the environment fills host, port and home where not given."""
    settings = validated_settings(BeamngSettings, with_environment(values))
    steps_per_tick(settings.physics_hz, settings.controller_hz, "backend_settings.controller_hz",
                   ", ".join(f"{settings.physics_hz / k:g}" for k in range(1, 5)))
    low, high = settings.node_spacing
    if not 0 < low <= high:
        raise InputError(f"({low:g}, {high:g}) is not a spacing range", field="backend_settings.node_spacing",
                         allowed="(smallest, largest) with 0 < smallest <= largest, in m")
    return settings


def with_environment(settings: dict) -> dict:
    """``settings`` with host, port and home filled from the environment where not given."""
    out = dict(settings)
    for key, var in ENV.items():
        value = os.environ.get(var)
        if key in out or not value:
            continue
        if key == "port":
            try:
                out[key] = int(value)
            except ValueError:
                raise InputError(f"'{value}' is not a port number", field=f"environment {var}",
                                 allowed="1 to 65535") from None
        else:
            out[key] = value
    return out


#: the beamng backend, as the registry knows it (its physics imported when one is made)
BACKEND = BackendEntry("simgap.sim.beamng.backend:BeamngBackend", load_settings, "beamngpy", extra="beamng",
                       check="simgap.sim.beamng.session:check_server")
