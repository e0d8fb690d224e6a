"""3D pictures of a run, rendered offscreen on the CPU."""

from __future__ import annotations

import imageio.v2 as imageio
import numpy as np

from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.report.scene3d import ANIMATION, STILL, render_run_3d
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario
from simgap.sim.mujoco.replay import MujocoReplay


def test_a_run_renders_in_3d_chase_birdseye_animation_and_side_by_side(tmp_path):
    xml = write_scenario(build_scenario("t-junction", {}), tmp_path, preview=False)
    execute(RunRequest(scenario=xml, backend="ideal", cosim=CosimSettings(replan_every=3, max_time_s=4.0)),
            tmp_path / "run")
    written = render_run_3d(tmp_path / "run", tmp_path / "pictures", frame_every=5, world=MujocoReplay)
    names = sorted(p.name for p in written)
    assert names == ["scene3d.gif", "scene3d_birdseye.png", "scene3d_chase.png", "side_by_side.png"]
    chase = imageio.imread(tmp_path / "pictures" / "scene3d_chase.png")
    birdseye = imageio.imread(tmp_path / "pictures" / "scene3d_birdseye.png")
    assert chase.shape[:2] == (STILL[1], STILL[0]) and birdseye.shape == chase.shape
    for image in (chase, birdseye):
        assert image.std() > 20                           # not blank
        grey = (np.abs(image[..., 0].astype(int) - image[..., 1]) < 8) & (image[..., 0] > 80) & (image[..., 0] < 140)
        assert grey.mean() > 0.02                         # asphalt is in the picture
    assert np.abs(chase.astype(int) - birdseye).mean() > 10
    frames = imageio.mimread(tmp_path / "pictures" / "scene3d.gif")
    assert len(frames) == 41 // 5 + 1 and frames[0].shape[:2] == (ANIMATION[1], ANIMATION[0])
    assert imageio.imread(tmp_path / "pictures" / "side_by_side.png").std() > 20
