"""Why a physical run parted from the ideal run: which of the planner's assumptions it broke, and
by how much (`explain`).

A run in a physical world breaks some of the assumptions the ideal world makes for the planner
(`simgap.sim.assumptions.Assumption`): the ones its settings declare and its values break (the
vehicle's actuators, a localisation that is not exact, latency, a relief, a friction other than
dry). Each counterfactual world is the run's own request as a replay makes it from the record
(`simgap.experiment.replay`: the scenario, vehicles, planners, loop settings and seed it kept, and
its plans' measured latencies) with a subset of them restored (`counterfactual`); every subset is run,
2^n worlds for the n assumptions the run breaks (at most 5, so the attribution is exact), beside
the ideal run, and each is compared with the ideal run by `evaluate`'s comparison (the gap: max
|d| against the ideal run by arc length, over the stretch of route the explained run drove — a
world that drives on past where the run left the road is measured where the run was —, and the
lateral tracking error). The run itself is the world where none holds: its record is read, not
rerun. An explanation is kept beside the run's record (``explanation.json``), where the report
draws it.

Per assumption the attribution reports its Shapley share of the gap (the mean, over the orders of
restoring them, of how much restoring it narrows the gap), of the lateral tracking error and of
the score (its score drop); whether restoring it alone brings the outcome back to the ideal run's
(leave-one-out); and the smallest sets that do. The vehicle model (``vehicle_dynamics``) has no
restoration apart from the others — its counterfactual is the ideal world itself — so it is the
base: its share is the perfect machine's gap against the ideal run (every other assumption
restored). The shares then add up to the run's gap exactly (Shapley's efficiency); what no single
restoration explains alone is the interaction (``interaction_m``).
"""

from __future__ import annotations

import itertools
import json
import math
import tempfile
import time
from collections.abc import Iterable, Iterator, Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from simgap.cosim import REFERENCE, History, Outcome
from simgap.errors import InputError
from simgap.evaluate.closed_loop_score import closed_loop_scores
from simgap.evaluate.compare import compare_histories
from simgap.experiment import fork_server
from simgap.experiment.replay import recorded_scenario, replay_request
from simgap.experiment.single_run import RunRequest, scene_of, simulated
from simgap.files import atomic_write_text
from simgap.record import RunRecord, read_run
from simgap.scenario import load_scenario
from simgap.sim.assumptions import Assumption, restorations, restoring
from simgap.sim.protocol import Realism
from simgap.sim.settings import TrackingSettings, realism_of

BASE = Assumption.VEHICLE_DYNAMICS
EXACT_UP_TO = 5          # assumptions restored apart (every one the worlds declare): 2^5 worlds at most


#: what breaking an assumption does to the car, and what restoring it gives (the explanation's sentence)
CAUSE = {Assumption.VEHICLE_DYNAMICS: "its body does not move as the plan's model says",
         Assumption.ACTUATORS: "its actuators act late", Assumption.SENSING: "its localisation drifts",
         Assumption.LATENCY: "its plans reach it late", Assumption.RELIEF: "the road is not flat",
         Assumption.FRICTION: "its road grips less than a dry one"}
RESTORED = {Assumption.ACTUATORS: "instant actuators", Assumption.SENSING: "exact sensing",
            Assumption.LATENCY: "plans without latency", Assumption.RELIEF: "a flat road",
            Assumption.FRICTION: "a dry road's friction"}
_DOES = {Outcome.OFF_ROAD: "leaves the road", Outcome.COLLISION: "collides",
         Outcome.TIMEOUT: "misses its goal's deadline", Outcome.PLANNER_FAILURE: "is left without a plan",
         Outcome.DIVERGED: "leaves the physics' world", Outcome.GOAL_REACHED: "reaches the goal"}
_BRINGS = {Outcome.GOAL_REACHED: "brings it to the goal"}


@dataclass(frozen=True)
class World:
    """One counterfactual world's run, against the ideal run."""

    restored: frozenset[Assumption]
    outcome: Outcome
    gap_m: float             # max |d| against the ideal run [m], where the explained run drove
    tracking_m: float        # max lateral tracking error (plan against car) [m]
    score: float             # the closed-loop score (the worst agent's)
    wall_s: float
    cpu_s: float = 0.0       # the processor time its run took, in a worker or the explaining process (0: the
                             # explained run's own record)

    def as_json(self) -> dict[str, Any]:
        return {"restored": sorted(self.restored), "outcome": str(self.outcome), "gap_m": self.gap_m,
                "tracking_m": self.tracking_m, "score": self.score, "wall_s": self.wall_s, "cpu_s": self.cpu_s}

    @classmethod
    def of_json(cls, d: Mapping[str, Any]) -> World:
        return cls(frozenset(Assumption(a) for a in d["restored"]), Outcome(d["outcome"]), float(d["gap_m"]),
                   float(d["tracking_m"]), float(d["score"]), float(d["wall_s"]), float(d.get("cpu_s", 0.0)))


@dataclass(frozen=True)
class AssumptionShare:
    """One assumption's part in a run's gap."""

    name: Assumption
    share_m: float            # Shapley share of the gap [m] (the base: the perfect machine's gap)
    tracking_share_m: float   # ... of the lateral tracking error [m]
    score_drop: float         # ... of the score's drop from the ideal run's
    fixes_outcome: bool       # restoring it alone brings the outcome back to the ideal run's

    def as_json(self) -> dict[str, Any]:
        return {"name": str(self.name), "share_m": self.share_m, "fixes_outcome": self.fixes_outcome,
                "score_drop": self.score_drop, "tracking_share_m": self.tracking_share_m}

    @classmethod
    def of_json(cls, d: Mapping[str, Any]) -> AssumptionShare:
        return cls(Assumption(d["name"]), float(d["share_m"]), float(d["tracking_share_m"]), float(d["score_drop"]),
                   bool(d["fixes_outcome"]))


@dataclass(frozen=True)
class Attribution:
    """Why a run parted from the ideal run (see the module doc)."""

    run: str
    scenario_id: str
    backend: str
    vehicle: str
    outcome: Outcome
    ideal_outcome: Outcome
    gap_m: float
    tracking_m: float
    assumptions: tuple[AssumptionShare, ...]          # largest first (see `_attribution`)
    fixing_sets: tuple[tuple[Assumption, ...], ...]   # the smallest sets whose restoration fixes the outcome
    interaction_m: float      # the gap's part no single restoration explains alone
    runs: int                 # runs made (the counterfactuals and the ideal run)
    wall_s: float
    run_wall_s: float         # the explained run's own wall time
    workers: int
    worlds: tuple[World, ...] = field(default=())
    cpu_s: float = 0.0        # the explanation's processor time: the explaining process's and its workers'

    @property
    def outcome_broken(self) -> bool:
        return self.outcome != self.ideal_outcome

    def as_json(self) -> dict[str, Any]:
        return {"run": self.run, "scenario_id": self.scenario_id, "backend": self.backend, "vehicle": self.vehicle,
                "outcome": str(self.outcome), "ideal_outcome": str(self.ideal_outcome), "gap_m": self.gap_m,
                "tracking_m": self.tracking_m, "assumptions": [a.as_json() for a in self.assumptions],
                "fixing_sets": [[str(a) for a in s] for s in self.fixing_sets], "interaction_m": self.interaction_m,
                "runs": self.runs, "wall_s": self.wall_s, "run_wall_s": self.run_wall_s, "workers": self.workers,
                "worlds": [w.as_json() for w in self.worlds], "cpu_s": self.cpu_s}

    @classmethod
    def of_json(cls, d: Mapping[str, Any]) -> Attribution:
        """An attribution as `as_json` wrote it (``explanation.json``)."""
        return cls(str(d["run"]), str(d["scenario_id"]), str(d["backend"]), str(d["vehicle"]), Outcome(d["outcome"]),
                   Outcome(d["ideal_outcome"]), float(d["gap_m"]), float(d["tracking_m"]),
                   tuple(AssumptionShare.of_json(a) for a in d["assumptions"]),
                   tuple(tuple(Assumption(a) for a in s) for s in d["fixing_sets"]), float(d["interaction_m"]),
                   int(d["runs"]), float(d["wall_s"]), float(d["run_wall_s"]), int(d["workers"]),
                   tuple(World.of_json(w) for w in d.get("worlds") or ()), float(d.get("cpu_s", 0.0)))

    def sentence(self) -> str:
        """The explanation in a sentence: what the car did, the assumption that most caused it, and
        what restoring it does."""
        top = self.assumptions[0]
        car = f"the {self.vehicle}"
        what = _DOES[self.outcome] if self.outcome_broken else f"parts from the ideal run by {self.gap_m:.2f} m"
        if top.name is BASE:
            return f"{car} {what} because {CAUSE[BASE]}: the perfect machine parts from the ideal run by " \
                   f"{top.share_m:.2f} m"
        cause = f"{car} {what} because {CAUSE[top.name]}"
        if not self.outcome_broken:
            return f"{cause}: restoring {RESTORED[top.name]} narrows the gap by {top.share_m:.2f} m"
        brings = _BRINGS.get(self.ideal_outcome, f"ends it as the ideal run ({self.ideal_outcome})")
        if top.fixes_outcome:
            return f"{cause}: restoring {RESTORED[top.name]} alone {brings}"
        if self.fixing_sets:
            return f"{cause}: restoring {_and(RESTORED[a] for a in self.fixing_sets[0])} {brings}"
        return f"{cause}, and no restoration {brings}: {CAUSE[BASE]}"

    def lines(self) -> list[str]:
        """The human explanation: one line per assumption, largest share first, then the sentence."""
        out = [f"{self.scenario_id} ({self.backend}, {self.vehicle}): {self.outcome} (the ideal run: "
               f"{self.ideal_outcome}); gap {self.gap_m:.3f} m (max |d| against the ideal run), lateral tracking "
               f"error {self.tracking_m:.3f} m"]
        for a in self.assumptions:
            part = f"{100 * a.share_m / self.gap_m:5.1f} %" if self.gap_m > 0 else "    — "
            fixes = "restoring it alone fixes the outcome" if a.fixes_outcome else \
                "base (the perfect machine against the ideal run)" if a.name is BASE else ""
            out.append(f"  {a.name:<16} {a.share_m:7.3f} m {part}  tracking {a.tracking_share_m:6.3f} m  "
                       f"score drop {a.score_drop:6.3f}  {fixes}".rstrip())
        if self.outcome_broken:
            sets = "; ".join("{" + ", ".join(s) + "}" for s in self.fixing_sets) or "none"
            out.append(f"smallest sets whose restoration fixes the outcome: {sets}")
        out.append(f"interaction (no single restoration explains it alone): {self.interaction_m:.3f} m")
        out.append(self.sentence())
        out.append(f"{self.runs} runs in {self.wall_s:.1f} s on {self.workers} workers (the run itself: "
                   f"{self.run_wall_s:.1f} s)")
        return out


def _and(words: Iterable[str]) -> str:
    words = list(words)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def broken_assumptions(record: RunRecord, request: RunRequest) -> tuple[Assumption, ...]:
    """The assumptions ``record``'s run broke that a counterfactual can restore apart (its world's
    settings declare them, and their values break them), in `Assumption`'s order."""
    settings, cosim = request.backend_settings, request.cosim
    declared = set(restorations(settings))
    real = realism_of(settings) is Realism.REAL
    if isinstance(settings, TrackingSettings) and real:
        declared |= set(restorations(cosim))
    breaks = {
        Assumption.ACTUATORS: isinstance(settings, TrackingSettings)
        and not all(settings.actuators(a.history.vehicle).ideal for a in record.agents),
        Assumption.SENSING: real and record.settings.sensing_accuracy is not None
        and not record.settings.sensing_accuracy.exact,
        Assumption.LATENCY: real and cosim.latency != 0.0,
        Assumption.FRICTION: restoring(settings, {Assumption.FRICTION}) != settings,
        Assumption.RELIEF: scene_of(request).relief is not None,     # the scenario's relief, or a tilt laid on it
    }
    return tuple(a for a in Assumption if a in declared and breaks.get(a, False))


def counterfactual(request: RunRequest, holding: Iterable[Assumption]) -> RunRequest:
    """``request`` in the world where the assumptions ``holding`` hold: its backend's and its loop's
    settings with their declared restorations put in (a flat twin of the road for ``relief``)."""
    holding = frozenset(holding)
    return replace(request, backend_settings=restoring(request.backend_settings, holding),
                   cosim=restoring(request.cosim, holding), flat_road=request.flat_road or Assumption.RELIEF in holding)


def ideal_request(request: RunRequest) -> RunRequest:
    """``request`` in the ideal world: every assumption holds."""
    return replace(request, backend=REFERENCE, backend_settings=None, replayed_latencies=None, flat_road=False)


@dataclass(frozen=True)
class _Ran:
    """What a worker returns of a run: its history, and each agent's score."""

    history: History
    scores: tuple[float, ...]
    wall_s: float
    cpu_s: float


def _run(request: RunRequest) -> _Ran:
    """``request``'s co-simulation and each agent's closed-loop score: all a world gives the
    attribution (its outcome, path and score); not the rest of a run's evaluation, its record or
    its files."""
    started, cpu = time.perf_counter(), time.process_time()
    run = simulated(request)
    scores = closed_loop_scores(run.history, run.scene.scenario, run.scene.problems, request.evaluation.score,
                                request.cosim.offroad_tolerance, road=run.scene.road, obstacles=run.scene.obstacles)
    return _Ran(run.history, tuple(0.0 if a.id not in scores else float(scores[a.id].score) for a in run.history.agents),
                time.perf_counter() - started, time.process_time() - cpu)


def _scores(record: RunRecord) -> tuple[float, ...]:
    return tuple(0.0 if a.score is None else float(a.score) for a in record.evaluation.agents)


EXPLANATION_FILE = "explanation.json"       # an explained run's attribution, beside its record


def write_explanation(run_dir: str | Path, attribution: Attribution) -> Path:
    """Keep ``attribution`` in its run directory (atomically), where the report finds it."""
    return atomic_write_text(Path(run_dir) / EXPLANATION_FILE, json.dumps(attribution.as_json(), indent=2))


def read_explanation(run_dir: str | Path) -> Attribution | None:
    """The attribution kept in ``run_dir`` (None: the run was not explained)."""
    path = Path(run_dir) / EXPLANATION_FILE
    if not path.is_file():
        return None
    try:
        return Attribution.of_json(json.loads(path.read_text()))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"cannot read the run's explanation ({type(exc).__name__}: {exc})", file=path,
                         allowed="the explanation.json simgap explain wrote; explain the run again") from None


def explain(run_dir: str | Path, workers: int = 2, assumptions: Iterable[Assumption] | None = None,
            keep: bool = True) -> Attribution:
    """Explain the run in ``run_dir`` (see the module doc): its counterfactual worlds run on
    ``workers`` processes (1: in this one); ``assumptions``: restore only these of those it broke
    (default: all); ``keep``: write it into the run directory (`EXPLANATION_FILE`)."""
    started, cpu = time.perf_counter(), time.process_time()
    if workers > 1:     # the fork server loads what a run imports while this process reads the run
        fork_server.start()
    run_dir = Path(run_dir)
    record = read_run(run_dir)
    if record.history.backend == REFERENCE:
        raise InputError("the run is in the ideal world, which is the planner's assumptions: nothing to explain",
                         file=run_dir, field="backend", allowed="a run in a physical world (dynamic, mujoco, beamng)")
    with tempfile.TemporaryDirectory(prefix="simgap-explain-") as scratch:
        # the run's own request, as a replay makes it: the scenario its record keeps, its vehicles,
        # planners, settings and seed, and its plans' latencies where they were measured
        request = replace(replay_request(record, recorded_scenario(run_dir, record, Path(scratch))),
                          validate=False, criticality=False)
        present = broken_assumptions(record, request)
        if assumptions is not None:
            present = tuple(a for a in present if a in set(assumptions))
        subsets = [frozenset(c) for k in range(1, len(present) + 1) for c in itertools.combinations(present, k)]
        requests = [ideal_request(request)] + [counterfactual(request, s) for s in subsets]
        scenario, problems = load_scenario(request.scenario)
        # the ideal run (the shortest) first, then the sets from the smallest: the larger (restored, a
        # car drives on further) are the longest, and this process takes them from the end while the
        # workers start (`_run_all`); each world is compared with the ideal run as it ends
        ran: dict[int, _Ran] = {}
        compared: dict[frozenset[Assumption], World] = {}
        in_workers = 0.0            # the processor time of the runs the workers made (this process's is counted)
        for index, r, in_worker in _run_all(requests, workers, list(range(len(requests)))):
            ran[index] = r
            in_workers += r.cpu_s if in_worker else 0.0
            if 0 not in ran:
                continue
            if index == 0:
                stretch = {c.agent_id: float(c.s[-1]) for c in
                           compare_histories(ran[0].history, record.history, scenario, problems) if len(c.s)}
            for i in [i for i in ran if i and subsets[i - 1] not in compared]:
                compared[subsets[i - 1]] = _world(subsets[i - 1], ran[i], ran[0].history, scenario, problems, stretch)
    ideal = ran[0]
    own = _Ran(record.history, _scores(record), record.history.wall_time_s, 0.0)
    worlds: dict[frozenset[Assumption], World] = \
        {frozenset(): _world(frozenset(), own, ideal.history, scenario, problems, stretch)} | {s: compared[s] for s in subsets}
    attribution = _attribution(run_dir, record, present, worlds, ideal, len(requests), time.perf_counter() - started,
                               max(1, workers), time.process_time() - cpu + in_workers)
    if keep:
        write_explanation(run_dir, attribution)
    return attribution


def _run_all(requests: list[RunRequest], workers: int, order: list[int]) -> Iterator[tuple[int, _Ran, bool]]:
    """The runs of ``requests``, started in ``order`` (their indices), each as it ends with its index
    and whether a worker made it, on ``workers`` processes forked from a server that has loaded what
    a run imports once (never forked from this process: a fork of a process with threads can
    deadlock). This process
    works beside them: it runs the first itself, then, from the end of the queue, each run no worker
    has taken yet — while the server loads (seconds) the workers take none, and after that three
    processes share the rest (put the longest runs last)."""
    if workers <= 1:
        yield from ((i, _run(requests[i]), False) for i in order)
        return
    with ProcessPoolExecutor(max_workers=min(workers, len(requests)), mp_context=fork_server.context()) as pool:
        futures = {pool.submit(_run, requests[i]): i for i in order[1:]}
        yield order[0], _run(requests[order[0]]), False
        for future in reversed(list(futures)):
            if not future.cancel():         # the workers have come this far: the rest is theirs
                break
            yield futures[future], _run(requests[futures[future]]), False
        for future in as_completed([f for f in futures if not f.cancelled()]):
            yield futures[future], future.result(), True


def _world(restored: frozenset[Assumption], ran: _Ran, ideal: History, scenario: Any, problems: Any,
           stretch: Mapping[int, float]) -> World:
    """A world's run against the ideal run; its gap over the ``stretch`` of route (agent -> arc
    length) the explained run drove, so that every world is measured where the run itself was (a
    world that drives on past where the run left the road adds no gap beyond it)."""
    history = ran.history
    comparisons = compare_histories(ideal, history, scenario, problems)
    gaps = [float(np.max(np.abs(c.d_b - c.d_a)[c.s <= stretch.get(c.agent_id, np.inf)], initial=0.0))
            for c in comparisons if len(c.s)]
    tracking = [c.tracking_lateral_b.max for c in comparisons if c.tracking_lateral_b is not None]
    return World(restored, Outcome.worst([a.outcome for a in history.agents]), _max(gaps), _max(tracking),
                 min(ran.scores, default=0.0), ran.wall_s, ran.cpu_s)


def _max(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return max(finite, default=0.0)


def shapley(players: tuple[Assumption, ...], value: Mapping[frozenset[Assumption], float]) -> dict[Assumption, float]:
    """Each player's Shapley share of ``value`` (given for every subset of ``players``) lost from
    the empty set to the full one: the weighted mean of value(S) - value(S ∪ {a}) over the subsets S
    without a. The shares add up to value(∅) - value(players)."""
    n = len(players)
    shares = {}
    for a in players:
        others = [p for p in players if p != a]
        total = 0.0
        for k in range(n):
            weight = math.factorial(k) * math.factorial(n - k - 1) / math.factorial(n)
            for c in itertools.combinations(others, k):
                s = frozenset(c)
                total += weight * (value[s] - value[s | {a}])
        shares[a] = total
    return shares


def _attribution(run_dir: Path, record: RunRecord, present: tuple[Assumption, ...],
                 worlds: dict[frozenset[Assumption], World], ideal: _Ran, runs: int, wall_s: float,
                 workers: int, cpu_s: float) -> Attribution:
    everything = frozenset(present)
    actual, machine = worlds[frozenset()], worlds[everything]
    ideal_outcome = Outcome.worst([a.outcome for a in ideal.history.agents])
    ideal_score = min(ideal.scores, default=0.0)
    gap = shapley(present, {s: w.gap_m for s, w in worlds.items()})
    tracking = shapley(present, {s: w.tracking_m for s, w in worlds.items()})
    drop = shapley(present, {s: -w.score for s, w in worlds.items()})
    broken = actual.outcome != ideal_outcome
    fixes = {a: broken and worlds[frozenset({a})].outcome == ideal_outcome for a in present}
    shares = [AssumptionShare(a, gap[a], tracking[a], drop[a], fixes[a]) for a in present]
    shares.append(AssumptionShare(BASE, machine.gap_m, machine.tracking_m, ideal_score - machine.score, False))
    # largest first: when the outcome broke, by what the outcome cost (restoring it alone fixes it,
    # then the score drop) — the gap, measured only as far as the run went, cannot see a car that
    # left the road early — else by the share of the gap
    shares.sort(key=(lambda a: (-a.fixes_outcome, -a.score_drop, -a.share_m)) if broken else (lambda a: -a.share_m))
    fixing: list[tuple[Assumption, ...]] = []
    if broken:
        for k in range(1, len(present) + 1):
            fixing = [tuple(a for a in present if a in s) for s, w in worlds.items()
                      if len(s) == k and w.outcome == ideal_outcome]
            if fixing:
                break
    alone = sum(actual.gap_m - worlds[frozenset({a})].gap_m for a in present)
    agent = next((a for a in record.agents if a.history.outcome != Outcome.GOAL_REACHED), record.agents[0])
    return Attribution(str(run_dir), record.scenario_id, record.history.backend, agent.history.vehicle.name,
                       actual.outcome, ideal_outcome, actual.gap_m, actual.tracking_m, tuple(shares),
                       tuple(sorted(fixing)), actual.gap_m - machine.gap_m - alone, runs, wall_s,
                       record.history.wall_time_s, workers, tuple(worlds.values()), cpu_s)

