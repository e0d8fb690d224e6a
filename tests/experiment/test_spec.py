"""Experiment specs: validation with clear errors, samplers with exact counts and determinism."""

from __future__ import annotations

import pytest
import yaml

from simgap.errors import InputError
from simgap.evaluate import EvaluationSettings
from simgap.experiment.samplers import sample
from simgap.experiment.spec import jobs, load_spec

BASE = {"name": "t", "logical": "curve", "fidelities": [{"backend": "ideal"}]}


def write(tmp_path, **changes):
    spec = BASE | changes
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


@pytest.mark.parametrize("changes, field, fragment", [
    ({"fidelitys": []}, "fidelitys", "name, description, logical"),
    ({"sampler": {"kind": "halton"}}, "sampler.kind", "grid"),
    ({"sampler": {"kind": "lhs"}}, "sampler", "needs 'samples'"),
    ({"sampler": {"kind": "grid", "samples": 5}}, "sampler", "takes every combination"),
    ({"repeats": 0}, "repeats", "greater than or equal to 1"),
    ({"sampler": {"kind": "random", "samples": 100_000}}, "sampler.samples", "less than or equal to 10000"),
    ({"parameters": {"radius": {"values": list(range(5, 205, 2))}, "angle": {"values": list(range(-90, 90))}}},
     "parameters", "at most 10,000 per experiment"),
    ({"parameters": {"radius": {"values": [2]}}}, "parameters.radius", "5 to 1000 m"),
    ({"parameters": {"radiuss": {"values": [20]}}}, "parameters.radiuss", "radius, angle"),
    ({"fidelities": [{"backend": "carla"}]}, "fidelities.0.backend", "ideal, dynamic, mujoco"),
    ({"fidelities": [{"backend": "mujoco", "vehicles": ["tank"]}]}, "fidelities.0.vehicles", "sedan"),
    ({"fidelities": [{"backend": "mujoco", "controllers": ["mpc"]}]}, "fidelities.0.controllers", "lqr"),
    ({"fidelities": [{"backend": "mujoco", "settings": {"physics_hz": 250}}]}, "fidelities.0.settings.physics_hz",
     "whole multiple of the controller rate"),
    ({"fidelities": [{"backend": "dynamic", "settings": {"offroad_friction": 0.5}}]},
     "fidelities.0.settings.offroad_friction", "params_id"),
    ({"fidelities": [{"backend": "ideal", "settings": {"road_friction": 0.5}}]},
     "fidelities.0.settings.road_friction", "no settings"),
    ({"logical": "intersection", "fidelities": [{"backend": "mujoco", "settings": {"road_bank": 3}}]},
     "fidelities.0.settings", "have no road's reference line to lay a uniform bank or grade along"),
    ({"cosim": {"replan_every": 0}}, "cosim.replan_every", "greater than or equal to 1"),
    ({"cosim": {"score": {"min_progress_ratio": 2}}}, "cosim.score.min_progress_ratio", "less than or equal to 1"),
    ({"evaluation": {"cost_function": "XX1"}}, "evaluation.cost_function", "SM1"),
    ({"cosim": {"cost_function": "SM1"}, "evaluation": {"cost_function": "MW1"}}, "cosim.cost_function",
     "evaluation.cost_function only"),
    ({"fidelities": [{"backend": "ideal"}, {"backend": "ideal"}]}, "fidelities.1", "as fidelities.0 does"),
    ({"fidelities": [{"backend": "mujoco", "vehicles": ["sedan", "sedan"]}]}, "fidelities.0",
     "names 'mujoco/sedan' twice"),
    ({"planner": {"speed": {"cruise": 12}}}, "planner.speed.cruise", "cruise_m_s"),
    ({"planners": ["frenet", "nope"]}, "planners.1", "frenet, reactive, idm, a module:Class"),
    ({"planners": [{"planner": "frenet", "settings": {"speed": {"cruise": 12}}}]}, "planners.0.settings.speed.cruise",
     "cruise_m_s"),
    ({"planners": ["frenet", {"planner": "frenet"}]}, "planners.1.label", "a label of its own"),
    ({"planners": [{"planner": "frenet", "label": "slow"}], "planner": {"speed": {"cruise_m_s": 8}}}, "planner",
     "planners: [{planner: frenet"),
])
def test_a_bad_spec_names_the_file_the_field_and_what_is_allowed(tmp_path, changes, field, fragment):
    with pytest.raises(InputError) as err:
        load_spec(write(tmp_path, **changes))
    assert err.value.file.endswith("spec.yaml")
    assert err.value.field == field
    assert fragment in str(err.value)


def test_the_builtin_paper_study_has_the_papers_counts():
    expanded = jobs(load_spec("paper-curves"))
    assert len(expanded) == 78
    all_jobs = [j for _, runs in expanded for j in runs]
    assert len(all_jobs) == 312 and len({j.key for j in all_jobs}) == 312
    assert sorted({j.fidelity for j in all_jobs}) == ["ideal", "mujoco/city", "mujoco/sedan", "mujoco/suv"]


@pytest.mark.parametrize("kind", ["random", "lhs", "sobol"])
def test_random_samplers_give_their_count_in_range_and_repeat_with_the_seed(tmp_path, kind):
    path = write(tmp_path, sampler={"kind": kind, "samples": 16, "seed": 3},
                 parameters={"radius": {"min": 10, "max": 100}, "angle": {"min": -90, "max": 90}})
    experiment = load_spec(path)
    spec, logical = experiment.spec, experiment.logical
    first, again = sample(spec, logical), sample(spec, logical)
    assert len(first) == 16 and first == again
    assert all(10 <= p["radius"] <= 100 and -90 <= p["angle"] <= 90 for p in first)
    assert len({(p["radius"], p["angle"]) for p in first}) == 16
    other = load_spec(write(tmp_path, sampler={"kind": kind, "samples": 16, "seed": 4},
                            parameters={"radius": {"min": 10, "max": 100}, "angle": {"min": -90, "max": 90}}))
    assert sample(other.spec, other.logical) != first
    if kind == "lhs":       # one sample in each of the 16 strata of every dimension
        strata = sorted(int((p["radius"] - 10) / 90 * 16) for p in first)
        assert strata == list(range(16))


def test_grid_over_given_values_and_repeats(tmp_path):
    path = write(tmp_path, parameters={"radius": {"values": [10, 20]}, "angle": {"values": [30, 60, 90]}},
                 repeats=2, fidelities=[{"backend": "ideal"}, {"backend": "mujoco", "vehicles": ["sedan", "suv"]}])
    expanded = jobs(load_spec(path))
    assert len(expanded) == 6
    keys = [j.key for _, runs in expanded for j in runs]
    assert len(keys) == 6 * 3 * 2 == len(set(keys))
    assert "curve_radius-10_angle-30/mujoco/suv/r1" in keys


def test_planners_are_a_dimension_and_older_specs_keep_their_results(tmp_path):
    experiment = load_spec(write(tmp_path, parameters={"radius": {"values": [10]}, "angle": {"values": [90]}},
                                 planners=["frenet", {"planner": "frenet", "label": "slow",
                                                      "settings": {"speed": {"cruise_m_s": 6}}}]))
    (_, runs), = jobs(experiment)
    assert [(j.key, j.id.folder, j.planner.settings) for j in runs] == [
        ("curve_radius-10_angle-90/ideal", "curve_radius-10_angle-90/ideal", {}),
        ("curve_radius-10_angle-90/ideal/slow", "curve_radius-10_angle-90/ideal@slow", {"speed": {"cruise_m_s": 6}})]
    # a spec from before planners: its frenet settings, the same results hash as then (so it resumes)
    old = load_spec(write(tmp_path, planner={"speed": {"cruise_m_s": 8}}))
    assert "planners" not in old.spec.results_relevant()
    (_, runs), *_ = jobs(old)
    assert runs[0].planner.settings == {"speed": {"cruise_m_s": 8}} and runs[0].key.endswith("/ideal")


def test_the_evaluations_settings_of_a_spec_reach_every_run_and_older_specs_keep_theirs_and_their_results(tmp_path):
    """A spec's ``evaluation`` is what its runs are evaluated by; a spec written when the cost function
    and the score were loop settings (``cosim``) is read as it was meant, with the same results hash."""
    score = {"min_progress_ratio": 0.4, "weights": {"comfort": 7.0}}
    older = load_spec(write(tmp_path, cosim={"replan_every": 2, "cost_function": "MW1", "score": score}))
    newer = load_spec(write(tmp_path, cosim={"replan_every": 2}, evaluation={"cost_function": "MW1", "score": score}))
    for experiment in (older, newer):
        assert experiment.cosim.replan_every == 2
        assert experiment.evaluation.cost_function.value == "MW1"
        assert experiment.evaluation.score.weights.comfort == 7.0 and experiment.evaluation.score.min_progress_ratio == 0.4
    # an older spec hashes what it hashed before: its cosim as written, no evaluation field
    assert "evaluation" not in older.spec.results_relevant() and older.spec.results_relevant()["cosim"]["score"] == score
    assert load_spec(write(tmp_path, cosim={"replan_every": 2})).evaluation == EvaluationSettings()
