"""simgap's own OpenDRIVE export of a generated road, read back by simgap's OpenDRIVE reader, gives
the same lanelets within 0.05 m, with the same successors and neighbours."""

from __future__ import annotations

import pytest
import shapely
from shapely.geometry import LineString

from simgap.export.write import export_road
from simgap.scenario import build_scenario, write_scenario
from simgap.scenario.opendrive.network import opendrive_network


@pytest.mark.parametrize("logical, parameters", [
    ("curve", {"radius": 20, "angle": 90}),
    ("curve", {"radius": 30, "angle": -60, "transition": 10, "lanes": 2}),
    ("s-curve", {"radius": 25, "angle": 45}),
    ("t-junction", {}),
    ("intersection", {}),
])
def test_an_exported_road_reads_back_as_the_same_lanelets(tmp_path, logical, parameters):
    concrete = build_scenario(logical, parameters)
    exported = export_road(write_scenario(concrete, tmp_path, preview=False), tmp_path / "out")
    back = opendrive_network(exported.files[0]).lanelets
    original = concrete.scenario.lanelet_network
    assert len(back.lanelets) == len(original.lanelets)
    same: dict[int, int] = {}
    for lanelet in original.lanelets:
        centre = LineString(lanelet.center_vertices)
        gap, twin = min((shapely.hausdorff_distance(centre, LineString(b.center_vertices)), b.lanelet_id)
                        for b in back.lanelets)
        assert gap < 0.05, (lanelet.lanelet_id, gap)
        same[lanelet.lanelet_id] = twin
    assert len(set(same.values())) == len(same)              # one lanelet read back for each
    for lanelet in original.lanelets:
        twin = back.find_lanelet_by_id(same[lanelet.lanelet_id])
        assert sorted(same[i] for i in lanelet.successor) == sorted(twin.successor)
        assert sorted(same[i] for i in lanelet.predecessor) == sorted(twin.predecessor)
        for side in ("left", "right"):
            neighbour = getattr(lanelet, f"adj_{side}")
            assert getattr(twin, f"adj_{side}") == (same[neighbour] if neighbour is not None else None)
            if neighbour is not None:
                assert getattr(twin, f"adj_{side}_same_direction") == getattr(lanelet, f"adj_{side}_same_direction")
