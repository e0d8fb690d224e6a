"""Which kind of road section each lanelet of a generated road lies on (`RoadSections`): what the
report shades its plots by and the comparison splits its gaps by. A scenario's sidecar
(``NAME.json`` beside its XML) keeps it as ``sections: {lanelet id: kind}``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from simgap.scenario.geometry import SectionKind

UNKNOWN = "unknown"        # a lanelet of no known section (a map's, or one the road was not built with)


@dataclass(frozen=True)
class RoadSections:
    """Lanelet id -> the kind of road section it lies on (straight, curve, clothoid, junction)."""

    kinds: Mapping[int, SectionKind] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "kinds", {int(k): v for k, v in sorted(self.kinds.items())})

    def __bool__(self) -> bool:
        return bool(self.kinds)

    def kind_of(self, lanelet_id: int) -> str:
        return self.kinds.get(int(lanelet_id), UNKNOWN)

    def as_json(self) -> dict[str, str]:
        """As a sidecar and a run record keep it: lanelet ids as strings."""
        return {str(k): v for k, v in self.kinds.items()}

    @classmethod
    def of_json(cls, data: Mapping[str, Any] | None) -> RoadSections:
        return cls({int(k): v for k, v in (data or {}).items()})
