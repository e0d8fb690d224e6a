"""A backend and a controller added the way a planner is: a package declares them in the entry-point
groups ``simgap.backends`` and ``simgap.controllers``, and simgap runs them by name.

"Installed" here, as in tests/cli/test_planner_plugins.py: the package's folder on the path plus a
``.dist-info`` folder whose ``entry_points.txt`` declares them, which is all importlib.metadata
reads to find an entry point (what pip would leave, without a build)."""

from __future__ import annotations

import os
import sys
import textwrap
from pathlib import Path

import pytest
import simgap_command
import yaml

from simgap.control import make_controller
from simgap.control.registry import CONTROLLERS
from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.errors import InputError
from simgap.experiment.knobs import check_knob
from simgap.experiment.search.ladder import Ladder
from simgap.experiment.search.space import Candidate
from simgap.experiment.search.spec import load_search_spec
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.record import read_run
from simgap.scenario import build_scenario, write_scenario
from simgap.sim.registry import BACKENDS, backend_settings, make_backend
from simgap.vehicles import load_vehicle

PACKAGE = '''
"""A backend and a controller of a package of one's own."""
from pydantic import BaseModel, ConfigDict

from simgap.control.pure_pursuit import PurePursuitController, PurePursuitGains
from simgap.errors import validated_settings
from simgap.sim.ideal import IdealBackend
from simgap.sim.protocol import BackendEntry
from simgap.sim.settings import RoadFrictionSettings, TrackingSettings


class CountingSettings(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    start_at: int = 0


class CountingBackend(IdealBackend):
    """The ideal world that counts its steps."""

    name = "counting"

    def __init__(self, settings: CountingSettings):
        super().__init__()
        self.steps = settings.start_at

    def step(self, plans):
        self.steps += 1
        return super().step(plans)


BACKEND = BackendEntry(CountingBackend, lambda values: validated_settings(CountingSettings, values),
                       "toy_plugins")


class SlipperySettings(TrackingSettings, RoadFrictionSettings):
    """A world whose car tracks its plan on a road with a friction: it takes those models' knobs."""


class SlipperyBackend(IdealBackend):
    """The ideal world that says the friction it was given."""

    name = "slippery"

    def __init__(self, settings: SlipperySettings):
        super().__init__()
        self.notes.append(f"road friction {settings.road_friction:g}")


SLIPPERY = BackendEntry(SlipperyBackend, lambda values: validated_settings(SlipperySettings, values), "toy_plugins")


class PatientGains(PurePursuitGains):
    extra_lookahead_time: float = 0.0


class PatientTracker(PurePursuitController):
    """Pure pursuit that looks a little further ahead."""

    Gains = PatientGains

    def __init__(self, vehicle, gains, rate_hz):
        super().__init__(vehicle, gains.model_copy(update={
            "lookahead_time": gains.lookahead_time + gains.extra_lookahead_time}), rate_hz)
'''


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A folder in which the package ``toy_plugins`` is installed."""
    site = tmp_path_factory.mktemp("site")
    (site / "toy_plugins.py").write_text(textwrap.dedent(PACKAGE))
    dist = site / "toy_plugins-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-plugins\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[simgap.backends]\ncounting = toy_plugins:BACKEND\n"
                                           "slippery = toy_plugins:SLIPPERY\n\n"
                                           "[simgap.controllers]\npatient = toy_plugins:PatientTracker\n")
    return site


@pytest.fixture
def installed(site, monkeypatch):
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setattr(BACKENDS, "_loaded", {})
    monkeypatch.setattr(CONTROLLERS, "_loaded", {})
    yield
    sys.modules.pop("toy_plugins", None)


def drive(concrete, backend):
    scenario, problems = concrete.scenario, concrete.problems
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planners = {a.id: FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[a.id], sedan,
                                                             scenario.lanelet_network)) for a in agents}
    return simulate(scenario, problems, backend, agents, planners, CosimSettings(replan_every=3))


def test_installed_names_follow_the_built_in_ones(installed):
    assert BACKENDS.names() == ["ideal", "dynamic", "mujoco", "beamng", "counting", "slippery"]
    assert CONTROLLERS.names() == ["pure_pursuit", "stanley", "lqr", "patient"]
    assert BACKENDS.origin("counting") == "installed (toy-plugins)"
    assert CONTROLLERS.target("patient") == "toy_plugins:PatientTracker"


def test_an_installed_backend_runs_a_scenario(installed):
    concrete = build_scenario("curve", {"radius": 20, "angle": 90})
    backend = make_backend("counting", backend_settings("counting", {"start_at": 1000}))
    run = drive(concrete, backend)
    assert run.agents[0].outcome == "goal_reached"
    assert backend.steps == 1000 + len(run.driven[1]) - 1
    with pytest.raises(InputError, match="backend_settings.speed"):
        backend_settings("counting", {"speed": 3})


def test_an_installed_controller_drives_a_physics_world(installed):
    sedan = load_vehicle("sedan")
    controller = make_controller("patient", sedan, overrides={"extra_lookahead_time": 0.2})
    assert type(controller).__name__ == "PatientTracker"
    assert controller.gains.lookahead_time == pytest.approx(make_controller("pure_pursuit", sedan).gains.lookahead_time
                                                            + 0.2)
    concrete = build_scenario("curve", {"radius": 20, "angle": 90})
    run = drive(concrete, make_backend("dynamic", backend_settings("dynamic", {"controller": "patient"})))
    assert run.agents[0].outcome == "goal_reached"
    assert run.timings["control"] > 0


def test_an_unknown_name_names_the_known_ones_and_the_group(installed):
    with pytest.raises(InputError) as backend:
        make_backend("countin")
    assert "unknown backend 'countin'" in str(backend.value)
    assert "ideal, dynamic, mujoco" in str(backend.value) and "simgap.backends" in str(backend.value)
    with pytest.raises(InputError) as controller:
        make_controller("patent", load_vehicle("sedan"))
    assert "pure_pursuit, stanley, lqr, patient" in str(controller.value)
    assert "simgap.controllers" in str(controller.value)


def test_simgap_run_takes_an_installed_backend(site, tmp_path):
    xml = write_scenario(build_scenario("curve", {"radius": 20, "angle": 90}), tmp_path, preview=False)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]), COLUMNS="160")
    proc = simgap_command.simgap("run", xml, "--backend", "counting", "--no-validate", "--out", tmp_path / "run", env=env,
                                 timeout=600)
    assert proc.returncode == 0, proc.stderr
    record = read_run(tmp_path / "run")
    assert record.history.backend == "counting" and record.agents[0].history.outcome == "goal_reached"


def test_an_installed_backend_takes_the_knobs_its_settings_model_includes(installed, tmp_path):
    # the search spec's way: the installed rung's settings take the knob, a knob of a model the
    # installed settings do not include (the slope) is left out
    spec = tmp_path / "search.yaml"
    spec.write_text(yaml.safe_dump({"name": "t", "logical": "curve", "parameters": {"radius": {"min": 10, "max": 50}},
                                    "knobs": {"road_friction": {"min": 0.2, "max": 1.0},
                                              "road_bank": {"min": 0.0, "max": 5.0}},
                                    "ladder": [{"backend": "ideal"}, {"backend": "slippery"}], "strategies": ["random"]}))
    search = load_search_spec(spec)
    candidate = Candidate(0, (0.5, 0.5, 0.5), "sedan", {"radius": 30.0}, {"road_friction": 0.3, "road_bank": 4.0})
    settings, _ = Ladder(search, tmp_path / "search").settings(candidate, 1)
    assert type(settings).__name__ == "SlipperySettings" and settings.road_friction == 0.3
    assert Ladder(search, tmp_path / "search").settings(candidate, 0)[0] == search.rungs[0].settings   # ideal: none
    check_knob("steer_delay", 0.1, 0.1, backend="slippery")
    with pytest.raises(InputError, match="the knob 'road_bank' does not apply to the slippery backend") as refused:
        check_knob("road_bank", 4.0, 4.0, backend="slippery")
    assert refused.value.allowed == "mujoco"


def test_simgap_run_puts_a_knob_into_an_installed_backend(site, installed, tmp_path):
    xml = write_scenario(build_scenario("curve", {"radius": 20, "angle": 90}), tmp_path, preview=False)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]), COLUMNS="160")
    run = ["run", xml, "--backend", "slippery", "--no-validate"]
    proc = simgap_command.simgap(*run, "--knob", "road_friction=0.4", "--out", tmp_path / "run", env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    record = read_run(tmp_path / "run")          # its settings read through its own settings model
    assert type(record.settings.backend).__name__ == "SlipperySettings" and record.settings.backend.road_friction == 0.4
    assert "road friction 0.4" in record.history.backend_notes
    refused = simgap_command.simgap(*run, "--knob", "road_grade=2", "--out", tmp_path / "r", env=env, timeout=600)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert "does not apply to the slippery backend" in refused.stderr and not (tmp_path / "r").exists()
