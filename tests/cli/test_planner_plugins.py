"""A planner written outside simgap (examples/time_gap_planner) run through `simgap run`,
`simgap experiment run` and `simgap search`, installed (entry point) and by file path; and a
planner that raises in a batch.

"Installed" here: the example's source folder on PYTHONPATH plus a ``.dist-info`` folder whose
``entry_points.txt`` is written from the example's own pyproject, which is all importlib.metadata
reads to find an entry point (what pip would leave, without a build)."""

from __future__ import annotations

import os
import subprocess
import tomllib
from pathlib import Path

import pytest
import simgap_command

from simgap.record import read_run
from simgap.scenario import build_scenario, write_scenario

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "time_gap_planner"
PLANNER_FILE = EXAMPLE / "time_gap_planner" / "planner.py"
BY_FILE = f"{PLANNER_FILE}:TimeGapPlanner"


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict[str, str]:
    """The environment of a process in which the example package is installed."""
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    site = tmp_path_factory.mktemp("site")
    dist = site / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    lines = [f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items())
             for group, eps in project["entry-points"].items()]
    (dist / "entry_points.txt").write_text("\n".join(lines))
    path = os.pathsep.join([str(site), str(EXAMPLE), os.environ.get("PYTHONPATH", "")])
    return dict(os.environ, PYTHONPATH=path, COLUMNS="160")


def simgap(env: dict[str, str], *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``simgap ARGS`` in a process whose environment is ``env`` (the example installed)."""
    return simgap_command.simgap(*args, env=env, cwd=cwd, timeout=600)


@pytest.fixture(scope="module")
def curve_xml(tmp_path_factory) -> Path:
    return write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 90.0}),
                          tmp_path_factory.mktemp("curve"), preview=False)


def outcome(run_dir: Path) -> tuple[str, str]:
    agent = read_run(run_dir).agents[0]
    return agent.planner, agent.history.outcome


def test_planners_lists_the_installed_planner_with_its_settings(installed):
    proc = simgap(installed, "planners")
    assert proc.returncode == 0, proc.stderr
    assert "time_gap" in proc.stdout and "installed (simgap-time-gap-planner)" in proc.stdout
    shown = simgap(installed, "planners", "show", "time_gap")
    assert shown.returncode == 0, shown.stderr
    for text in ("time_gap_s", "1.5", "time gap kept to the vehicle ahead"):
        assert text in shown.stdout


@pytest.mark.parametrize("planner, name, backend", [
    ("time_gap", "time_gap", "ideal"),
    (BY_FILE, "TimeGapPlanner", "ideal"),
    ("time_gap", "time_gap", "mujoco"),
])
def test_run_reaches_the_goal_with_the_external_planner(installed, curve_xml, tmp_path, planner, name, backend):
    proc = simgap(installed, "run", str(curve_xml), "--no-validate", "--backend", backend, "--planner", planner, "--out",
                  str(tmp_path / "run"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert outcome(tmp_path / "run") == (name, "goal_reached")


def test_bad_planner_input_is_refused_with_file_field_and_allowed(installed, curve_xml, tmp_path):
    for args, fragments in (
            (["--planner", "nope"], ["field 'planner'", "unknown planner 'nope'", "frenet, reactive, idm, time_gap"]),
            (["--planner", f"{PLANNER_FILE}:Nope"], ["has no class 'Nope'", "TimeGapPlanner"]),
            (["--planner", "1=frenet,x=time_gap"], ["'x=time_gap' is not AGENT_ID=PLANNER"])):
        proc = simgap(installed, "run", str(curve_xml), "--no-validate", "--out", str(tmp_path / "r"), *args)
        assert proc.returncode != 0 and "Traceback" not in proc.stderr
        for fragment in fragments:
            assert fragment in proc.stderr, proc.stderr
    config = tmp_path / "gap.yaml"
    config.write_text("time_gap_s: 0\n")
    proc = simgap(installed, "run", str(curve_xml), "--no-validate", "--out", str(tmp_path / "r"), "--planner", "time_gap",
                  "--planner-config", str(config))
    assert proc.returncode != 0 and "gap.yaml: field 'time_gap_s': Input should be greater than 0" in proc.stderr
    assert not (tmp_path / "r").exists()


SPEC = """
name: plugins
logical: curve
parameters: {{radius: {{values: [10]}}, angle: {{values: [90]}}}}
fidelities: [{{backend: ideal}}]
planners:
  - time_gap
  - {{planner: '{by_file}', label: gap_file, settings: {{desired_speed_m_s: 6}}}}
  - broken.py:Broken
"""

BROKEN = '''
class Broken:
    """Raises in its constructor."""

    def __init__(self, setup, settings):
        raise RuntimeError("no map for this road")

    def plan(self, observed, t, world):
        return None
'''


def test_experiment_compares_planners_and_survives_one_that_raises(installed, tmp_path):
    (tmp_path / "broken.py").write_text(BROKEN)
    spec = tmp_path / "plugins.yaml"
    spec.write_text(SPEC.format(by_file=BY_FILE))
    out = tmp_path / "exp"
    proc = simgap(installed, "experiment", "run", str(spec), "--no-validate", "--out", str(out), "--workers", "2")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "3 runs: 3 ran now (1 failed)" in proc.stdout
    index = (out / "report" / "index.html").read_text()          # the report too, the failed run in it
    assert "3 planners (Broken, gap_file, time_gap)" in index and "raised RuntimeError in its constructor" in index
    query = simgap(installed, "experiment", "query", str(out),
                   "SELECT planner, status, outcome, planner_exceptions FROM runs ORDER BY planner", "--csv",
                   str(tmp_path / "rows.csv"))
    assert query.returncode == 0, query.stderr
    rows = (tmp_path / "rows.csv").read_text().splitlines()
    assert rows == ["planner,status,outcome,planner_exceptions", "Broken,failed,planner_failure,1",
                    "gap_file,ok,goal_reached,0", "time_gap,ok,goal_reached,0"]
    broken = read_run(next(out.glob("runs/*/*@Broken/run.json")).parent)
    assert "raise RuntimeError" in broken.history.planner_errors[0].traceback
    assert broken.settings.planner.name == "Broken"
    again = simgap(installed, "experiment", "run", str(spec), "--no-validate", "--out", str(out), "--no-report")
    assert again.returncode == 0 and "3 runs: 0 ran now (0 failed), 3 finished earlier" in again.stdout


def test_experiment_spec_with_a_bad_planner_is_refused(installed, tmp_path):
    spec = tmp_path / "bad.yaml"
    spec.write_text(SPEC.format(by_file=BY_FILE).replace("broken.py:Broken", "idmm"))
    proc = simgap(installed, "experiment", "run", str(spec), "--no-validate", "--out", str(tmp_path / "exp"))
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert "bad.yaml: field 'planners.2': unknown planner 'idmm' (allowed: frenet, reactive, idm, time_gap" in proc.stderr
    spec.write_text(SPEC.format(by_file=BY_FILE).replace("desired_speed_m_s: 6", "desired_speed: 6"))
    proc = simgap(installed, "experiment", "run", str(spec), "--no-validate", "--out", str(tmp_path / "exp"))
    assert "field 'planners.1.settings.desired_speed'" in proc.stderr and "desired_speed_m_s" in proc.stderr
    assert not (tmp_path / "exp").exists()


SEARCH = """
name: plugin-search
logical: curve
parameters: {{radius: {{min: 10, max: 50}}}}
planners: [time_gap, {{planner: '{by_file}', label: gap_file}}]
ladder: [{{backend: ideal}}, {{backend: dynamic}}]
strategies: [grid]
grid_levels: 2
"""


def test_search_runs_external_planners_as_a_dimension(installed, tmp_path):
    spec = tmp_path / "search.yaml"
    spec.write_text(SEARCH.format(by_file=BY_FILE))
    out = tmp_path / "search"
    proc = simgap(installed, "search", str(spec), "--no-validate", "--budget", "4", "--out", str(out), "--workers", "2", "--no-report")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    import pyarrow.parquet as pq

    rows = [pq.read_table(p).to_pylist()[0] for p in sorted((out / "grid" / "store" / "rows").glob("*.parquet"))]
    assert sorted(r["planner"] for r in rows if r["rung"] == 1) == ["gap_file", "gap_file", "time_gap", "time_gap"]
    assert all(r["status"] == "ok" for r in rows)
