"""What a generated road network was built from, kept beside the scenario so that other formats
(OpenDRIVE) can write the exact geometry instead of fitting the sampled lanelets.

A template records its blueprint in the scenario's sidecar (``blueprint``): a road is its segments,
lane layout and, when it is not flat, its relief (`simgap.scenario.relief`: elevation and
superelevation along its centre line); a junction its arms, approach length, lane width and centre
marking (junctions are flat). Lanelet ids
are allocated from ``first_id`` exactly as the template did, so rebuilding a blueprint gives the
same lanelets (`rebuild`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from simgap.errors import InputError
from simgap.scenario.geometry import Arc, CentreLine, Straight, centre_line
from simgap.scenario.junction import Junction, build_junction
from simgap.scenario.relief import LEVEL, MAX_BANK_DEG, MAX_GRADE_PERCENT, ReliefProfile, RoadRelief, RoadTilt
from simgap.scenario.road import LaneLayout, Road, build_road

RELIEF_SAMPLE_M = 0.2      # sampling of the centre line a relief is laid on [m]


class RoadBlueprint(BaseModel):
    """One road: segments laid end to end from the origin heading +x, lanes along them."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    kind: Literal["road"] = "road"
    segments: list[Straight | Arc]
    lanes_per_direction: int = 1
    lane_width: float = 3.0
    two_way: bool = True
    centre_marking: str = "solid"      # as `LaneLayout` and `build_junction` take it
    first_id: int
    relief: ReliefProfile | None = None     # None: flat

    @property
    def layout(self) -> LaneLayout:
        return LaneLayout(self.lanes_per_direction, self.lane_width, self.two_way, self.centre_marking)

    def centre(self) -> CentreLine:
        return centre_line(self.segments)

    def rebuild(self) -> Road:
        return build_road(self.centre(), self.layout, self.first_id)

    def road_relief(self, tilt: RoadTilt = LEVEL) -> RoadRelief | None:
        """The road's surface in the world: its relief with ``tilt`` laid on it (a flat road's
        profile where it has none; None: flat and not tilted)."""
        if self.relief is None and tilt.is_level:
            return None
        profile = (self.relief or ReliefProfile()).tilted(tilt)
        return RoadRelief(profile, centre_line(self.segments, max_step=RELIEF_SAMPLE_M))


class JunctionBlueprint(BaseModel):
    """Straight arms meeting at the origin, one lane per direction, turning lanelets between them."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    kind: Literal["junction"] = "junction"
    arm_angles: list[float]
    approach_length: float
    lane_width: float
    centre_marking: str = "solid"      # as `LaneLayout` and `build_junction` take it
    first_id: int

    def rebuild(self) -> Junction:
        return build_junction(self.arm_angles, self.approach_length, self.lane_width, self.first_id,
                              self.centre_marking)


Blueprint = Annotated[RoadBlueprint | JunctionBlueprint, Field(discriminator="kind")]


_BLUEPRINT: TypeAdapter[RoadBlueprint | JunctionBlueprint] = TypeAdapter(Blueprint)


def blueprint_of(metadata: Mapping[str, Any], file: str | Path | None = None) -> RoadBlueprint | JunctionBlueprint | None:
    """The blueprint in a scenario's sidecar ``file`` (None: not a generated scenario, or written
    before blueprints were recorded); one that is not readable as one — a relief out of bounds, a
    field of the wrong type — is refused, naming its field: a 3D world would otherwise drive a flat
    road."""
    raw = metadata.get("blueprint")
    if raw is None:
        return None
    try:
        return _BLUEPRINT.validate_python(raw)
    except ValidationError as err:
        first = err.errors()[0]
        loc = list(first.get("loc", ()))
        if loc and loc[0] in ("road", "junction"):      # the union's tag, not a field
            loc = loc[1:]
        raise InputError(first.get("msg", str(err)).removeprefix("Value error, "), file=file,
                         field=".".join(["blueprint", *map(str, loc)]),
                         allowed="the blueprint simgap generate wrote (a relief: grades within "
                                 f"+-{MAX_GRADE_PERCENT:g} %, banks within +-{MAX_BANK_DEG:g} deg, vertical curves "
                                 "of a positive radius at finite stations)") from None
