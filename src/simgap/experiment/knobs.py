"""Reality knobs: what the 2D world assumes and the real world does not, as parameters a search
can vary in the higher fidelities. Each knob's default is the ideal world's assumption, so a
knob left out of a search spec changes nothing; the ideal fidelity never takes a knob.

`KNOBS` is the one table of them (name, unit, the settings field it turns, the backends that take
it, what it means); a knob's default and range are its field's, bound once in the settings model:
the search spec's validation, ``simgap run --knob`` (its help and its checks) and the README's
table (`knob_table`, checked by a test) all come from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from simgap.cosim import CosimSettings
from simgap.cosim.loop import ObservationNoise
from simgap.errors import InputError
from simgap.sim.mujoco.settings import WorldSettings
from simgap.sim.settings import RoadSurface, TrackingSettings


@dataclass(frozen=True)
class Knob:
    """A reality knob: the setting of a settings model it turns (a backend setting, or
    ``cosim.<section>.<field>``); its default and range are that field's own."""

    name: str
    unit: str
    model: type[BaseModel]      # the settings model that holds the knob's field
    setting: str
    backends: tuple[str, ...]
    meaning: str

    @property
    def _field(self) -> FieldInfo:
        return self.model.model_fields[self.setting.rpartition(".")[2]]

    @property
    def default(self) -> float:
        return float(self._field.default)

    @property
    def low(self) -> float:
        """The widest range a spec may ask for: the field's bounds."""
        return float(next(m.ge for m in self._field.metadata if hasattr(m, "ge")))

    @property
    def high(self) -> float:
        return float(next(m.le for m in self._field.metadata if hasattr(m, "le")))


KNOBS: dict[str, Knob] = {k.name: k for k in (
    Knob("road_friction", "-", RoadSurface, "road_friction", ("dynamic", "mujoco"),
         "road friction, scales the tyres' (dry 1.0, wet about 0.6, snow about 0.3)"),
    Knob("steer_delay", "s", TrackingSettings, "steer_delay", ("dynamic", "mujoco", "beamng"),
         "steering actuator dead time"),
    Knob("pedal_delay", "s", TrackingSettings, "pedal_delay", ("dynamic", "mujoco", "beamng"),
         "throttle and brake dead time"),
    Knob("position_noise", "m", ObservationNoise, "cosim.observation_noise.position_m", ("dynamic", "mujoco", "beamng"),
         "std. dev. of the noise on the x and y the planner observes"),
    Knob("yaw_noise", "deg", ObservationNoise, "cosim.observation_noise.yaw_deg", ("dynamic", "mujoco", "beamng"),
         "std. dev. of the noise on the heading the planner observes"),
    Knob("speed_noise", "m/s", ObservationNoise, "cosim.observation_noise.speed_mps", ("dynamic", "mujoco", "beamng"),
         "std. dev. of the noise on the speed the planner observes"),
    Knob("road_bank", "deg", WorldSettings, "road_bank", ("mujoco",),
         "cross slope; positive: the road falls to the right of the way of travel"),
    Knob("road_grade", "deg", WorldSettings, "road_grade", ("mujoco",), "grade; positive: uphill"),
)}


def knob(name: str, *, file: str | Path | None = None, where: str = "knob") -> Knob:
    """The knob ``name``, or an `InputError` naming the known ones."""
    if name not in KNOBS:
        raise InputError(f"unknown reality knob '{name}'", file=file, field=where, allowed=", ".join(KNOBS))
    return KNOBS[name]


def check_knob(name: str, low: float, high: float, *, file: str | Path | None = None, where: str = "knob",
               backend: str | None = None) -> Knob:
    """``name`` is a knob, [low, high] lies in its range and (if given) ``backend`` takes it."""
    k = knob(name, file=file, where=where)
    if low < k.low or high > k.high:
        what = f"{low:g} {k.unit} is out of range" if low == high else f"[{low:g}, {high:g}] leaves the knob's range"
        raise InputError(what, file=file, field=where, allowed=f"{k.low:g} to {k.high:g} {k.unit}")
    if backend is not None and backend not in k.backends:
        raise InputError(f"the knob '{name}' does not apply to the {backend} backend", file=file, field=where,
                         allowed=", ".join(k.backends))
    return k


def knob_value(name: str, values: Mapping[str, Any] | BaseModel) -> float:
    """The value of knob ``name`` in ``values`` (a backend's settings model, or knob values), else
    its default."""
    k = KNOBS[name]
    if isinstance(values, BaseModel):
        return float(getattr(values, k.setting, k.default))
    return float(values.get(k.setting, k.default))


def knob_table() -> str:
    """The knobs as the README's Markdown table."""
    rows = ["| knob | unit | default | range | fidelities | meaning |", "|---|---|---|---|---|---|"]
    rows += [f"| `{k.name}` | {k.unit} | {k.default:g} | {k.low:g}–{k.high:g} | {', '.join(k.backends)} | {k.meaning} |"
             for k in KNOBS.values()]
    return "\n".join(rows)


def apply_knobs(backend: str, values: Mapping[str, float]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(backend settings, cosim settings) that put the knob ``values`` into ``backend``; knobs
    that do not apply to it are left out."""
    settings: dict[str, Any] = {}
    cosim: dict[str, Any] = {}
    for name, value in values.items():
        knob = KNOBS[name]
        if backend not in knob.backends or value == knob.default:
            continue
        if knob.setting.startswith("cosim."):
            section, field = knob.setting.split(".")[1:]
            cosim.setdefault(section, {})[field] = float(value)
        else:
            settings[knob.setting] = float(value)
    return settings, cosim


def with_knobs(backend: str, settings: BaseModel | None, cosim: CosimSettings,
               values: Mapping[str, float]) -> tuple[BaseModel | None, CosimSettings]:
    """``backend``'s settings and the loop's with the knob ``values`` put in (those that apply to
    it). The values lie in the knobs' ranges, which are the settings models' own bounds, so the
    models take them as they are."""
    overrides, sections = apply_knobs(backend, values)
    if overrides and settings is not None:
        settings = settings.model_copy(update=overrides)
    if sections:
        cosim = cosim.model_copy(update={name: getattr(cosim, name).model_copy(update=fields)
                                         for name, fields in sections.items()})
    return settings, cosim
