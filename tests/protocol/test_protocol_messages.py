"""The protocol's Python messages are the ones its .proto file defines."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

PROTOCOL = Path(__file__).resolve().parents[2] / "planner-protocol"


@pytest.mark.skipif(shutil.which("protoc") is None, reason="no protoc (Debian's protobuf-compiler; make planner-toolchain)")
def test_the_generated_python_messages_match_the_proto_file(tmp_path):
    subprocess.run(["protoc", f"--proto_path={PROTOCOL}", f"--python_out={tmp_path}", "simgap_planner.proto"],
                   check=True)
    committed = PROTOCOL / "python" / "simgap_planner" / "simgap_planner_pb2.py"
    assert (tmp_path / "simgap_planner_pb2.py").read_text() == committed.read_text(), \
        "regenerate: protoc --python_out=planner-protocol/python/simgap_planner simgap_planner.proto (in planner-protocol/)"


def test_a_trajectory_crosses_the_wire_unchanged():
    import numpy as np
    from simgap_planner import simgap_planner_pb2 as pb
    from simgap_planner.messages import STATE_FIELDS, Trajectory, trajectory_message, trajectory_of

    rng = np.random.default_rng(0)
    sent = Trajectory(0.1, **{f: rng.normal(size=31) for f in STATE_FIELDS})
    wire = trajectory_message(sent, pb.Trajectory()).SerializeToString()
    received = trajectory_of(pb.Trajectory.FromString(wire))
    assert received.dt == 0.1
    for f in STATE_FIELDS:
        assert np.array_equal(getattr(received, f), getattr(sent, f))
    with pytest.raises(ValueError, match="not a whole number"):
        trajectory_of(pb.Trajectory(dt=0.1, t=b"\x00" * 7))
