from pathlib import Path

import pytest

from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario


@pytest.fixture(scope="session")
def curve_xml(tmp_path_factory) -> Path:
    """A short curve with one planning problem (a few seconds of driving)."""
    return write_scenario(build_scenario("curve", {"radius": 30.0, "angle": 45.0}), tmp_path_factory.mktemp("curve"),
                          preview=False)
