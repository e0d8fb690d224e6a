"""Vehicle data files: every catalogue vehicle loads, and a file that describes no road vehicle
is refused naming the file and the field."""

from __future__ import annotations

from importlib import resources

import pytest

from simgap.errors import InputError
from simgap.vehicles.catalogue import load_vehicle_file, vehicle_names


@pytest.mark.parametrize("name", vehicle_names())
def test_every_catalogue_vehicle_is_within_the_bounds_of_a_road_vehicle(name):
    assert load_vehicle_file(resources.files("simgap.vehicles") / "data" / f"{name}.yaml").name == name


@pytest.mark.parametrize("old, new, field", [
    ("width: 1.610", "width: 400", "width"),
    ("max_power: 115000.0", "max_power: 1.0e15", "physics.max_power"),
    ("mass: 1093.3", "mass: .inf", "physics.mass"),
    ("max_speed: 50.8", "max_speed: 1.0e300", "limits.max_speed"),
    ("wheelbase: 2.578766", "wheelbase: 40", "wheelbase"),
    ("rear_axle_to_center: 1.4227", "rear_axle_to_center: 50", "rear_axle_to_center"),
])
def test_a_vehicle_no_road_carries_is_refused_naming_the_field(tmp_path, old, new, field):
    text = (resources.files("simgap.vehicles") / "data" / "sedan.yaml").read_text()
    assert old in text
    path = tmp_path / "absurd.yaml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(InputError) as err:
        load_vehicle_file(path)
    assert err.value.file == str(path) and err.value.field == field
