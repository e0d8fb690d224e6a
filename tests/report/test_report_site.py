"""The HTML report of a small real experiment, opened in a real headless browser."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.record import read_run
from simgap.report.scene2d import render_run
from simgap.report.scene3d import write_video
from simgap.report.site import build_report
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CURVES = [{"radius": 20, "angle": 30}, {"radius": 20, "angle": 90}, {"radius": 40, "angle": 30},
          {"radius": 40, "angle": 90}]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    root = tmp_path_factory.mktemp("experiment")
    cosim = CosimSettings(replan_every=3, max_time_s=8.0)
    for params in CURVES:
        xml = write_scenario(build_scenario("curve", params), root / "scenarios", preview=False)
        for backend, vehicle in (("ideal", "sedan"), ("mujoco", "city")):
            run_dir = root / "runs" / xml.stem / backend
            execute(RunRequest(scenario=xml, backend=backend, vehicles=vehicle, cosim=cosim, validate=True), run_dir)
    render_run(root / "runs" / xml.stem / "mujoco", animation=False)
    write_video(root / "runs" / xml.stem / "mujoco" / "scene3d.mp4",         # as `simgap render --3d` leaves it
                (np.full((180, 320, 3), 10 * k, dtype=np.uint8) for k in range(10)), fps=5)
    index = build_report(root / "runs", root / "report")
    return index


def _open(page: Path, profile: Path) -> tuple[str, str]:
    proc = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                           "--disable-background-networking", "--disable-component-update", "--disable-sync",
                           f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                           "--virtual-time-budget=5000", "--dump-dom", page.as_uri()],
                          capture_output=True, text=True, timeout=120)
    return proc.stdout, proc.stderr


def test_the_report_is_one_folder_of_pages_and_pictures(report):
    out = report.parent
    pages = sorted(out.rglob("*.html"))
    assert len(pages) == 1 + len(CURVES)
    text = report.read_text()
    for fragment in ("Headline numbers", "Where the gap is largest", "class='heatmap'", "Run times per fidelity",
                     "Scenarios, largest gap first", "mujoco/city", "median [s]", "std [s]",
                     "Scores per planner and fidelity", "mean score", "valid solutions", "Where the score drops"):
        assert fragment in text
    # the heatmaps cover radius x angle: four cells with hover text, each linking to its page
    assert len(re.findall(r"title='angle \[deg\] = \d+, radius \[m\] = \d+: [\d.]+ m'", text)) == len(CURVES)
    assert len(re.findall(r"title='angle \[deg\] = \d+, radius \[m\] = \d+: -?[\d.]+'", text)) == len(CURVES)
    # every run's breakdown on its scenario's page: both worlds, every component, the cost, the verdict
    scenario_page = (out / "scenarios" / f"{sorted(p.stem for p in (out / 'scenarios').glob('*.html'))[0]}.html")
    page = scenario_page.read_text()
    for fragment in ("<h2>Scores</h2>", "at_fault_collisions", "time_to_collision", "comfort", "partial costs",
                     "invalid: goal not reached"):
        assert fragment in page
    # the physical run's timeline (why it parted from its plan), drawn from the commands its record holds;
    # none of the ideal run, which cannot part
    assert "timeline_mujoco-city_1.png" in page and "timeline_ideal" not in page
    mujoco = read_run(next((out.parent / "runs").glob("*/mujoco"))).history.agents[0]
    assert mujoco.controls is not None and np.diff(mujoco.controls.t) == pytest.approx(0.01)
    for ref in re.findall(r"(?:src|href)='([^']+)'", text):
        if not ref.startswith(("data:", "http")):
            assert (out / ref).exists(), ref
    assert not any("http://" in p.read_text() or "https://" in p.read_text() for p in pages)
    # every table scrolls sideways in its own box rather than widening the page
    assert text.count("<table") == text.count("<div class='table-box'><table") > 0
    assert ".table-box { overflow-x: auto" in (out / "report.css").read_text()
    # a run's 3D video plays in its scenario's page
    videos = [(p, ref) for p in pages for ref in re.findall(r"<video src='([^']+)'", p.read_text())]
    assert [(p.parent.name, Path(ref).name) for p, ref in videos] == [("scenarios", "mujoco-city_scene3d.mp4")]
    assert (videos[0][0].parent / videos[0][1]).stat().st_size > 1000


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (make test installs it)")
def test_every_page_loads_in_chromium_without_console_errors_and_with_its_images(report, tmp_path):
    pages = [report] + sorted((report.parent / "scenarios").glob("*.html"))
    for page in pages:
        dom, log = _open(page, tmp_path / "profile")
        console = [line for line in log.splitlines() if ":CONSOLE" in line]
        assert not console, f"{page.name}: {console}"
        match = re.search(r'data-images="([^"]*)"', dom)
        assert match, f"{page.name}: the page did not finish loading"
        assert match.group(1).startswith("ok "), f"{page.name}: {match.group(1)}"
        videos = re.search(r'data-videos="([^"]*)"', dom)
        assert videos and videos.group(1).startswith("ok "), f"{page.name}: {videos and videos.group(1)}"
        images = int(match.group(1).split()[1])
        assert images >= (1 if page == report else 4), page.name       # heatmap; d, v, paths, boxes
    scenario_pages = [p.read_text() for p in pages[1:]]
    assert any("mujoco-city_scene.png" in text for text in scenario_pages)   # the run's own 2D picture
    assert all("class='zoom'" in text for text in scenario_pages)
