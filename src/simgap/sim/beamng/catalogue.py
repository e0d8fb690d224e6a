"""Which BeamNG.tech model stands in for which simgap vehicle, and what simgap needs to know
about it.

The defaults are the paper's three cars. A run may map differently with the backend setting
``vehicle_models`` (``{sedan: etk800, my_truck: pickup}``); a simgap vehicle with no mapping is
an input error naming that setting. ``steer_lock`` is the road-wheel angle [rad] at full
steering input: the factor between simgap's road-wheel angle and BeamNG's steering input in
[-1, 1]. The defaults are estimates (road-wheel locks typical of cars of each class, 31-36 deg),
not measurements of BeamNG's steering racks: measure them on your build (README: BeamNG.tech)
and override them with the backend setting ``steer_locks``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from simgap.errors import InputError


@dataclass(frozen=True)
class BeamngModel:
    name: str               # BeamNG model id
    title: str
    length: float           # body [m], as the paper states it
    width: float
    steer_lock: float       # road-wheel angle at full steering input [rad]


MODELS: dict[str, BeamngModel] = {m.name: m for m in (
    BeamngModel("etk800", "ETK 800 (touring car)", 4.713, 1.827, 0.55),
    BeamngModel("hopper", "Hopper (off-road)", 3.840, 1.730, 0.60),
    BeamngModel("autobello", "Autobello Piccolina (city car)", 2.970, 1.320, 0.62),
)}

#: simgap vehicle → BeamNG model, the paper's pairing
DEFAULT_MODELS: dict[str, str] = {"sedan": "etk800", "suv": "hopper", "city": "autobello"}

#: BeamNG steers to the right for a positive steering input; simgap's angles are positive left
STEERING_SIGN = -1.0


def model_for(vehicle: str, overrides: Mapping[str, str] | None = None,
              steer_locks: Mapping[str, float] | None = None) -> BeamngModel:
    """The BeamNG model driving simgap vehicle ``vehicle``. A model outside `MODELS` is allowed
    when its steering lock is given in ``steer_locks``."""
    mapping = DEFAULT_MODELS | dict(overrides or {})
    name = mapping.get(vehicle)
    if name is None:
        raise InputError(f"no BeamNG model for the vehicle '{vehicle}'",
                         field=f"backend_settings.vehicle_models.{vehicle}",
                         allowed=f"a BeamNG model id, e.g. {', '.join(MODELS)}")
    locks = dict(steer_locks or {})
    known = MODELS.get(name)
    if name in locks:
        lock = float(locks[name])
        if not 0.05 <= lock <= 1.2:
            raise InputError(f"{lock:g} rad is not a steering lock", field=f"backend_settings.steer_locks.{name}",
                             allowed="0.05 to 1.2 rad")
        return BeamngModel(name, known.title if known else name, known.length if known else 0.0,
                           known.width if known else 0.0, lock)
    if known is None:
        raise InputError(f"the BeamNG model '{name}' (for '{vehicle}') has no known steering lock",
                         field=f"backend_settings.steer_locks.{name}",
                         allowed=f"its road-wheel angle at full lock in rad, or a model of {', '.join(MODELS)}")
    return known
