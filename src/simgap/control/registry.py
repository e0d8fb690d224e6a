"""Controllers by name, and their gains: defaults, overridden by the vehicle's data file.

A vehicle file may carry, for example::

    controllers:
      pure_pursuit: {lookahead_time: 0.6, speed: {kp: 0.8}}
      stanley: {cross_track_gain: 3.0}

Keys are validated against the controller's gains model; a wrong key or value is an
`InputError` naming the vehicle file and the field (``controllers.stanley.cross_track_gain``).
"""

from __future__ import annotations

from typing import Any, Mapping

from pydantic import BaseModel, ValidationError

from simgap.control.longitudinal import vehicle_source
from simgap.control.lqr import LqrController, LqrGains
from simgap.control.protocol import Controller
from simgap.control.pure_pursuit import PurePursuitController, PurePursuitGains
from simgap.control.stanley import StanleyController, StanleyGains
from simgap.control.tracking import CONTROLLER_HZ, MIN_RATE_HZ, TrackingController
from simgap.errors import InputError, validation_error

CONTROLLERS: dict[str, tuple[type[TrackingController], type[BaseModel]]] = {
    cls.name: (cls, gains) for cls, gains in ((PurePursuitController, PurePursuitGains),
                                              (StanleyController, StanleyGains), (LqrController, LqrGains))}
DEFAULT_CONTROLLER = PurePursuitController.name     # every physics backend's, unless told otherwise


def controller_names() -> list[str]:
    return list(CONTROLLERS)


def _check_name(name: str) -> None:
    if name not in CONTROLLERS:
        raise InputError(f"unknown controller '{name}'", field="controller",
                         allowed=", ".join(CONTROLLERS))


def _merge(base: dict[str, Any], override: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(dict(out[key]), value)
        else:
            out[key] = value
    return out


def controller_gains(name: str, vehicle=None, overrides: Mapping[str, Any] | None = None
                     ) -> BaseModel:
    """The gains of controller ``name``: defaults, then the vehicle's ``controllers[name]``,
    then ``overrides`` (for example from an experiment's configuration)."""
    _check_name(name)
    model = CONTROLLERS[name][1]
    values: dict[str, Any] = {}
    source = vehicle_source(vehicle) if vehicle is not None else None
    layers: list[tuple[Mapping[str, Any], str | None]] = []
    if vehicle is not None and name in (vehicle.controllers or {}):
        layers.append((vehicle.controllers[name], source))
    if overrides:
        layers.append((overrides, None))
    for layer, where in layers:
        if not isinstance(layer, Mapping):
            raise InputError("controller gains must be a mapping of gain names to values",
                             file=where, field=f"controllers.{name}",
                             allowed=", ".join(model.model_fields))
        try:
            model.model_validate(_merge(values, layer))
        except ValidationError as err:
            raise validation_error(err, file=where, prefix=f"controllers.{name}", model=model,
                                   unknown="unknown gain") from None
        values = _merge(values, layer)
    return model.model_validate(values)


def make_controller(name: str, vehicle, rate_hz: float = CONTROLLER_HZ,
                    overrides: Mapping[str, Any] | None = None) -> Controller:
    """A fresh controller ``name`` for ``vehicle``, updating at ``rate_hz`` (>= 50 Hz)."""
    _check_name(name)
    try:
        rate = float(rate_hz)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {rate_hz!r}", field="rate_hz") from None
    if not rate >= MIN_RATE_HZ:
        raise InputError(f"controller rate must be >= {MIN_RATE_HZ:g} Hz, got {rate_hz!r}",
                         field="rate_hz")
    gains = controller_gains(name, vehicle, overrides)
    cls = CONTROLLERS[name][0]
    return cls(vehicle, gains, rate)
