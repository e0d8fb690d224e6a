"""Reality knobs: what the 2D world assumes and the real world does not, as parameters a search
can vary in the higher fidelities. A knob left out of a search spec leaves its setting at the
world's default (the vehicle's actuators, the sensing profile's accuracy, the measured latency);
a knob's ``nominal`` value is the ideal world's assumption (no delay, no error), which a failure's
probes move it back to. The ideal fidelity never takes a knob, and a physics world of realism
ideal (a perfect machine) none of the loop's (latency, localisation errors).

`KNOBS` is the one table of them (name, unit, the settings field it turns, what it means); a
knob's range is its field's, bound once in the settings model: the search spec's validation,
``simgap run --knob`` (its help and its checks) and the README's table (`knob_table`, checked by a
test) all come from it. Which backends take a knob is not written here: each backend's settings
model says it, by the knob models it includes (`RoadFrictionSettings`, `RoadTiltSettings`, `TrackingSettings`:
`simgap.sim.settings`) but the fields it names in ``NOT_KNOBS``; a knob of the loop
(``cosim.<section>.<field>``) applies to a world whose car tracks its plan (`TrackingSettings`),
of realism real. A backend installed from an entry point takes knobs the same way.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from simgap.cosim import CosimSettings
from simgap.cosim.sensing import SensingSettings
from simgap.errors import InputError
from simgap.sim.protocol import Realism
from simgap.sim.registry import BUILTIN_BACKENDS, settings_model
from simgap.sim.settings import RoadFrictionSettings, RoadTiltSettings, TrackingSettings, not_knobs, realism_of
from simgap.vehicles.channels import TimingKnobs, timing_knobs


@dataclass(frozen=True)
class Knob:
    """A reality knob: the setting of a settings model it turns (a backend setting, or
    ``cosim.<section>.<field>``); its default and range are that field's own."""

    name: str
    unit: str
    model: type[BaseModel]      # the settings model that holds the knob's field
    setting: str
    meaning: str
    nominal: float = 0.0            # the ideal world's assumption
    default: str = ""               # what the world has when the knob is left out (empty: the field's default)

    def applies_to(self, settings: type[BaseModel]) -> bool:
        """Whether a backend whose settings model is ``settings`` takes the knob: the model includes
        the knob's (for a knob of the loop: `TrackingSettings`, a car that tracks its plan) and does
        not leave its field out (``NOT_KNOBS``)."""
        if self.real_only:
            return issubclass(settings, TrackingSettings)
        return issubclass(settings, self.model) and self.setting not in not_knobs(settings)

    @property
    def backends(self) -> tuple[str, ...]:
        """The built-in backends that take the knob (an installed one may too: `applies_to`)."""
        return tuple(name for name, model in _builtin_models() if self.applies_to(model))

    @property
    def _field(self) -> FieldInfo:
        return self.model.model_fields[self.setting.rpartition(".")[2]]

    @property
    def _bounds(self) -> list:
        """The field's bound metadata (of its number, where the field also takes a word)."""
        metadata = list(self._field.metadata)
        for arg in getattr(self._field.annotation, "__args__", ()):
            for info in getattr(arg, "__metadata__", ()):
                metadata += getattr(info, "metadata", [info])
        return metadata

    @property
    def low(self) -> float:
        """The widest range a spec may ask for: the field's bounds."""
        return float(next(m.ge for m in self._bounds if hasattr(m, "ge")))

    @property
    def high(self) -> float:
        return float(next(m.le for m in self._bounds if hasattr(m, "le")))

    @property
    def real_only(self) -> bool:
        """Taken by a world of realism real only: under realism ideal (a perfect machine) the loop
        sends every plan at once and the planner observes the exact state (`simgap.cosim.loop`,
        `simgap.cosim.sensing`), whatever the loop's latency and sensing settings say."""
        return self.setting.startswith("cosim.")

    @property
    def default_text(self) -> str:
        return self.default or f"{self._field.default:g}"


@cache
def _builtin_models() -> tuple[tuple[str, type[BaseModel]], ...]:
    """Each built-in backend with its settings model (read once: the help and the docs' table ask)."""
    return tuple((name, settings_model(name)) for name in BUILTIN_BACKENDS)


def _actuator_knobs(pair: TimingKnobs) -> tuple[Knob, Knob]:
    """The dead-time and the lag knob of the actuator channels that declare ``pair``
    (`simgap.vehicles.channels`)."""
    return (Knob(pair.delay, "s", TrackingSettings, pair.delay, f"{pair.subject} dead time", default="the vehicle's"),
            Knob(pair.lag, "s", TrackingSettings, pair.lag, f"{pair.subject} lag: first-order time constant",
                 default="the vehicle's"))


KNOBS: dict[str, Knob] = {k.name: k for k in (
    Knob("road_friction", "-", RoadFrictionSettings, "road_friction",
         "road friction, scales the tyres' (dry 1.0, wet about 0.6, snow about 0.3)", nominal=1.0),
    *(knob for pair in timing_knobs() for knob in _actuator_knobs(pair)),
    Knob("latency", "s", CosimSettings, "cosim.latency", "from the planning time to the plan reaching the car",
         default="measured"),
    Knob("position_drift", "m", SensingSettings, "cosim.sensing.position_drift_m",
         "drifting localisation error on x and y, 1-sigma", default="the profile's"),
    Knob("heading_drift", "deg", SensingSettings, "cosim.sensing.heading_drift_deg",
         "drifting localisation error on the heading, 1-sigma", default="the profile's"),
    Knob("speed_drift", "m/s", SensingSettings, "cosim.sensing.speed_drift_mps",
         "drifting localisation error on the speed, 1-sigma", default="the profile's"),
    Knob("position_noise", "m", SensingSettings, "cosim.sensing.position_noise_m",
         "white noise on the x and y the planner observes, 1-sigma", default="the profile's"),
    Knob("yaw_noise", "deg", SensingSettings, "cosim.sensing.heading_noise_deg",
         "white noise on the heading the planner observes, 1-sigma", default="the profile's"),
    Knob("speed_noise", "m/s", SensingSettings, "cosim.sensing.speed_noise_mps",
         "white noise on the speed the planner observes, 1-sigma", default="the profile's"),
    Knob("road_bank", "deg", RoadTiltSettings, "road_bank",
         "bank laid on a generated road's relief; positive: the road falls to the right of its reference line"),
    Knob("road_grade", "deg", RoadTiltSettings, "road_grade",
         "grade laid on a generated road's relief; positive: uphill along its reference line"),
)}


def knob(name: str, *, file: str | Path | None = None, where: str = "knob") -> Knob:
    """The knob ``name``, or an `InputError` naming the known ones."""
    if name not in KNOBS:
        raise InputError(f"unknown reality knob '{name}'", file=file, field=where, allowed=", ".join(KNOBS))
    return KNOBS[name]


def check_knob(name: str, low: float, high: float, *, file: str | Path | None = None, where: str = "knob",
               backend: str | None = None, realism: Realism | None = None) -> Knob:
    """``name`` is a knob, [low, high] lies in its range and (if given) ``backend`` in ``realism``
    takes it."""
    k = knob(name, file=file, where=where)
    if low < k.low or high > k.high:
        what = f"{low:g} {k.unit} is out of range" if low == high else f"[{low:g}, {high:g}] leaves the knob's range"
        raise InputError(what, file=file, field=where, allowed=f"{k.low:g} to {k.high:g} {k.unit}")
    if backend is not None and not k.applies_to(settings_model(backend)):
        raise InputError(f"the knob '{name}' does not apply to the {backend} backend", file=file, field=where,
                         allowed=", ".join(k.backends))
    if realism is Realism.IDEAL and k.real_only:
        raise InputError(f"the knob '{name}' does not apply under realism ideal (a perfect machine: plans reach the "
                         "car at once, the planner observes the exact state)", file=file, field=where,
                         allowed="realism real, or leave the knob out")
    return k


def knob_table() -> str:
    """The knobs as a Markdown table (the docs' reference page)."""
    rows = ["| knob | unit | default | ideal | range | fidelities | meaning |", "|---|---|---|---|---|---|---|"]
    rows += [f"| `{k.name}` | {k.unit} | {k.default_text} | {k.nominal:g} | {k.low:g}–{k.high:g} | "
             f"{', '.join(k.backends)} | {k.meaning} |" for k in KNOBS.values()]
    return "\n".join(rows)


def apply_knobs(backend: str, values: Mapping[str, float],
                realism: Realism = Realism.REAL) -> tuple[dict[str, Any], dict[str, Any]]:
    """(backend settings, cosim settings) that put the knob ``values`` into ``backend`` in a world
    of ``realism``; knobs that do not apply there are left out (so no record says they applied)."""
    return _split(settings_model(backend), values, realism)


def _split(model: type[BaseModel], values: Mapping[str, float],
           realism: Realism) -> tuple[dict[str, Any], dict[str, Any]]:
    """`apply_knobs` for a backend whose settings model is ``model``."""
    settings: dict[str, Any] = {}
    cosim: dict[str, Any] = {}
    for name, value in values.items():
        knob = KNOBS[name]
        if not knob.applies_to(model) or (realism is Realism.IDEAL and knob.real_only):
            continue
        if knob.setting.startswith("cosim."):
            path = knob.setting.split(".")[1:]
            if len(path) == 1:
                cosim[path[0]] = float(value)
            else:
                cosim.setdefault(path[0], {})[path[1]] = float(value)
        else:
            settings[knob.setting] = float(value)
    return settings, cosim


def with_knobs(settings: BaseModel | None, cosim: CosimSettings,
               values: Mapping[str, float]) -> tuple[BaseModel | None, CosimSettings]:
    """A backend's ``settings`` and the loop's with the knob ``values`` put in (those that apply to
    it: its settings model says which; none to an optional backend that is not installed, whose
    settings are None). The values lie in the knobs' ranges, which are the settings models' own
    bounds, so the models take them as they are."""
    if settings is None:
        return settings, cosim
    overrides, sections = _split(type(settings), values, realism_of(settings))
    if overrides:
        settings = settings.model_copy(update=overrides)
    if sections:
        cosim = cosim.model_copy(update={name: getattr(cosim, name).model_copy(update=fields)
                                         if isinstance(fields, dict) else fields for name, fields in sections.items()})
    return settings, cosim
