"""A scenario's sidecar (``NAME.json`` beside its CommonRoad XML), typed: what the XML cannot keep —
the scenario's name, the logical scenario and parameters it was built from (with their units),
the kind of road section of each lanelet, and what its 3D ground is built from (a generated road's
blueprint, an imported OpenDRIVE network's origin). Read once, where a run starts
(`read_sidecar`); a run directory keeps it as ``driven.json``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import JsonValue

from simgap.errors import InputError
from simgap.scenario.blueprint import JunctionBlueprint, RoadBlueprint, blueprint_of
from simgap.scenario.opendrive.origin import OpenDriveOrigin, origin_of
from simgap.scenario.sections import RoadSections


@dataclass(frozen=True)
class ScenarioSidecar:
    """What a scenario's sidecar says; all empty for a scenario without one (a map, a recording)."""

    name: str | None = None
    logical: str | None = None
    parameters: Mapping[str, JsonValue] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)            # parameter -> unit
    sections: RoadSections = field(default_factory=RoadSections)
    blueprint: RoadBlueprint | JunctionBlueprint | None = None        # what the road network was built from
    opendrive: OpenDriveOrigin | None = None                          # the OpenDRIVE file it was read from

    def __post_init__(self) -> None:
        for name in ("parameters", "units"):
            object.__setattr__(self, name, dict(getattr(self, name)))

    def __bool__(self) -> bool:
        return self != ScenarioSidecar()

    def with_parameters(self, parameters: Mapping[str, JsonValue]) -> ScenarioSidecar:
        """The sidecar with ``parameters`` over its own (a placed agent's start and goal)."""
        return ScenarioSidecar(self.name, self.logical, {**self.parameters, **parameters}, self.units, self.sections,
                               self.blueprint, self.opendrive)

    def as_json(self) -> dict[str, Any]:
        """As the sidecar file keeps it."""
        out: dict[str, Any] = {"name": self.name, "logical": self.logical, "parameters": dict(self.parameters),
                               "units": dict(self.units), "sections": self.sections.as_json(),
                               "blueprint": None if self.blueprint is None else
                               self.blueprint.model_dump(mode="json", exclude_none=True)}
        if self.opendrive is not None:
            out["opendrive"] = self.opendrive.model_dump(mode="json", exclude_none=True)
        return out

    @classmethod
    def of_json(cls, data: Mapping[str, Any], file: str | Path | None = None) -> ScenarioSidecar:
        """``data``, a parsed sidecar, typed; a blueprint or an OpenDRIVE origin that does not read is
        refused naming ``file`` and the field (a scenario whose relief cannot be read is never run
        flat)."""
        where = _not_finite(data)
        if where is not None:
            raise InputError("a number that is not finite", file=file, field=where, allowed="finite numbers")
        name, logical = data.get("name"), data.get("logical")
        return cls(name=None if name is None else str(name), logical=None if logical is None else str(logical),
                   parameters=_mapping(data, "parameters", file), units=_mapping(data, "units", file),
                   sections=RoadSections.of_json(_mapping(data, "sections", file)),
                   blueprint=blueprint_of(data, file), opendrive=origin_of(data, file))


def read_sidecar(xml_path: str | Path) -> ScenarioSidecar:
    """The sidecar beside the scenario file ``xml_path`` (empty if there is none). One that is not a
    JSON object, holds a number that is not finite, or whose blueprint or OpenDRIVE origin does not
    read is refused naming the field."""
    sidecar = Path(xml_path).with_suffix(".json")
    if not sidecar.exists():
        return ScenarioSidecar()
    try:
        data = json.loads(sidecar.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"unreadable scenario metadata: {exc}", file=sidecar) from None
    if not isinstance(data, dict):
        raise InputError(f"the scenario metadata is {json.dumps(data)[:40]}, not a JSON object", file=sidecar,
                         allowed="a JSON object (the sidecar simgap generate wrote)")
    return ScenarioSidecar.of_json(data, sidecar)


def _mapping(data: Mapping[str, Any], name: str, file: str | Path | None) -> dict[str, Any]:
    value = data.get(name)
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise InputError(f"holds {json.dumps(value)[:40]}, not an object", file=file, field=name,
                         allowed="the JSON object simgap generate wrote")
    return value


def _not_finite(value: Any, path: str = "") -> str | None:
    """The path of the first number in ``value`` (parsed JSON) that is not finite, or None."""
    if isinstance(value, float):
        return None if math.isfinite(value) else path or "."
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        found = _not_finite(item, f"{path}.{key}".lstrip("."))
        if found is not None:
            return found
    return None
