"""ASAM's Quality Checker on what simgap exports: every checker of the OpenSCENARIO bundle runs on
the default .xosc (1.2) and finds nothing; the OpenDRIVE bundle finds no error in generated and
recorded road networks. Skipped, with the reason, where the checker is not installed (`make qc`)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from simgap.experiment.single_run import RunRequest, execute
from simgap.export import checks
from simgap.export.write import export_run
from simgap.scenario import build_scenario, write_scenario


@pytest.fixture(scope="module")
def intersection_run(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("intersection")
    xml = write_scenario(build_scenario("intersection", {"agents": 2}), tmp, preview=False)
    execute(RunRequest(scenario=xml), tmp / "run")
    return tmp / "run"


def moved_connecting_road(xodr: Path, out: Path, by_m: float) -> Path:
    """``xodr`` with its first connecting road moved sideways by ``by_m``."""
    tree = ET.parse(xodr)
    road = next(r for r in tree.getroot().iter("road") if r.get("junction") != "-1")
    geometry = road.find("planView/geometry")
    geometry.set("y", str(float(geometry.get("y")) + by_m))
    tree.write(out)
    return out


def test_a_run_exports_openscenario_1_2_that_every_rule_checks_and_passes(tmp_path, intersection_run, asam_qc):
    export = export_run(intersection_run, tmp_path)
    xodr, xosc = export.files
    assert checks.declared_version(xosc) == ("OpenSCENARIO", 1, 2)
    report = asam_qc(xosc)
    assert report.skipped == [] and len(report.checkers) >= 17
    assert (report.errors, report.warnings) == (0, 0), report.rules
    road = asam_qc(xodr)
    assert road.errors == 0 and road.warnings == 0, road.rules


def test_the_checker_finds_a_gap_of_two_centimetres(tmp_path, intersection_run, asam_qc):
    """Not a rubber stamp: a connecting road moved by 2 cm leaves gaps to the lanes it joins."""
    xodr = export_run(intersection_run, tmp_path / "out").files[0]
    report = asam_qc(moved_connecting_road(xodr, tmp_path / "moved.xodr", 0.02))
    assert report.rules.get("asam.net:xodr:1.7.0:lane_smoothness.contact_point_no_horizontal_gaps", 0) >= 1


@pytest.mark.parametrize("logical, params", [("crest-curve", {"radius": 30, "vertical_radius": 100}),
                                             ("banked-curve", {"bank": -10}),
                                             ("mountain-road", {"grade": 8})])
def test_a_3d_road_exports_its_relief_and_every_checker_passes(tmp_path, asam_qc, logical, params):
    """A road's elevation and superelevation as OpenDRIVE writes them pass ASAM's checker."""
    from simgap.export.write import export_road

    xml = write_scenario(build_scenario(logical, params), tmp_path / "scenario", preview=False)
    (xodr,) = export_road(xml, tmp_path / "out").files
    road = ET.parse(xodr).getroot().find("road")
    profile = road.findall("elevationProfile/elevation") + road.findall("lateralProfile/superelevation")
    assert any(float(r.get("b")) or float(r.get("a")) or float(r.get("c")) for r in profile)   # it has a relief
    report = asam_qc(xodr)
    assert (report.errors, report.warnings) == (0, 0), report.rules
