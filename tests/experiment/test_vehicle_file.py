"""A vehicle given as a data file (not a catalogue name) works end to end: in `simgap run` and its
report, in an experiment and its report, and in a search — each run records the model it
drove, so nothing looks the vehicle up by name afterwards."""

from __future__ import annotations

import shutil
from importlib import resources
from pathlib import Path

import pytest
import simgap_command
import yaml

from simgap.cosim import CosimSettings
from simgap.experiment.runner import run_experiment
from simgap.experiment.search import Budget, run_search
from simgap.experiment.search.results import search_results
from simgap.experiment.single_run import RunRequest, execute
from simgap.experiment.store import ResultsStore
from simgap.record import read_run
from simgap.report.search_page import build_search_report
from simgap.report.site import build_experiment_report, build_report
from simgap.scenario import build_scenario, write_scenario

# the dynamic world's quick settings (as the search tests' screen), on a short, gentle curve
DYNAMIC = {"backend": "dynamic", "settings": {"integration_step": 0.004, "controller_hz": 50}}
CURVE = {"radius": {"values": [50]}, "angle": {"values": [30]}}


@pytest.fixture()
def car_file(tmp_path) -> Path:
    """A vehicle outside the catalogue: the sedan's data under another name, in its own folder."""
    folder = tmp_path / "cars"
    folder.mkdir()
    path = folder / "my_car.yaml"
    shutil.copyfile(Path(str(resources.files("simgap.vehicles") / "data" / "sedan.yaml")), path)
    return path


def test_run_and_report_with_a_vehicle_file(tmp_path, car_file):
    xml = write_scenario(build_scenario("curve", {"radius": 50, "angle": 30}), tmp_path / "scenarios", preview=False)
    execute(RunRequest(scenario=xml, vehicles=str(car_file), cosim=CosimSettings(replan_every=3)),
            tmp_path / "runs" / "ideal")
    run = simgap_command.simgap("run", xml, "--backend", "dynamic", "--controller-hz", "50", "--vehicle", car_file,
                                "--replan-every", "3", "--no-validate", "--out", tmp_path / "runs" / "dynamic")
    assert run.returncode == 0, run.stderr
    recorded = read_run(tmp_path / "runs" / "dynamic")
    assert recorded.agents[0].history.vehicle.name == "my_car" and recorded.agents[0].history.vehicle.length == pytest.approx(4.508)
    index = build_report(tmp_path / "runs", tmp_path / "report")
    assert "dynamic/my_car" in index.read_text()


def test_an_experiment_with_a_vehicle_file_beside_its_spec(tmp_path, car_file):
    spec = tmp_path / "cars" / "spec.yaml"        # the vehicle file is named relative to the spec
    spec.write_text(yaml.safe_dump({"name": "own-car", "logical": "curve", "parameters": CURVE,
                                    "fidelities": [{"backend": "ideal"}, DYNAMIC | {"vehicles": ["my_car.yaml"]}],
                                    "cosim": {"replan_every": 3}}))
    result = run_experiment(spec, tmp_path / "out", workers=2)
    assert result.failed == 0 and result.ran == 2
    rows = {r["fidelity"]: r for r in ResultsStore(tmp_path / "out").rows()}
    assert set(rows) == {"ideal", "dynamic/my_car"} and rows["dynamic/my_car"]["outcome"] == "goal_reached"
    report = build_experiment_report(tmp_path / "out")
    assert "dynamic/my_car" in report.read_text()


def test_a_search_over_a_vehicle_file(tmp_path, car_file):
    spec = tmp_path / "cars" / "search.yaml"
    spec.write_text(yaml.safe_dump({"name": "own-car", "logical": "curve", "parameters": {"radius": {"min": 40, "max": 60}},
                                    "vehicles": ["my_car.yaml"], "ladder": [{"backend": "ideal"}, DYNAMIC],
                                    "strategies": ["random"], "cosim": {"replan_every": 5}}))
    (result,) = run_search(spec, tmp_path / "search", Budget(runs=2), workers=2)
    rows = ResultsStore(tmp_path / "search" / "random").rows()
    assert result.runs == 2 and all(r["status"] == "ok" for r in rows)
    assert {r["fidelity"] for r in rows} == {"dynamic/my_car"}
    page = build_search_report(search_results(tmp_path / "search"))
    assert "random" in page.read_text()
