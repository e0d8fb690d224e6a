"""3D pictures and the chase-camera video of a run, rendered offscreen on the CPU."""

from __future__ import annotations

import imageio.v2 as imageio
import numpy as np

from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.report.scene3d import STILL, VIDEO, render_run_3d
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario
from simgap.sim.mujoco.replay import MujocoReplay


def _first_car(frame: np.ndarray) -> np.ndarray:
    """Where the first agent's car (painted blue) is in a frame: its pixels."""
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    return (b > 120) & (r < 50) & (b > g + 30)


def test_a_run_renders_in_3d_chase_birdseye_video_and_side_by_side(tmp_path):
    xml = write_scenario(build_scenario("t-junction", {}), tmp_path, preview=False)
    execute(RunRequest(scenario=xml, backend="ideal", cosim=CosimSettings(replan_every=3, max_time_s=4.0)),
            tmp_path / "run")
    written = render_run_3d(tmp_path / "run", tmp_path / "pictures", world=MujocoReplay, fps=5)
    names = sorted(p.name for p in written)
    assert names == ["scene3d.mp4", "scene3d_birdseye.png", "scene3d_chase.png", "side_by_side.png"]
    chase = imageio.imread(tmp_path / "pictures" / "scene3d_chase.png")
    birdseye = imageio.imread(tmp_path / "pictures" / "scene3d_birdseye.png")
    assert chase.shape[:2] == (STILL[1], STILL[0]) and birdseye.shape == chase.shape
    for image in (chase, birdseye):
        assert image.std() > 20                           # not blank
        grey = (np.abs(image[..., 0].astype(int) - image[..., 1]) < 8) & (image[..., 0] > 80) & (image[..., 0] < 140)
        assert grey.mean() > 0.02                         # asphalt is in the picture
    assert np.abs(chase.astype(int) - birdseye).mean() > 10
    assert imageio.imread(tmp_path / "pictures" / "side_by_side.png").std() > 20

    reader = imageio.get_reader(tmp_path / "pictures" / "scene3d.mp4", format="FFMPEG")
    meta = reader.get_meta_data()
    assert meta["codec"] == "h264" and meta["fps"] == 5 and tuple(meta["size"]) == VIDEO
    frames = [frame for frame in reader]
    assert len(frames) == 4 * 5 + 1                       # the run's 4 s, its first and last state
    height, width = frames[0].shape[:2]
    for frame in frames:
        car = _first_car(frame)
        assert car.mean() > 0.01                          # the car is in every frame ...
        rows, cols = np.nonzero(car)
        assert abs(cols.mean() / width - 0.5) < 0.15 and abs(rows.mean() / height - 0.5) < 0.2   # ... near its centre
    assert np.abs(frames[-1].astype(int) - frames[0]).mean() > 5      # while the world moves past


def test_a_run_on_a_crest_is_replayed_on_its_relief(tmp_path):
    """The run directory keeps the scenario's sidecar (driven.json), so the replay builds the
    road's relief even where the scenario file has gone."""
    xml = write_scenario(build_scenario("crest-curve", {"radius": 30, "vertical_radius": 100}), tmp_path, preview=False)
    execute(RunRequest(scenario=xml, backend="ideal", cosim=CosimSettings(replan_every=5, max_time_s=1.0)),
            tmp_path / "run")
    xml.unlink()
    xml.with_suffix(".json").unlink()
    built = []

    def world(scenario, vehicles, driven, dt, relief):
        built.append(relief)
        return MujocoReplay(scenario, vehicles, driven, dt, relief)

    render_run_3d(tmp_path / "run", tmp_path / "pictures", world=world, fps=2)
    (relief,) = built
    assert relief is not None and relief.profile.elevation.grade == 8.0
    assert relief.surface(np.array([60.0]), np.array([-1.5])).z[0] > 4.0      # 60 m up the 8 % grade
