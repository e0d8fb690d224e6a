"""An OpenDRIVE file read back on its own terms: each road's reference line and lane centres,
sampled along the road — to check a written file against the lanelets it stands for, without the
writer's objects. The file is read and its geometry evaluated by simgap's OpenDRIVE reader
(`simgap.scenario.opendrive`: `read_document`, `reference_poses`, `lane_edges`), the same code
that imports other tools' roads.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simgap.scenario.opendrive.document import read_document
from simgap.scenario.opendrive.lanes import lane_edges, section_ends
from simgap.scenario.opendrive.reference_line import reference_poses


@dataclass(frozen=True)
class RoadSamples:
    """One road sampled every ``step`` metres: arc length, reference points, and the centre
    points and outer border points of each lane (by lane id, over the lane sections that have it)."""

    road: int
    s: np.ndarray
    reference: np.ndarray
    lane_centres: dict[int, np.ndarray]
    lane_borders: dict[int, np.ndarray]


def _points(x: np.ndarray, y: np.ndarray, hdg: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.column_stack([x - t * np.sin(hdg), y + t * np.cos(hdg)])


def reference_ends(path: str | Path) -> dict[int, tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """Each road's reference line at its start and its end: (x, y, heading)."""
    out = {}
    for road in read_document(path).roads.values():
        end = road.geometries[-1].s + road.geometries[-1].length
        p = reference_poses(road.geometries, np.array([0.0, min(road.length, end)]))
        out[int(road.id)] = ((float(p.x[0]), float(p.y[0]), float(p.hdg[0])),
                             (float(p.x[1]), float(p.y[1]), float(p.hdg[1])))
    return out


SAMPLING_ROADS = "reading roads back"     # the phase, as an export's progress names it


def sample_roads(path: str | Path, step: float = 0.1,
                 on_progress: Callable[[str, int, int], None] = lambda *_: None) -> list[RoadSamples]:
    """Every road of the OpenDRIVE file at ``path``, sampled every ``step`` metres (and at its end);
    ``on_progress(phase, done, total)`` after each road."""
    out = []
    roads = read_document(path).roads
    for road in roads.values():
        s_all = np.unique(np.concatenate([np.arange(0.0, road.length, step), [road.length]]))
        poses = reference_poses(road.geometries, s_all)
        centres: dict[int, list[np.ndarray]] = {}
        borders: dict[int, list[np.ndarray]] = {}
        ends = section_ends(road)
        for k, (section, (s0, s1)) in enumerate(zip(road.sections, ends)):
            last = k == len(road.sections) - 1
            mask = (s_all >= s0 - 1e-9) & ((s_all <= s1 + 1e-9) if last else (s_all < s1 - 1e-9))
            s = s_all[mask]
            x, y, hdg = poses.x[mask], poses.y[mask], poses.hdg[mask]
            for lane_id, (low, high) in lane_edges(road, section, s).items():
                outer = low if lane_id < 0 else high
                centres.setdefault(lane_id, []).append(_points(x, y, hdg, 0.5 * (low + high)))
                borders.setdefault(lane_id, []).append(_points(x, y, hdg, outer))
        out.append(RoadSamples(int(road.id), s_all, np.column_stack([poses.x, poses.y]),
                               {k: np.vstack(v) for k, v in centres.items()},
                               {k: np.vstack(v) for k, v in borders.items()}))
        on_progress(SAMPLING_ROADS, len(out), len(roads))
    return out
