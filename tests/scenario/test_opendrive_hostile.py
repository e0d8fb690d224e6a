"""OpenDRIVE files that cannot be a road are refused in one line naming the file, the road and
the element; links that lead nowhere are dropped and counted, one warning per kind — on simgap's
own exported roads, mutated as a careless or hostile user would."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
import simgap_command

from simgap.errors import InputError
from simgap.export.opendrive import UniformRoad, road_network
from simgap.scenario import build_scenario
from simgap.scenario.opendrive.network import opendrive_network

CURVE_ARC = '<arc curvature="0.02"/>'


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict[str, str]:
    """simgap's own curve (straight, arc, straight) and T-junction, exported as OpenDRIVE."""
    folder = tmp_path_factory.mktemp("exported")
    texts = {}
    for name, params in (("curve", {"radius": 50, "angle": 30}), ("t-junction", {})):
        concrete = build_scenario(name, params)
        path = folder / f"{name}.xodr"
        road_network(concrete.scenario.lanelet_network, name, concrete.blueprint, UniformRoad()).opendrive.write_xml(
            str(path))
        texts[name] = path.read_text()
    return texts


def _mutated(exported: dict[str, str], tmp_path: Path, base: str, old: str, new: str, count: int = 1) -> Path:
    text = exported[base]
    assert old in text, old
    path = tmp_path / "hostile.xodr"
    path.write_text(text.replace(old, new, count))
    return path


def test_the_exported_roads_read_without_a_word(exported, tmp_path):
    for base in exported:
        network = opendrive_network(_mutated(exported, tmp_path, base, "<OpenDRIVE>", "<OpenDRIVE>"))
        assert network.dropped == () and network.links.kept == network.links.source


def test_latin1_bytes_in_a_file_declared_utf8_are_refused_naming_the_file(exported, tmp_path):
    path = tmp_path / "latin1.xodr"
    path.write_bytes(exported["curve"].replace('name="curve"', 'name="Straße"').encode("latin-1"))
    with pytest.raises(InputError) as refused:
        opendrive_network(path)
    message = refused.value.describe()
    assert str(path) in message and "encoding" in message and "\n" not in message


FIRST_LINE = 'length="100.0">\n                <line/>'
REFUSED = [  # name, base, old, new, what the message says
    ("zero-length-first-geometry", "curve", FIRST_LINE, FIRST_LINE.replace("100.0", "0"),
     "the first geometry starts at s = 100 m"),
    ("zero-length-arc", "curve", 'length="26.17993877991494"', 'length="0"', "the one before ends at s = 100 m"),
    ("last-geometry-short", "curve", 'length="100.0">\n                <line/>\n            </geometry>\n        '
     '</planView>', 'length="10.0">\n                <line/>\n            </geometry>\n        </planView>',
     "the geometries end at s = 136.18 m"),
    ("geometry-moved", "curve", 'x="100.0" y="0.0"', 'x="105.0" y="0.0"', "5 m from where the one before ends"),
    ("negative-lane-width", "curve", '<width a="3.0"', '<width a="-3.0"', "width -3 m"),
    ("curvature-1e6", "curve", CURVE_ARC, '<arc curvature="1e6"/>', "curvature 1e+06"),
    ("spiral-1e3", "curve", CURVE_ARC, '<spiral curvStart="0" curvEnd="1e3"/>', "curvature 1000"),
    ("paramPoly3-all-zero", "curve", CURVE_ARC, '<paramPoly3 aU="0" bU="0" cU="0" dU="0" aV="0" bV="0" cV="0" '
     'dV="0" pRange="normalized"/>', "the <paramPoly3> is 0 m long"),
    ("paramPoly3-1e200", "curve", CURVE_ARC, '<paramPoly3 aU="0" bU="1e200" cU="0" dU="0" aV="0" bV="0" cV="0" '
     'dV="1e200" pRange="normalized"/>', "<paramPoly3>"),
    ("poly3-1e200", "curve", CURVE_ARC, '<poly3 a="0" b="0" c="0" d="1e200"/>', "<poly3>"),
    ("poly3-1e300", "curve", CURVE_ARC, '<poly3 a="0" b="0" c="1e300" d="1e300"/>', "<poly3>"),
    ("elevation-1e200", "curve", "<elevationProfile/>",
     '<elevationProfile><elevation s="0" a="0" b="0" c="0" d="1e200"/></elevationProfile>', "elevationProfile"),
    ("superelevation-100-degrees", "curve", "<lateralProfile/>",
     '<lateralProfile><superelevation s="0" a="1.75" b="0" c="0" d="0"/></lateralProfile>', "superelevations under"),
    ("lane-width-1e200", "curve", '<width a="3.0" b="0" c="0" d="0"', '<width a="3.0" b="0" c="0" d="1e200"',
     "outer border"),
    ("duplicate-road-id", "t-junction", 'id="2" junction="-1"', 'id="1" junction="-1"', "road id '1' again"),
    ("duplicate-lane-id", "curve", '<lane id="1" type="driving"', '<lane id="-1" type="driving"', "lane id -1 again"),
    ("duplicate-junction-id", "t-junction", "</OpenDRIVE>", '<junction id="1" name="again" type="default"/>'
     "</OpenDRIVE>", "junction id '1' again"),
]


@pytest.mark.parametrize("base, old, new, says", [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_what_cannot_be_a_road_is_refused_in_one_line_without_numpy_warnings(exported, tmp_path, base, old, new, says):
    path = _mutated(exported, tmp_path, base, old, new)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # an overflow's RuntimeWarning fails the test
        with pytest.raises(InputError) as refused:
            opendrive_network(path)
    message = refused.value.describe()
    assert says in message and str(path) in message and "line " in message and "(allowed: " in message
    assert "\n" not in message


T_LINK = '<predecessor elementType="road" elementId="1" contactPoint="start"/>'
DROPPED = [  # name, old, new, count of replacements, kinds dropped and how many
    ("link-to-no-road", '<successor elementType="road" elementId="2"', '<successor elementType="road" elementId="99"',
     2, {"road links to roads that are not in the file": 2}),
    ("link-to-no-junction", '<predecessor elementType="junction" elementId="1"/>',
     '<predecessor elementType="junction" elementId="7"/>', 1,
     {"road links to junctions that are not in the file": 1,
      "junction connections from or to roads that are not in the file, or that do not lead into it": 2}),
    ("lane-link-to-no-lane", '<successor id="-1"/>', '<successor id="-4"/>', 3,
     {"lane links to lanes that the linked lane section does not have": 3}),
    ("junction-into-itself", T_LINK, '<predecessor elementType="junction" elementId="1"/>', 1,
     {"links of a junction into itself": 1}),
]


@pytest.mark.parametrize("old, new, count, kinds", [c[1:] for c in DROPPED], ids=[c[0] for c in DROPPED])
def test_links_that_lead_nowhere_are_dropped_and_counted_per_kind(exported, tmp_path, old, new, count, kinds):
    whole = opendrive_network(_mutated(exported, tmp_path, "t-junction", "<OpenDRIVE>", "<OpenDRIVE>"))
    network = opendrive_network(_mutated(exported, tmp_path, "t-junction", old, new, count))
    assert {d.kind: d.count for d in network.dropped} == kinds
    assert all("\n" not in d.describe() for d in network.dropped)
    assert len(network.lanelets.lanelets) == len(whole.lanelets.lanelets)       # every road is still there
    assert network.links.kept == network.links.source <= whole.links.source


def test_a_connection_from_the_junctions_own_road_into_itself_is_dropped(exported, tmp_path):
    path = _mutated(exported, tmp_path, "t-junction", 'incomingRoad="1" id="0"', 'incomingRoad="100" id="0"')
    network = opendrive_network(path)
    assert {d.kind: d.count for d in network.dropped} == {"links of a junction into itself": 1}


def test_simgap_generate_warns_once_per_kind_and_refuses_without_a_traceback(exported, tmp_path):
    """The lanes from road 1 into the junction lose their way out; a route from road 2 still drives."""
    road = _mutated(exported, tmp_path, "t-junction", '<successor id="-1"/>', '<successor id="-4"/>', 2)
    command = ["generate", str(road), "--start", "2:1:30", "--goal", "1:-1:30",
               "--no-preview", "--out", str(tmp_path / "out")]
    done = simgap_command.simgap(*command, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stderr.strip().splitlines() == [
        f"warning: {road}: lane links to lanes that the linked lane section does not have: 2 dropped (road 100 "
        "lane -1 successor -4, road 101 lane -1 successor -4)"]
    road.write_bytes(exported["curve"].replace('name="curve"', 'name="Straße"').encode("latin-1"))
    refused = simgap_command.simgap(*command, timeout=120)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1 and str(road) in refused.stderr
