"""Controllers by name, and their gains: defaults, overridden by the vehicle's data file.

A controller is a class with a pydantic ``Gains`` model, built as ``cls(vehicle, gains, rate_hz)``
(`simgap.control.tracking.TrackingController` is the base of the built-in ones). Built-ins are
one line each in `BUILTIN_CONTROLLERS`; an installed package adds one in the entry-point group
``simgap.controllers`` (``[project.entry-points."simgap.controllers"]``,
``my_tracker = "my_package.tracker:MyTracker"``).

A vehicle file may carry, for example::

    controllers:
      pure_pursuit: {lookahead_time: 0.6, speed: {kp: 0.8}}
      stanley: {cross_track_gain: 3.0}

Keys are validated against the controller's gains model; a wrong key or value is an
`InputError` naming the vehicle file and the field (``controllers.stanley.cross_track_gain``).
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any, Protocol

from pydantic import BaseModel, ValidationError

from simgap.control.longitudinal import vehicle_source
from simgap.control.protocol import Controller
from simgap.control.tracking import CONTROLLER_HZ, MIN_RATE_HZ
from simgap.errors import InputError, validation_error
from simgap.registry import Registry

BUILTIN_CONTROLLERS: dict[str, str] = {
    "pure_pursuit": "simgap.control.pure_pursuit:PurePursuitController",
    "stanley": "simgap.control.stanley:StanleyController",
    "lqr": "simgap.control.lqr:LqrController",
}
DEFAULT_CONTROLLER = "pure_pursuit"     # every physics backend's, unless told otherwise


class ControllerClass(Protocol):
    """What a controller name names: a class with a pydantic ``Gains`` model, built as
    ``cls(vehicle, gains, rate_hz)``."""

    Gains: type[BaseModel]

    def __call__(self, vehicle: Any, gains: BaseModel, rate_hz: float) -> Controller: ...


def _controller_class(obj: Any, name: str) -> ControllerClass:
    """``obj`` if it is a controller class: ``command`` and ``reset``, and a pydantic ``Gains``."""
    controller_class: ControllerClass = obj       # what the checks below make sure of
    gains = getattr(obj, "Gains", None)
    if not (inspect.isclass(obj) and callable(getattr(obj, "command", None))
            and callable(getattr(obj, "reset", None)) and isinstance(gains, type) and issubclass(gains, BaseModel)):
        raise InputError(f"controller '{name}' is not a controller class", field="controller",
                         allowed="a class with command(measured, plan, t), reset(state) and a pydantic Gains "
                                 "model, built as cls(vehicle, gains, rate_hz)")
    return controller_class


#: the controllers by name: the built-ins, then those installed in the entry-point group
CONTROLLERS: Registry[ControllerClass] = Registry("controller", "simgap.controllers", BUILTIN_CONTROLLERS, _controller_class)


def controller_names() -> list[str]:
    return CONTROLLERS.names()


def _check_name(name: str) -> None:
    CONTROLLERS.target_of(name)


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
    model = CONTROLLERS.load(name).Gains
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
    cls = CONTROLLERS.load(name)
    return cls(vehicle, gains, rate)
