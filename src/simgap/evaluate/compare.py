"""Cross-fidelity comparison of two runs of the same scenario, agent by agent.

Lateral displacement d is measured in the frame of the agent's route centre line and aligned by
arc length; position, orientation and velocity errors are aligned by time.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim.history import History
from simgap.evaluate.errors import (
    Aggregate,
    frenet_tracking_errors,
    interp_by_s,
    lateral_displacement_by_s,
    time_aligned_errors,
    tracking_errors,
)
from simgap.evaluate.route_centre import route_centre, section_of_s
from simgap.scenario.sections import RoadSections


@dataclass
class AgentComparison:
    agent_id: int
    s: np.ndarray                         # arc-length grid of the d comparison [m]
    d_a: np.ndarray                       # lateral offset of run A on that grid [m]
    d_b: np.ndarray
    lateral_displacement: Aggregate       # |d_b - d_a| by arc length
    position_error: Aggregate             # by time
    orientation_error: Aggregate
    velocity_error: Aggregate
    by_section: dict[str, Aggregate] = field(default_factory=dict)   # lateral displacement per section
    section_along_s: np.ndarray | None = None                         # road section kind at each s
    tracking_a: Aggregate | None = None      # planned vs driven position error within run A [m]
    tracking_b: Aggregate | None = None
    tracking_lateral_a: Aggregate | None = None       # ... its lateral part in the route's frame [m]
    tracking_lateral_b: Aggregate | None = None
    tracking_longitudinal_a: Aggregate | None = None  # ... and its longitudinal part [m]
    tracking_longitudinal_b: Aggregate | None = None

    def as_dict(self) -> dict:
        return {
            "agent_id": self.agent_id,
            "lateral_displacement": self.lateral_displacement.as_dict(),
            "position_error": self.position_error.as_dict(),
            "orientation_error": self.orientation_error.as_dict(),
            "velocity_error": self.velocity_error.as_dict(),
            "lateral_displacement_by_section": {k: v.as_dict() for k, v in self.by_section.items()},
            "tracking_error_a": self.tracking_a.as_dict() if self.tracking_a else None,
            "tracking_error_b": self.tracking_b.as_dict() if self.tracking_b else None,
            "lateral_tracking_error_a": self.tracking_lateral_a.as_dict() if self.tracking_lateral_a else None,
            "lateral_tracking_error_b": self.tracking_lateral_b.as_dict() if self.tracking_lateral_b else None,
            "longitudinal_tracking_error_a":
                self.tracking_longitudinal_a.as_dict() if self.tracking_longitudinal_a else None,
            "longitudinal_tracking_error_b":
                self.tracking_longitudinal_b.as_dict() if self.tracking_longitudinal_b else None,
        }


def compare_histories(a: History, b: History, scenario: Scenario, problems: PlanningProblemSet,
                      sections: RoadSections | None = None, ds: float = 0.5) -> list[AgentComparison]:
    """Run ``b`` against run ``a`` of the same scenario, agent by agent (agents with a route only)."""
    out = []
    for aid in sorted(set(a.driven) & set(b.driven)):
        problem = problems.planning_problem_dict[aid]
        frame = route_centre(scenario.lanelet_network, problem)
        if frame is None:
            continue
        ta, tb = a.driven[aid], b.driven[aid]
        s, dd = lateral_displacement_by_s(ta, tb, frame, ds)
        sa, da = frame.project(np.column_stack([ta.x, ta.y]))
        sb, db = frame.project(np.column_stack([tb.x, tb.y]))
        d_a, d_b = interp_by_s(s, sa, da), interp_by_s(s, sb, db)
        errs = time_aligned_errors(ta, tb)
        by_section, kinds = {}, None
        if sections and len(s):
            kinds = section_of_s(scenario.lanelet_network, problem, sections, s)
            for kind in dict.fromkeys(kinds):
                by_section[str(kind)] = Aggregate.of(dd[kinds == kind])
        fa = frenet_tracking_errors(ta, a.plans.get(aid, []), frame)
        fb = frenet_tracking_errors(tb, b.plans.get(aid, []), frame)
        out.append(AgentComparison(aid, s, d_a, d_b, Aggregate.of(dd), Aggregate.of(errs.position),
                                   Aggregate.of(errs.orientation), Aggregate.of(errs.velocity), by_section,
                                   kinds,
                                   Aggregate.of(tracking_errors(ta, a.plans.get(aid, [])).position),
                                   Aggregate.of(tracking_errors(tb, b.plans.get(aid, [])).position),
                                   Aggregate.of(fa.lateral), Aggregate.of(fb.lateral),
                                   Aggregate.of(fa.longitudinal), Aggregate.of(fb.longitudinal)))
    return out

