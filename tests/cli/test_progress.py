"""Progress and quiet: the long commands (run, export, render, report, experiment run, generate) draw progress bars
with the time left on standard error, forced on here with ``SIMGAP_PROGRESS=always`` so that they
draw into the captured stream; what they print on standard output is the same as without bars;
without a terminal and without the variable they draw none. Notes alike but for their numbers
print as one line with their count."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import simgap_command
from drawn_bars import drawn, same_stdout

from simgap.cli.console import PROGRESS_ENV, ProgressBars, collapsed_notes
from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.scenario import build_scenario, write_scenario

SIMGAP = [sys.executable, "-m", "simgap"]
SPEC = """name: two
logical: curve
parameters: {radius: {values: [50, 100]}, angle: {values: [30]}}
fidelities: [{backend: ideal}]
cosim: {replan_every: 3}
"""


def simgap(*args, bars: bool) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="150")
    env.pop(PROGRESS_ENV, None)
    if bars:
        env[PROGRESS_ENV] = "always"
    proc = simgap_command.simgap(*args, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc


def assert_finished(bars: dict[str, list[re.Match]], phase: str, total: int | None = None) -> None:
    """``phase``'s bar was drawn and its last drawing shows it whole (n/n, or ``total``/``total``)."""
    assert phase in bars, list(bars)
    done, _, of = bars[phase][-1]["counts"].partition("/")
    assert done == of and (total is None or int(of) == total), bars[phase][-1].group(0)


@pytest.fixture(scope="module")
def a_run(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("a_run")
    xml = write_scenario(build_scenario("curve", {"radius": 30, "angle": 30}), tmp, preview=False)
    execute(RunRequest(scenario=xml, backend="ideal", cosim=CosimSettings(max_time_s=4.0)), tmp / "run")   # 4 s: a short video
    return tmp / "run"


# ------------------------------------------------------------------------------ the bars themselves
def test_a_run_shows_its_simulated_time_and_prints_the_same(tmp_path, a_run):
    xml = next(a_run.parent.glob("*.xml"))
    shown = simgap("run", xml, "--backend", "dynamic", "--max-time", "3", "--knob", "latency=0.1", "--no-validate",
                   "--out", tmp_path / "a", bars=True)
    plain = simgap("run", xml, "--backend", "dynamic", "--max-time", "3", "--knob", "latency=0.1", "--no-validate",
                   "--out", tmp_path / "b", bars=False)
    (phase,) = drawn(shown.stderr)
    assert phase == f"dynamic: {xml.name}" and drawn(shown.stderr)[phase][-1]["counts"] == "100 %"
    assert drawn(plain.stderr) == {}
    assert "\x1b[" not in shown.stdout and "elapsed," not in shown.stdout        # the bars: on standard error only
    fingerprint = re.compile(r"fingerprint (\w+)")
    assert fingerprint.search(shown.stdout)[1] == fingerprint.search(plain.stdout)[1]



def test_a_bar_shows_how_far_a_phase_is_and_the_time_it_has_left(monkeypatch, capsys):
    monkeypatch.setenv(PROGRESS_ENV, "always")
    clock = [0.0]
    with ProgressBars(get_time=lambda: clock[0]) as bars:
        for done in range(3):                  # 2 of 4 roads in 20 s: 20 s left
            clock[0] = 10.0 * done
            bars.update("fitting roads", done, 4)
    (bar,) = drawn(capsys.readouterr().err)["fitting roads"][-1:]
    assert (bar["counts"], bar["elapsed"], bar["left"]) == ("2/4", "0:00:20", "0:00:20")


def test_a_phase_that_starts_again_restarts_its_bar(monkeypatch, capsys):
    monkeypatch.setenv(PROGRESS_ENV, "always")
    clock = [0.0]
    with ProgressBars(get_time=lambda: clock[0]) as bars:
        for clock[0], done in ((0.0, 0), (50.0, 1), (100.0, 2), (100.0, 0), (101.0, 1), (102.0, 2)):
            bars.update("fitting roads", done, 4)          # the second export's roads are quicker
    bar = drawn(capsys.readouterr().err)["fitting roads"][-1]
    assert (bar["counts"], bar["left"]) == ("2/4", "0:00:02")


@pytest.mark.parametrize("setting, shown", [(None, False), ("never", False), ("always", True)])
def test_bars_show_on_a_terminal_or_when_asked_only(monkeypatch, capsys, setting, shown):
    monkeypatch.delenv(PROGRESS_ENV, raising=False)
    if setting:
        monkeypatch.setenv(PROGRESS_ENV, setting)
    with ProgressBars() as bars:                          # (pytest's captured stderr is no terminal)
        bars.update("runs", 1, 2)
    assert bars.shown is shown and bool(drawn(capsys.readouterr().err)) is shown


def test_bars_asked_off_by_the_command_stay_off(monkeypatch, capsys):
    monkeypatch.setenv(PROGRESS_ENV, "always")
    with ProgressBars(shown=False) as bars:               # e.g. --json
        bars.update("runs", 1, 2)
    assert capsys.readouterr().err == ""


# ------------------------------------------------------------------------------ repeated notes

def test_notes_alike_but_for_their_numbers_print_as_one_with_their_count():
    banks = [f"road_bank {b:g} deg is every road's superelevation" for b in (1.5, 2.25, 7, 1.5)]
    notes = banks + ["no blueprint beside the scenario: the road network is fitted"] * 3 + ["a note said once"]
    assert collapsed_notes(notes) == [
        "road_bank 1.5 deg is every road's superelevation (×4, with other numbers)",
        "no blueprint beside the scenario: the road network is fitted (×3)",
        "a note said once"]


def test_notes_that_differ_in_words_stay_apart():
    assert collapsed_notes(["3 roads fitted", "3 roads dropped"]) == ["3 roads fitted", "3 roads dropped"]


# ------------------------------------------------------------------------------ each long command

def test_export_of_a_run_shows_each_phase_and_prints_the_same(tmp_path, a_run):
    shown = simgap("export", a_run, "--out", tmp_path / "a", bars=True)
    plain = simgap("export", a_run, "--out", tmp_path / "b", bars=False)
    bars = drawn(shown.stderr)
    for phase in ("reading the scenario", "writing the road network", "reading roads back",
                  "checking against the schema", "checking lane centres"):
        assert_finished(bars, phase)
    assert drawn(plain.stderr) == {}
    same_stdout(shown.stdout.replace(str(tmp_path / "a"), "OUT"), plain.stdout.replace(str(tmp_path / "b"), "OUT"))


def test_render_shows_the_animations_frames(tmp_path, a_run):
    shown = simgap("render", a_run, "--out", tmp_path / "a", "--frame-every", "10", bars=True)
    plain = simgap("render", a_run, "--out", tmp_path / "b", "--frame-every", "10", bars=False)
    bars = drawn(shown.stderr)
    assert_finished(bars, "2D animation: frames")
    same_stdout(shown.stdout.replace(str(tmp_path / "a"), "OUT"), plain.stdout.replace(str(tmp_path / "b"), "OUT"))


@pytest.mark.slow
def test_render_3d_shows_the_videos_frames(tmp_path, a_run):
    shown = simgap("render", a_run, "--out", tmp_path / "a", "--3d", bars=True)
    bars = drawn(shown.stderr)
    assert_finished(bars, "3D video offscreen: frames")
    assert sorted(Path(line.split()[-1]).name for line in shown.stdout.splitlines()) == sorted(
        ["scene.png", "run.gif", "scene3d_chase.png", "scene3d_birdseye.png", "scene3d.mp4", "side_by_side.png"])


def test_experiment_run_and_report_show_their_runs_and_pages(tmp_path):
    (tmp_path / "spec.yaml").write_text(SPEC)
    shown = simgap("experiment", "run", tmp_path / "spec.yaml", "--out", tmp_path / "exp", "--workers", "1",
                   "--no-validate", bars=True)
    bars = drawn(shown.stderr)
    assert bars["runs"][-1]["counts"] == "2 done, 0 failed, 0 earlier, 0 to run"
    assert_finished(bars, "reading runs", total=2)                  # the experiment's report
    assert_finished(bars, "scenario pages", total=2)
    assert "\x1b[" not in shown.stdout and "elapsed," not in shown.stdout and "2 runs: 2 ran now" in shown.stdout

    report = simgap("report", tmp_path / "exp" / "runs", "--out", tmp_path / "r1", bars=True)
    plain = simgap("report", tmp_path / "exp" / "runs", "--out", tmp_path / "r2", bars=False)
    bars = drawn(report.stderr)
    for phase in ("reading runs", "comparing runs with their ideal run", "scenario pages"):
        assert_finished(bars, phase, total=2)
    same_stdout(report.stdout.replace(str(tmp_path / "r1"), "OUT"), plain.stdout.replace(str(tmp_path / "r2"), "OUT"))


def test_generate_of_many_scenarios_shows_them_and_prints_the_same(tmp_path):
    shown = simgap("generate", "curve", "--set", "radius=50", "--no-preview", "--out", tmp_path / "a", bars=True)
    plain = simgap("generate", "curve", "--set", "radius=50", "--no-preview", "--out", tmp_path / "b", bars=False)
    written = len(list((tmp_path / "a").glob("*.xml")))
    assert written > 4 and drawn(shown.stderr)["generating curve"][-1]["counts"] == f"{written}/{written}"
    same_stdout(shown.stdout.replace(str(tmp_path / "a"), "OUT"), plain.stdout.replace(str(tmp_path / "b"), "OUT"))
