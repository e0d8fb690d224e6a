"""Scenarios: road geometry, lanes and markings, junctions, planning problems, logical scenarios
(templates plus parameter spaces) and CommonRoad XML in and out."""

from simgap.scenario.files import load_scenario, write_scenario
from simgap.scenario.logical import LogicalScenario, build_scenario, builtin_names, load_logical
from simgap.scenario.sidecar import ScenarioSidecar, read_sidecar
from simgap.scenario.templates import ConcreteScenario

__all__ = ["ConcreteScenario", "LogicalScenario", "ScenarioSidecar", "build_scenario", "builtin_names", "load_logical",
           "load_scenario", "read_sidecar", "write_scenario"]
