"""A scenario whose 3D ground cannot be read is refused in one line naming the sidecar and the
field, never run on a flat road; a logical scenario that leaves out what its template needs, or
gives it a value of the wrong kind, is refused naming the file and the name."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import simgap_command

from simgap.errors import InputError
from simgap.scenario import build_scenario, load_logical, read_sidecar, write_scenario
from simgap.scenario.ground import ground_of
from simgap.scenario.logical import TEMPLATES
from simgap.scenario.templates import REQUIRED


@pytest.fixture(scope="module")
def crest(tmp_path_factory) -> Path:
    """A generated road with a grade, a crest and banks (its relief in the sidecar)."""
    concrete = build_scenario("crest-curve", {"radius": 30, "vertical_radius": 200})
    return write_scenario(concrete, tmp_path_factory.mktemp("crest"), preview=False)


def _edited(crest: Path, folder: Path, edit) -> Path:
    xml = folder / "edited.xml"
    xml.write_bytes(crest.read_bytes())
    metadata = json.loads(crest.with_suffix(".json").read_text())
    metadata = edit(metadata)
    xml.with_suffix(".json").write_text(json.dumps(metadata))
    return xml


def _relief(change):
    def edit(metadata):
        change(metadata["blueprint"]["relief"])
        return metadata
    return edit


EDITS = [  # name, edit, the field named
    ("grade-1000-percent", _relief(lambda r: r["elevation"].update(grade=1000)), "blueprint.relief.elevation.grade"),
    ("bank-90-degrees", _relief(lambda r: r["superelevation"][2].update(bank=90)),
     "blueprint.relief.superelevation.2.bank"),
    ("vertical-radius-0", _relief(lambda r: r["elevation"]["changes"][0].update(radius=0)),
     "blueprint.relief.elevation.changes.0.radius"),
    ("vertical-radius-negative", _relief(lambda r: r["elevation"]["changes"][0].update(radius=-100)),
     "blueprint.relief.elevation.changes.0.radius"),
    ("vertical-radius-nan", _relief(lambda r: r["elevation"]["changes"][0].update(radius=math.nan)),
     "blueprint.relief.elevation.changes.0.radius"),
    ("grade-a-string", _relief(lambda r: r["elevation"].update(grade="steep")), "blueprint.relief.elevation.grade"),
    ("vertical-curve-at-nan", _relief(lambda r: r["elevation"]["changes"][0].update(s=math.nan)),
     "blueprint.relief.elevation.changes.0.s"),
    ("sidecar-null", lambda metadata: None, None),
]


def test_the_unedited_sidecar_gives_the_roads_relief(crest):
    relief = ground_of(read_sidecar(crest))
    assert relief is not None
    assert relief.profile.height(np.array([123.56]))[0][0] > 5.0         # the crest, 9 m up


@pytest.mark.parametrize("edit, field", [c[1:] for c in EDITS], ids=[c[0] for c in EDITS])
def test_a_sidecar_whose_relief_does_not_read_is_refused_naming_the_file_and_field(crest, tmp_path, edit, field):
    xml = _edited(crest, tmp_path, edit)
    with pytest.raises(InputError) as refused:
        read_sidecar(xml)
    message = refused.value.describe()
    assert refused.value.file == str(xml.with_suffix(".json")) and refused.value.field == field
    assert "\n" not in message


def test_an_imported_roads_heights_that_do_not_read_are_refused(tmp_path):
    concrete = build_scenario("curve", {"radius": 50, "angle": 30})
    concrete.blueprint = None
    metadata = concrete.sidecar.as_json() | {"opendrive": {"source": "road.xodr", "sha256": "0", "profiles": {},
                                                   "lanelets": {"100": {"road": "1", "section": 0, "lane": -1,
                                                                        "s_start": 0, "s_end": 10,
                                                                        "left_z": ["high"], "right_z": None}}}}
    xml = write_scenario(concrete, tmp_path, preview=False)
    xml.with_suffix(".json").write_text(json.dumps(metadata))
    with pytest.raises(InputError, match=r"field 'opendrive\.lanelets\.100\.left_z\.0'"):
        read_sidecar(xml)


def test_simgap_run_refuses_the_edited_relief_before_it_runs(crest, tmp_path):
    xml = _edited(crest, tmp_path, _relief(lambda r: r["elevation"].update(grade=1000)))
    done = simgap_command.simgap("run", xml, "--backend", "mujoco", "--no-validate", "--max-time", "1",
                                 "--out", tmp_path / "run")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines() == [f"error: {xml.with_suffix('.json')}: field "
                                                "'blueprint.relief.elevation.grade': Input should be less than or "
                                                "equal to 40 (allowed: the blueprint simgap generate wrote (a relief: "
                                                "grades within +-40 %, banks within +-30 deg, vertical curves of a "
                                                "positive radius at finite stations))"]
    assert not (tmp_path / "run").exists()


LOGICAL = "name: hostile\ntemplate: {template}\nfixed: {fixed}\nparameters: {{}}\n"


@pytest.mark.parametrize("template", sorted(t for t in REQUIRED if REQUIRED[t]))
def test_each_name_a_template_needs_is_asked_for_in_one_line(tmp_path, template):
    assert set(REQUIRED) == set(TEMPLATES)
    for missing in REQUIRED[template]:
        given = {name: "x" if name in ("file", "start", "goal") else ([] if name == "segments" else 10)
                 for name in REQUIRED[template] if name != missing}
        path = tmp_path / "logical.yaml"
        path.write_text(LOGICAL.format(template=template, fixed=json.dumps(given)))
        with pytest.raises(InputError) as refused:
            load_logical(path)
        assert refused.value.file == str(path) and refused.value.field == missing


@pytest.mark.parametrize("fixed, field", [
    ({"radius": 50, "angle": "big"}, "fixed.angle"),
    ({"radius": 50, "angle": 30, "lanes": 1.5}, "fixed.lanes"),
    ({"radius": 50, "angle": 30, "two_way": "maybe"}, "fixed.two_way"),
    ({"radius": 50, "angle": 30, "straight_length": [1, 2]}, "fixed.straight_length"),
    ({"radius": 50, "angle": 30, "grade": "steep"}, "fixed.grade"),
])
def test_a_fixed_setting_of_the_wrong_kind_is_refused_naming_it(tmp_path, fixed, field):
    path = tmp_path / "logical.yaml"
    path.write_text(LOGICAL.format(template="curve", fixed=json.dumps(fixed)))
    with pytest.raises(InputError) as refused:
        load_logical(path)
    assert refused.value.file == str(path) and refused.value.field == field
    assert load_logical("curve").build({}).blueprint is not None      # the built-ins still build
