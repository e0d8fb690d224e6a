"""Trajectory-tracking controllers: steering, throttle and brake from a plan and a measured state.

``make_controller(name, vehicle, rate_hz)`` builds one by name (`controller_names()`); each
controller's gains have documented defaults that a vehicle file's ``controllers.<name>``
section overrides. The pedal map from acceleration to throttle/brake is
`simgap.control.longitudinal.LongitudinalMap`, fed by the vehicle's ``physics`` section.
"""

from simgap.control.longitudinal import (
    DEFAULT_PHYSICS,
    LongitudinalMap,
    SpeedController,
    SpeedGains,
)
from simgap.control.lqr import LqrController, LqrGains
from simgap.control.protocol import Command, Controller
from simgap.control.pure_pursuit import PurePursuitController, PurePursuitGains
from simgap.control.registry import DEFAULT_CONTROLLER, controller_gains, controller_names, make_controller
from simgap.control.stanley import StanleyController, StanleyGains
from simgap.control.tracking import TrackingController, TrackingGains

__all__ = [
    "Command",
    "Controller",
    "DEFAULT_CONTROLLER",
    "DEFAULT_PHYSICS",
    "LongitudinalMap",
    "LqrController",
    "LqrGains",
    "PurePursuitController",
    "PurePursuitGains",
    "SpeedController",
    "SpeedGains",
    "StanleyController",
    "StanleyGains",
    "TrackingController",
    "TrackingGains",
    "controller_gains",
    "controller_names",
    "make_controller",
]
