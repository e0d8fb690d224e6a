"""The exit codes a CI job reads (0 ok, 1 a check failed, 2 bad input, 3 simgap failed) and the
help of every command at 80 columns, every option's full name in it."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import simgap_command
from click.testing import CliRunner
from typer.main import get_command

from simgap.cli.exit_codes import ExitCode
from simgap.cli.main import _register, app
from simgap.scenario import build_scenario, write_scenario

STRAIGHT = '''
import math

from simgap.trajectory import Trajectory


class Straight:
    """Drives straight ahead at 8 m/s, whatever the road does."""

    def plan(self, observed, t, world):
        n, v = 30, 8.0
        ts = [t + k * world.dt for k in range(n)]
        c, s = math.cos(observed.yaw), math.sin(observed.yaw)
        return Trajectory(world.dt, t=ts, x=[observed.x + v * k * world.dt * c for k in range(n)],
                          y=[observed.y + v * k * world.dt * s for k in range(n)], yaw=[observed.yaw] * n,
                          v=[v] * n, a=[0.0] * n, yaw_rate=[0.0] * n, steer=[0.0] * n)
'''


def simgap(*args: str) -> subprocess.CompletedProcess:
    return simgap_command.simgap(*args, env=dict(os.environ, COLUMNS="200"))


@pytest.fixture(scope="module")
def off_the_curve(tmp_path_factory) -> tuple[Path, str]:
    """A 10 m curve and a planner that drives straight off it."""
    folder = tmp_path_factory.mktemp("curve")
    (folder / "straight.py").write_text(STRAIGHT)
    xml = write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 90.0}), folder, preview=False)
    return xml, f"{folder / 'straight.py'}:Straight"


def test_a_run_that_leaves_the_road_exits_1_with_fail_on_off_road_and_0_without(off_the_curve, tmp_path):
    xml, planner = off_the_curve
    checked = simgap("run", str(xml), "--planner", planner, "--no-validate", "--out", str(tmp_path / "a"),
                     "--fail-on", "collision,off_road", "--min-score", "0.5")
    assert checked.returncode == ExitCode.CHECK_FAILED, checked.stderr
    assert "check failed: agent 1 ended off_road (--fail-on)" in checked.stdout
    assert "check failed: agent 1: score 0.000, below --min-score 0.5" in checked.stdout
    assert (tmp_path / "a" / "run.json").exists()                   # the run is kept: CI can look at it
    plain = simgap("run", str(xml), "--planner", planner, "--no-validate", "--out", str(tmp_path / "b"), "--json",
                   "--fail-on", "collision")
    assert plain.returncode == ExitCode.OK, plain.stderr
    assert '"outcome": "off_road"' in plain.stdout and "check failed" not in plain.stdout + plain.stderr


@pytest.mark.parametrize("option, value, words", [
    ("--fail-on", "off-road,crash", ["field 'fail-on'", "'crash' is no outcome", "goal_reached, collision, off_road"]),
    ("--fail-on", ",", ["no outcome named"]),
    ("--min-score", "1.5", ["field 'min-score'", "0 to 1"])])
def test_a_bad_check_is_refused_before_the_run_with_exit_2(off_the_curve, tmp_path, option, value, words):
    xml, planner = off_the_curve
    proc = simgap("run", str(xml), "--planner", planner, "--out", str(tmp_path / "r"), option, value)
    assert proc.returncode == ExitCode.BAD_INPUT and "Traceback" not in proc.stderr
    assert proc.stderr.count("\n") == 1 and all(w in proc.stderr for w in words), proc.stderr
    assert not (tmp_path / "r").exists()


def _commands(group, path: tuple[str, ...] = ()) -> list[tuple[tuple[str, ...], object]]:
    out = []
    for name, command in group.commands.items():
        out += _commands(command, path + (name,)) if hasattr(command, "commands") else [(path + (name,), command)]
    return out


def test_the_help_of_every_command_at_80_columns_shows_every_option_whole():
    _register([])
    cli = get_command(app)
    runner = CliRunner()
    commands = _commands(cli)
    assert len(commands) >= 12
    for path, command in [((), cli)] + commands:
        shown = runner.invoke(cli, [*path, "--help"], env={"COLUMNS": "80"}, terminal_width=80)
        assert shown.exit_code == 0, shown.output
        lines = shown.output.splitlines()
        assert max(len(line) for line in lines) <= 80, (path, max(lines, key=len))
        names = [n for p in command.params for n in (*p.opts, *getattr(p, "secondary_opts", ())) if n.startswith("--")]
        for name in names:
            assert re.search(rf"(?<![\w-]){re.escape(name)}(?![\w-])", shown.output), (path, name, shown.output)
        if path in ((), ("run",), ("experiment", "run"), ("search",)):
            assert "Exit codes:" in shown.output and "3  simgap could not finish" in shown.output, path


def test_simgap_run_help_in_an_80_column_terminal_names_its_longest_option():
    proc = subprocess.run([sys.executable, "-m", "simgap", "run", "--help"], capture_output=True, text=True,
                          timeout=120, env=dict(os.environ, COLUMNS="80"))
    assert proc.returncode == 0 and "--planner-startup-timeout <float>" in proc.stdout and "…" not in proc.stdout


def test_experiment_run_and_search_fail_on_an_outcome_of_any_of_their_runs(off_the_curve, tmp_path):
    _, planner = off_the_curve
    spec = tmp_path / "offroad.yaml"
    spec.write_text(f"name: offroad\nlogical: curve\nparameters:\n  radius: {{values: [10]}}\n  angle: {{values: [90]}}\n"
                    f"sampler: {{kind: grid}}\nfidelities:\n  - backend: ideal\n"
                    f"planners:\n  - {{planner: '{planner}', label: straight}}\n")
    out = tmp_path / "experiment"
    first = simgap("experiment", "run", str(spec), "--out", str(out), "--workers", "1", "--no-report",
                   "--no-validate", "--fail-on", "off_road")
    assert first.returncode == ExitCode.CHECK_FAILED, first.stdout + first.stderr
    assert "check failed: curve_radius-10_angle-90/ideal/straight ended off_road (--fail-on)" in first.stdout
    again = simgap("experiment", "run", str(spec), "--out", str(out), "--no-report", "--min-score", "0")
    assert again.returncode == ExitCode.OK and "0 ran now" in again.stdout, again.stdout + again.stderr
    search = tmp_path / "search.yaml"
    search.write_text(f"name: offroad\nlogical: curve\nparameters: {{radius: {{min: 10, max: 12}}}}\n"
                      f"planners: [{{planner: '{planner}', label: straight}}]\nladder: [{{backend: ideal}}, "
                      f"{{backend: dynamic}}]\nstrategies: [random]\n")
    found = simgap("search", str(search), "--budget", "1", "--out", str(tmp_path / "s"), "--workers", "1",
                   "--no-explain", "--no-report", "--no-validate", "--fail-on", "collision,off_road")
    assert found.returncode == ExitCode.CHECK_FAILED, found.stdout + found.stderr
    assert "check failed: random " in found.stdout and "ended off_road (--fail-on)" in found.stdout
