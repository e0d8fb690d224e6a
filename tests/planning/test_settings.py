"""Planner settings: defaults as the paper's Frenetix, validation with field paths."""

from __future__ import annotations

import pytest

from simgap.errors import InputError
from simgap.planning.settings import FrenetSettings


def test_defaults_follow_the_paper():
    s = FrenetSettings()
    assert s.sampling.horizon_s == 3.0
    assert s.sampling.t_min_s == 1.1
    assert s.sampling.lateral_range_m == 3.0
    assert 700 <= s.sampling.samples_per_cycle <= 900
    assert (s.costs.lateral_jerk, s.costs.longitudinal_jerk, s.costs.velocity_offset,
            s.costs.distance_to_reference_path) == (0.2, 0.2, 1.0, 5.0)


def test_nested_values_are_read_and_dumped():
    s = FrenetSettings.from_mapping({"sampling": {"lateral_samples": 5}, "speed": {"cruise_m_s": 8}})
    assert s.sampling.lateral_samples == 5 and s.speed.cruise_m_s == 8.0
    assert FrenetSettings.model_validate(s.model_dump()) == s


@pytest.mark.parametrize("data, field", [
    ({"sampling": {"t_min_s": 4.0}}, "sampling"),
    ({"costs": {"lateral_jerk": -1}}, "costs.lateral_jerk"),
    ({"sampling": {"time_samples": 0}}, "sampling.time_samples"),
    ({"speed": {"max_lateral_acceleration": 0}}, "speed.max_lateral_acceleration"),
    ({"sampling": {"horizon": 3.0}}, "sampling.horizon"),
])
def test_bad_fields_are_named(data, field):
    with pytest.raises(InputError) as err:
        FrenetSettings.from_mapping(data, file="planner.yaml")
    assert err.value.field == field
    assert "planner.yaml" in str(err.value)


def test_yaml_file(tmp_path):
    path = tmp_path / "planner.yaml"
    path.write_text("sampling:\n  lateral_range_m: 2.0\ncollision:\n  traffic_margin_m: 0.3\n")
    s = FrenetSettings.from_yaml(path)
    assert s.sampling.lateral_range_m == 2.0 and s.collision.traffic_margin_m == 0.3
    path.write_text("- not a mapping\n")
    with pytest.raises(InputError):
        FrenetSettings.from_yaml(path)
