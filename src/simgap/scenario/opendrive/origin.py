"""Where an imported scenario's lanelets came from, kept in its sidecar (``opendrive``): the source
file, each lanelet's road, lane section, lane and stations, and the road's relief as the file states
it — each road's elevation and superelevation records, and the heights of every lanelet's bound
vertices — for a 3D world to lay the surface on (the CommonRoad XML is 2D).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

from simgap.errors import validation_error
from simgap.scenario.opendrive.document import Poly3


class LaneletPlace(BaseModel):
    """A lanelet's lane in the OpenDRIVE file, over stations ``s_start`` to ``s_end`` of its road's
    reference line; on a road with a relief, the heights [m] of its left and right bound vertices."""

    model_config = ConfigDict(frozen=True, allow_inf_nan=False)
    road: str
    section: int
    lane: int
    s_start: float
    s_end: float
    left_z: tuple[float, ...] | None = None
    right_z: tuple[float, ...] | None = None


class RoadProfile(BaseModel):
    """A road's elevation [m] and superelevation [rad, positive: falls to the right] records."""

    model_config = ConfigDict(frozen=True, allow_inf_nan=False)
    elevation: tuple[Poly3, ...] = ()
    superelevation: tuple[Poly3, ...] = ()


class OpenDriveOrigin(BaseModel):
    """An imported road network's source and relief (see the module doc)."""

    model_config = ConfigDict(frozen=True, allow_inf_nan=False)
    source: str
    sha256: str
    lanelets: dict[int, LaneletPlace]
    profiles: dict[str, RoadProfile]     # the roads that are not flat


def origin_of(metadata: Mapping[str, Any], file: str | Path | None = None) -> OpenDriveOrigin | None:
    """The OpenDRIVE origin in a scenario's sidecar ``file`` (None: not imported from OpenDRIVE); one
    that is not readable as one is refused, naming its field (a 3D world would otherwise stand the
    road on flat ground)."""
    raw = metadata.get("opendrive")
    if raw is None:
        return None
    try:
        return OpenDriveOrigin.model_validate(raw)
    except ValidationError as err:
        raise validation_error(err, file=file, prefix="opendrive",
                               allowed="the origin simgap generate wrote for an OpenDRIVE road") from None
