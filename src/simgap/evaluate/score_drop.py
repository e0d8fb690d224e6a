"""How much of its closed-loop score an agent lost across fidelities, and on which components
(`score_drop`: the reference run's agent against the same agent in another run)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from simgap.evaluate.closed_loop_score import COMPONENTS, combine
from simgap.evaluate.run_evaluation import AgentEvaluation
from simgap.evaluate.settings import ScoreWeights


@dataclass(frozen=True)
class ComponentLoss:
    """How much of the score drop one component explains."""

    name: str
    a: float                 # its value in the reference run
    b: float                 # ... in the other run
    regained: float          # the other run's score with this component as in the reference, minus its score


def score_drop(a: AgentEvaluation, b: AgentEvaluation, weights: ScoreWeights) -> tuple[float, list[ComponentLoss]]:
    """``a``'s score minus ``b``'s, and the components that lost it, the largest loss first: each
    ranked by how much of ``b``'s score would come back if it alone were as in ``a``."""
    if a.score is None or b.score is None or not a.score_components or not b.score_components:
        return math.nan, []
    losses = []
    for name in COMPONENTS:
        ca, cb = a.score_components.get(name, math.nan), b.score_components.get(name, math.nan)
        restored = combine(dict(b.score_components) | {name: ca}, weights)
        losses.append(ComponentLoss(name, ca, cb, restored - b.score))
    losses.sort(key=lambda c: -c.regained)
    return a.score - b.score, losses
