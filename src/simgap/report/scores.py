"""The scores in the report: per planner and fidelity the closed-loop score and the CommonRoad
solution's cost and validity, where over the scenario parameters the score drops from the ideal
world, and on each scenario's page every run's breakdown (components, partial costs, the reason a
solution is invalid)."""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Sequence

import numpy as np

from simgap.cosim import REFERENCE
from simgap.evaluate.closed_loop_score import COMPONENTS
from simgap.evaluate.run_evaluation import AgentEvaluation
from simgap.evaluate.score_drop import score_drop
from simgap.evaluate.settings import ScoreWeights
from simgap.experiment.run_row import RunRow
from simgap.report.collection import ScenarioGroup

SCORES_NOTE = ("<p>score: the closed-loop score (built like nuPlan's CLS: the multipliers at-fault collisions, "
               "drivable area, driving direction and making progress times the weighted mean of progress, time to "
               "collision, speed limit and comfort); drop: the ideal run's score minus this one's, and the component "
               "that would give most of it back; cost: the driven trajectory's cost as a CommonRoad solution (its "
               "benchmark's cost function); valid: by commonroad-drivability-checker, with the first reason when "
               "not.</p>")


def _largest(totals: dict[str, float], n: int) -> list[tuple[str, float]]:
    """The ``n`` largest totals, largest first (ties in the order they were added)."""
    return sorted(totals.items(), key=lambda item: item[1], reverse=True)[:n]


def _weights(entry) -> ScoreWeights:
    return entry.run.settings.evaluation.score.weights


def agent_drops(group: ScenarioGroup, fidelity: str) -> list[tuple[AgentEvaluation, float, list]]:
    """Each agent of ``fidelity``'s run: (the agent, its score drop from the ideal run, the losses)."""
    ideal, entry = group.reference, group.runs.get(fidelity)
    if ideal is None or entry is None:
        return []
    out = []
    reference = {a.id: a for a in ideal.run.evaluation.agents}
    for agent in entry.run.evaluation.agents:
        if agent.id in reference:
            drop, losses = score_drop(reference[agent.id], agent, _weights(entry))
            out.append((agent, drop, losses))
    return out


def run_score_drop(group: ScenarioGroup, fidelity: str) -> float:
    """The largest score drop of any agent of ``fidelity``'s run against the ideal run (NaN: none)."""
    drops = [d for _, d, _ in agent_drops(group, fidelity) if math.isfinite(d)]
    return max(drops) if drops else math.nan


def score_rows(groups: Sequence[ScenarioGroup], variants: list[tuple[str, str]]) -> list[dict]:
    """Per planner and fidelity: mean and lowest score, mean drop from the ideal run and the
    component that lost most of it, mean cost, and how many solutions are valid."""
    rows = []
    for planner, fidelity in variants:
        mine = [g for g in groups if g.planner == planner and fidelity in g.runs]
        agents = [a for g in mine for a in g.runs[fidelity].run.evaluation.agents]
        scores = [a.score for a in agents if a.score is not None]
        costs = [a.solution_cost for a in agents if a.solution_cost is not None]
        checked = [a for a in agents if a.solution_valid is not None]
        drops: list[float] = []
        lost: defaultdict[str, float] = defaultdict(float)      # score lost per component
        for g in mine:
            for _, drop, losses in agent_drops(g, fidelity):
                if math.isfinite(drop):
                    drops.append(drop)
                    for c in losses:
                        lost[c.name] += c.regained
        reasons = Counter(_reason_kind(a.solution_reason) for a in checked if a.solution_valid is False)
        row = {"planner": planner, "fidelity": fidelity, "agents": len(agents),
               "mean score": float(np.mean(scores)) if scores else "—",
               "lowest score": min(scores) if scores else "—"}
        top = _largest(lost, 1)
        row |= {"mean drop": float(np.mean(drops)) if drops else "—",
                "largest drop": max(drops) if drops else "—",
                "lost most on": top[0][0] if top and top[0][1] > 1e-9 else "—"}
        row |= {"mean cost": float(np.mean(costs)) if costs else "—",
                "valid solutions": f"{sum(a.solution_valid is True for a in checked)}/{len(checked)}" if checked else "—",
                "invalid because": ", ".join(f"{k} ({n})" for k, n in reasons.most_common()) or "—"}
        rows.append(row)
    return rows


def _reason_kind(reason: str) -> str:
    """The kind of an invalid solution's first reason (infeasible, collision, goal not reached, ...)."""
    for kind in ("infeasible", "goal not reached", "collision with obstacle", "collision with agent",
                 "leaves the road boundary", "does not start", "drove no step", "the check raised"):
        if kind in reason:
            return kind
    return reason.split(" (")[0] or "unknown"


def score_drop_maps(groups: Sequence[ScenarioGroup], fidelities: list[str], planners: list[str], xp: str,
                    yp: str) -> dict[tuple[str, str], list[tuple[float, float, float, ScenarioGroup]]]:
    """Per (fidelity, planner): the score drop from the ideal run at each (xp, yp) of the scenario
    parameters, with the scenario's group (fidelities without a drop left out)."""
    maps = {}
    for fidelity in fidelities:
        if fidelity == REFERENCE:
            continue
        for planner in planners:
            points = [(float(g.parameters[xp]), float(g.parameters[yp]), run_score_drop(g, fidelity), g)
                      for g in groups if g.planner == planner and fidelity in g.runs
                      and xp in g.parameters and yp in g.parameters]
            if any(math.isfinite(p[2]) for p in points):
                maps[(fidelity, planner)] = points
    return maps


def breakdown_rows(group: ScenarioGroup) -> list[dict]:
    """Every run's agents: score, components, the drop from the ideal run, the solution's cost and
    partial costs, its validity and first reason."""
    rows = []
    for fidelity, entry in group.runs.items():
        drops = {a.id: (d, losses) for a, d, losses in agent_drops(group, fidelity)} if fidelity != REFERENCE else {}
        for a in entry.run.evaluation.agents:
            if a.score is None:
                continue
            drop, losses = drops.get(a.id, (math.nan, []))
            row = {"fidelity": fidelity, "agent": a.id, "score": a.score}
            row |= {name: a.score_components.get(name, math.nan) for name in COMPONENTS}
            row |= {"drop": drop if fidelity != REFERENCE else "—",
                    "lost most on": next((c.name for c in losses if c.regained > 1e-9), "—") if losses else "—",
                    "cost": a.solution_cost if a.solution_cost is not None else (a.solution_cost_error or "—"),
                    "partial costs (weighted)": ", ".join(f"{k} {c.weighted:.0f}"
                                                          for k, c in a.solution_partial_costs.items()) or "—",
                    "solution": {True: "valid", False: f"invalid: {a.solution_reason}",
                                 None: "not checked"}[a.solution_valid]}
            rows.append(row)
    return rows


def _scored(row: RunRow) -> AgentEvaluation:
    """A store row's scores as an agent's evaluation (the worst agent's, as the row keeps them)."""
    return AgentEvaluation(0, None, 0.0, None, score=row.score,
                           score_components={name: v for name, v in row.score_components.items()
                                             if v is not None and not math.isnan(v)})


def store_score_rows(rows: list[RunRow]) -> list[dict]:
    """Per planner and non-ideal fidelity of an experiment's store: the mean ideal and physical
    score, the mean and largest drop, the component whose loss explains most of it (summed over
    the runs), the mean costs, and how many solutions valid in the ideal world are invalid here, by
    their first reason."""
    ok = [r for r in rows if r.status == "ok"]
    ideal = {(r.id.scenario, r.id.planner): r for r in ok if r.id.fidelity.backend == REFERENCE}
    out = []
    for planner, fidelity in sorted({(r.id.planner, r.id.fidelity.label) for r in ok
                                     if r.id.fidelity.backend != REFERENCE}):
        pairs = [(ideal[(r.id.scenario, planner)], r) for r in ok
                 if r.id.planner == planner and r.id.fidelity.label == fidelity and (r.id.scenario, planner) in ideal]
        pairs = [(a, b) for a, b in pairs if _known(a.score) and _known(b.score)]
        if not pairs:
            continue
        drops: list[float] = []
        lost: defaultdict[str, float] = defaultdict(float)      # score lost per component
        for a, b in pairs:
            drop, losses = score_drop(_scored(a), _scored(b), ScoreWeights())
            drops.append(drop)
            for c in losses:
                lost[c.name] += c.regained
        broken = [b for a, b in pairs if a.solution_valid is True and b.solution_valid is False]
        reasons = Counter(_reason_kind(b.solution_reason or "") for b in broken)
        top = [(name, total) for name, total in _largest(lost, 2) if total > 1e-9]
        out.append({"planner": planner, "fidelity": fidelity, "runs": len(pairs),
                    "ideal score": float(np.mean([a.score for a, _ in pairs])),
                    "score": float(np.mean([b.score for _, b in pairs])),
                    "mean drop": float(np.mean(drops)), "largest drop": float(max(drops)),
                    "runs that lost": sum(d > 1e-9 for d in drops),
                    "lost most on": ", ".join(f"{name} ({total / len(pairs):.3f})" for name, total in top) or "—",
                    "ideal cost": _mean(a.solution_cost for a, _ in pairs),
                    "cost": _mean(b.solution_cost for _, b in pairs),
                    "ideal valid": sum(a.solution_valid is True for a, _ in pairs),
                    "valid": sum(b.solution_valid is True for _, b in pairs),
                    "ideal-valid now invalid": len(broken),
                    "because": ", ".join(f"{k} ({n})" for k, n in reasons.most_common()) or "—"})
    return out


def _known(value: float | None) -> bool:
    return value is not None and not math.isnan(value)


def _mean(values) -> float:
    known = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(known)) if known else math.nan
