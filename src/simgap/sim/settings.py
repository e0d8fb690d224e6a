"""Settings every physics backend shares, each bound and default written once: the tracking
(controller, its rate and gains, actuator delays) and the road's friction and tilt. A backend's own
settings model extends `TrackingSettings`; a world with a road surface extends `RoadFrictionSettings`, one
that tilts the road it builds `RoadTiltSettings` (the tilt is the road's: `simgap.scenario.relief.RoadTilt`).

These models are also the knob models: a backend takes the reality knobs of the models its
settings model includes (`simgap.experiment.knobs`), but those of the fields it names in
``NOT_KNOBS`` (a class variable, as ``ASSUMPTIONS``: `not_knobs`)."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

from pydantic import BaseModel, ConfigDict, Field, field_validator

from simgap.control import DEFAULT_CONTROLLER
from simgap.control.registry import CONTROLLERS
from simgap.control.tracking import CONTROLLER_HZ, MIN_RATE_HZ
from simgap.scenario.relief import RoadTilt
from simgap.sim.assumptions import Assumption, Restorations
from simgap.sim.protocol import Realism
from simgap.vehicles import Vehicle
from simgap.vehicles.actuators import IDEAL_ACTUATORS, MAX_DEAD_TIME_S, MAX_TIME_CONSTANT_S, Actuators
from simgap.vehicles.channels import knob_names

DRY_ROAD_FRICTION = 1.0         # the tyres' own friction, unscaled (the ideal world's assumption)

MAX_RATE_HZ = 5000.0        # Hz: as the physics' own limit (a controller no faster than its physics)
ActuatorDelay = Annotated[float | None, Field(ge=0.0, le=MAX_DEAD_TIME_S)]
ActuatorLag = Annotated[float | None, Field(ge=0.0, le=MAX_TIME_CONSTANT_S)]
RoadFriction = Annotated[float, Field(ge=0.1, le=1.5, description="scales each tyre's friction [-]")]


class RoadFrictionSettings(BaseModel):
    """The settings of a world whose road has a friction (the relief it lies on is
    `simgap.scenario.relief.Surface`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    ASSUMPTIONS: ClassVar[Restorations] = {Assumption.FRICTION: {"road_friction": DRY_ROAD_FRICTION}}

    road_friction: RoadFriction = DRY_ROAD_FRICTION


class RoadTiltSettings(RoadTilt):
    """The settings of a world that tilts the road it builds: a bank and a grade laid on the road's
    relief, which the run makes the world's ground (`simgap.scenario.ground.ground_of`)."""

    # a flat twin of the road: no tilt (and none of the scenario's own relief:
    # `simgap.experiment.single_run.RunRequest.flat_road`)
    ASSUMPTIONS: ClassVar[Restorations] = {Assumption.RELIEF: {"road_bank": 0.0, "road_grade": 0.0}}


def not_knobs(model: type[BaseModel]) -> frozenset[str]:
    """The fields of ``model`` that no reality knob varies in its world: the ``NOT_KNOBS`` every
    class of the model declares (none by default)."""
    names: set[str] = set()
    for base in model.__mro__:
        names |= set(vars(base).get("NOT_KNOBS", ()))
    return frozenset(names)


def road_friction(settings: BaseModel | None) -> float:
    """The friction of a world's road: its setting, or the dry road of a world without one (the
    ideal world's assumption)."""
    return settings.road_friction if isinstance(settings, RoadFrictionSettings) else DRY_ROAD_FRICTION


class TrackingSettings(BaseModel):
    """How each car of a physics backend follows its plan."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    # the perfect machine: no dead time, no lag on any channel (sensing and latency, which
    # ``realism`` also gates, are the loop's settings: `simgap.cosim.CosimSettings`)
    ASSUMPTIONS: ClassVar[Restorations] = {Assumption.ACTUATORS: dict.fromkeys(knob_names(), 0.0)}

    controller: str = Field(DEFAULT_CONTROLLER, description="tracking controller: pure_pursuit, stanley, lqr")
    controller_hz: float = Field(CONTROLLER_HZ, ge=MIN_RATE_HZ, le=MAX_RATE_HZ, description="controller rate [Hz]")
    controller_gains: dict[str, Any] = Field(default_factory=dict,
                                             description="gains over the controller's defaults and the vehicle's")
    realism: Realism = Field(Realism.REAL, description="real: the vehicle's actuators, a drifting localisation and "
                             "compute latency; ideal: a perfect machine (the ideal world's assumptions on a physical car)")
    # the knobs the actuator channels declare (`simgap.vehicles.channels`)
    steer_delay: ActuatorDelay = Field(None, description="steering dead time [s] (default: the vehicle's)")
    steer_lag: ActuatorLag = Field(None, description="steering first-order lag, time constant [s] (default: the vehicle's)")
    pedal_delay: ActuatorDelay = Field(None, description="drive and brake dead time [s] (default: the vehicle's)")
    pedal_lag: ActuatorLag = Field(None, description="drive and brake first-order lag, time constant [s] "
                                   "(default: the vehicle's)")
    delay_compensation: bool = Field(True, description="the controller predicts the car over its actuators' known "
                                     "delays before it steers (as Autoware's MPC and openpilot do); false: a naive "
                                     "controller")

    def actuators(self, vehicle: Vehicle) -> Actuators:
        """The actuators ``vehicle``'s car has in this world: the vehicle's (none that delay under
        ``realism: ideal``), with the dead time and lag of each channel's knobs over them."""
        own = IDEAL_ACTUATORS if self.realism is Realism.IDEAL else vehicle.actuators or IDEAL_ACTUATORS
        return Actuators({channel.section: numbers.with_changes(getattr(self, channel.knobs.delay),
                                                                getattr(self, channel.knobs.lag))
                          for channel, numbers in own.items()})

    @field_validator("controller")
    @classmethod
    def _known_controller(cls, name: str) -> str:
        if name not in CONTROLLERS:
            raise ValueError(f"unknown controller '{name}'; known: {CONTROLLERS.allowed()}")
        return name


def realism_of(settings: BaseModel | None) -> Realism:
    """How real a world's car is: its tracking settings' realism; the ideal world's is ideal."""
    return settings.realism if isinstance(settings, TrackingSettings) else Realism.IDEAL
