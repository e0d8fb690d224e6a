"""Reading scenario files: every bad file is refused with its name, the field and what is allowed."""

from __future__ import annotations

import pytest
from commonroad.planning.planning_problem import PlanningProblemSet

from simgap.errors import InputError
from simgap.scenario import build_scenario, load_scenario
from simgap.scenario.files import write_xml


def test_a_file_without_planning_problems_is_refused(tmp_path):
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    path = tmp_path / "no-agents.xml"
    write_xml(concrete.scenario, PlanningProblemSet([]), path)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "planningProblem"
    assert "no planning problems" in str(err.value)


@pytest.mark.parametrize("text", ["<commonRoad><oops", "not xml at all", ""])
def test_malformed_xml_is_refused(tmp_path, text):
    path = tmp_path / "broken.xml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and "CommonRoad XML" in err.value.allowed


def test_a_file_of_an_older_commonroad_format_is_refused_naming_its_version(tmp_path):
    path = tmp_path / "GER_A9_2a.xml"
    path.write_text('<?xml version="1.0"?>\n<commonRoad commonRoadVersion="2017a" benchmarkID="GER_A9_2a"></commonRoad>')
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "commonRoadVersion"
    assert "format 2017a" in str(err.value) and "2018b or 2020a" in err.value.allowed


def test_a_missing_file_is_refused(tmp_path):
    with pytest.raises(InputError, match="no such scenario file"):
        load_scenario(tmp_path / "missing.xml")
