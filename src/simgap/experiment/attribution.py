"""Why a physical run parted from the ideal run: which of the planner's assumptions it broke, and
by how much (`explain`).

A run in a physical world breaks some of the assumptions the ideal world makes for the planner
(`simgap.sim.assumptions.Assumption`): the ones its settings declare and its values break (the
vehicle's actuators, a localisation that is not exact, latency, a relief, a friction other than
dry). Each counterfactual world is the run's own request as a replay makes it from the record
(`simgap.experiment.replay`: the scenario, vehicles, planners, loop settings and seed it kept, and
its plans' measured latencies) with a subset of them restored (`counterfactual`); every subset is run,
2^n worlds for the n assumptions the run breaks (at most 5, so the attribution is exact), beside
the ideal run. Every world is measured where the explained run itself was: its gap is max |d|
against the ideal run by arc length over the stretch of route the explained run drove, and its
lateral tracking error (plan against car) is the largest over that same stretch. The run itself
is the world where none holds: its record is read, not rerun. An explanation is kept beside the
run's record (``explanation.json``), where the report draws it.

Per assumption the attribution reports its Shapley share of the gap (the mean, over the orders of
restoring them, of how much restoring it narrows the gap) and of the lateral tracking error;
whether restoring it alone brings the outcome back to the ideal run's (leave-one-out), and the
score restoring it alone gives back (its score drop); and the smallest sets whose restoration
fixes the outcome. The vehicle model (``vehicle_dynamics``) has no restoration apart from the
others — its counterfactual is the ideal world itself — so it is the base: its share is the
perfect machine's gap against the ideal run (every other assumption restored), its score drop the
perfect machine's score against the ideal run's. The shares then add up to the run's gap exactly
(Shapley's efficiency); what no single restoration explains alone is the interaction
(``interaction_m``).

How each world ends is asked only of the ideal run, of each assumption restored alone, and of the
perfect machine. So when the explained run ended early (it left the road, collided, ...), every
other world — the sets of two to n - 1 assumptions, 2^n - n - 2 of them, the bulk for n > 3 — is
*cut*: it runs `CUT_MARGIN_S` past the explained run's end, far enough to measure it over the
stretch the run drove (a world is deterministic, so it is the prefix of its full run), and its own
end is not known (``outcome`` None, ``until_s`` the cut). When no single restoration fixes the
outcome, the cut sets still on the road are finished, the smallest first, to find the smallest sets
that fix it; a cut world that fell short of the stretch is finished too. This keeps an explanation
of a run that failed early from costing a full run per world.
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
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim import REFERENCE, CosimSettings, History, Outcome
from simgap.cosim.loop import deadline
from simgap.errors import InputError
from simgap.evaluate.closed_loop_score import closed_loop_scores
from simgap.evaluate.errors import frenet_tracking_errors, lateral_displacement_by_s
from simgap.evaluate.route_centre import route_centre
from simgap.experiment import fork_server
from simgap.experiment.replay import recorded_scenario, replay_request
from simgap.experiment.single_run import RunRequest, scene_of, simulated
from simgap.files import atomic_write_text
from simgap.record import RunRecord, read_run
from simgap.scenario import load_scenario
from simgap.scenario.goal import Goal
from simgap.scenario.road_frame import PathFrame
from simgap.sim.assumptions import Assumption, restorations, restoring
from simgap.sim.protocol import Realism
from simgap.sim.settings import TrackingSettings, realism_of

BASE = Assumption.VEHICLE_DYNAMICS
CUT_MARGIN_S = 1.0       # a cut world runs this long past the explained run's end [s]
GRID_M = 0.5             # the arc-length grid the gap is measured on [m]


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
    outcome: Outcome | None  # how it ended (None: still driving where it was cut)
    gap_m: float             # max |d| against the ideal run [m], where the explained run drove
    tracking_m: float        # max lateral tracking error (plan against car) [m], where the explained run drove
    score: float | None      # the closed-loop score (the worst agent's; None: cut)
    wall_s: float
    cpu_s: float = 0.0       # the processor time its run took, in a worker or the explaining process (0: the
                             # explained run's own record)
    until_s: float | None = None    # where it was cut [s of simulated time] (None: run to its end)

    @property
    def cut(self) -> bool:
        return self.until_s is not None

    def as_json(self) -> dict[str, Any]:
        return {"restored": sorted(self.restored), "outcome": None if self.outcome is None else str(self.outcome),
                "gap_m": self.gap_m, "tracking_m": self.tracking_m, "score": self.score, "wall_s": self.wall_s,
                "cpu_s": self.cpu_s, "until_s": self.until_s}

    @classmethod
    def of_json(cls, d: Mapping[str, Any]) -> World:
        return cls(frozenset(Assumption(a) for a in d["restored"]), None if d["outcome"] is None else Outcome(d["outcome"]),
                   float(d["gap_m"]), float(d["tracking_m"]), _optional(d["score"]),
                   float(d["wall_s"]), float(d.get("cpu_s", 0.0)), _optional(d.get("until_s")))


def _optional(value: Any) -> float | None:
    return None if value is None else float(value)


@dataclass(frozen=True)
class AssumptionShare:
    """One assumption's part in a run's gap."""

    name: Assumption
    share_m: float            # Shapley share of the gap [m] (the base: the perfect machine's gap)
    tracking_share_m: float   # ... of the lateral tracking error [m]
    score_drop: float         # the score restoring it alone gives back (the base: the ideal run's score over
                              # the perfect machine's)
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
        cut = [w.until_s for w in self.worlds if w.until_s is not None]
        cuts = f" ({len(cut)} cut at t = {cut[0]:.1f} s, past where the run ended)" if cut else ""
        out.append(f"{self.runs} runs{cuts} in {self.wall_s:.1f} s on {self.workers} workers (the run itself: "
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
    """What a worker returns of a run: its history, each agent's score (None: the world was cut,
    its end not run), and its times."""

    history: History
    scores: tuple[float, ...] | None
    wall_s: float
    cpu_s: float
    until_s: float | None = None      # where it was cut (None: it ran to its end)


@dataclass(frozen=True)
class _Job:
    """A world to run: its request, and where to cut it (None: run it to its end)."""

    restored: frozenset[Assumption]
    request: RunRequest
    until_s: float | None


def _run(request: RunRequest, until_s: float | None = None) -> _Ran:
    """``request``'s co-simulation and each agent's closed-loop score: all a world gives the
    attribution (its outcome, path and score); not the rest of a run's evaluation, its record or
    its files. ``until_s``: cut it there (simulated time); a world still driving there is cut (no
    outcome, no score), one that ended before it is whole."""
    started, cpu = time.perf_counter(), time.process_time()
    if until_s is not None:
        request = replace(request, cosim=request.cosim.model_copy(update={"max_time_s": until_s}))
    run = simulated(request)
    cut = until_s is not None and any(a.outcome == Outcome.TIMEOUT for a in run.history.agents)
    scores = None
    if not cut:
        by_agent = closed_loop_scores(run.history, run.scene.scenario, run.scene.problems, request.evaluation.score,
                                      request.cosim.offroad_tolerance, road=run.scene.road, obstacles=run.scene.obstacles)
        scores = tuple(0.0 if a.id not in by_agent else float(by_agent[a.id].score) for a in run.history.agents)
    return _Ran(run.history, scores, time.perf_counter() - started, time.process_time() - cpu,
                until_s if cut else None)


def _scores(record: RunRecord) -> tuple[float, ...]:
    return tuple(0.0 if a.score is None else float(a.score) for a in record.evaluation.agents)


def cut_time(record: RunRecord, problems: PlanningProblemSet, cosim: CosimSettings) -> float | None:
    """Where the counterfactual worlds that need not end may be cut: `CUT_MARGIN_S` past the end
    of ``record``'s run when it ended early (an agent failed: off the road, a collision, ...)
    before its deadline; None when it ran to its end."""
    history = record.history
    if all(a.outcome in (Outcome.GOAL_REACHED, Outcome.TIMEOUT) for a in history.agents):
        return None
    end = max((float(t.t_end) for t in history.driven.values() if len(t)), default=0.0)
    # before every agent's own deadline: the cut is every agent's deadline in a cut world, and an
    # agent that times out earlier in the whole world would drive on in the cut one
    first = min(deadline(Goal.of(p.goal, float(history.dt)), cosim) for p in problems.planning_problem_dict.values())
    return end + CUT_MARGIN_S if end + CUT_MARGIN_S < first - 1e-9 else None


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
        scenario, problems = load_scenario(request.scenario)
        until = cut_time(record, problems, request.cosim)
        jobs = [_Job(frozenset(), ideal_request(request), None)] + [
            _Job(s, counterfactual(request, s), None if len(s) in (1, len(present)) else until)
            for k in range(1, len(present) + 1) for s in map(frozenset, itertools.combinations(present, k))]
        # the ideal run (the shortest) first, then the sets from the smallest: the larger (restored, a
        # car drives on further) are the longest, and this process takes them from the end while the
        # workers start (`_run_all`); each world is measured against the ideal run as it ends
        ran: dict[int, _Ran] = {}
        worlds: dict[frozenset[Assumption], World] = {}
        short: set[frozenset[Assumption]] = set()       # cut worlds that fell short of the stretch
        in_workers = 0.0            # the processor time of the runs the workers made (this process's is counted)
        yardstick: _Yardstick | None = None
        for index, r, in_worker in _run_all(jobs, workers):
            ran[index] = r
            in_workers += r.cpu_s if in_worker else 0.0
            if 0 not in ran:
                continue
            if yardstick is None:
                yardstick = _Yardstick.of(ran[0].history, record.history, scenario, problems)
            for i in [i for i in ran if i and jobs[i].restored not in worlds]:
                worlds[jobs[i].restored], fell_short = yardstick.measure(jobs[i].restored, ran[i])
                if fell_short:
                    short.add(jobs[i].restored)
        assert yardstick is not None
        ideal = ran[0]
        ideal_outcome = Outcome.worst([a.outcome for a in ideal.history.agents])
        worlds[frozenset()], _ = yardstick.measure(frozenset(), _Ran(record.history, _scores(record),
                                                                     record.history.wall_time_s, 0.0))
        finished, cpu_finishing = _finish(worlds, short, present, ideal_outcome, request, yardstick, workers)
    attribution = _attribution(run_dir, record, present, worlds, ideal, ideal_outcome, len(jobs) + finished,
                               time.perf_counter() - started, max(1, workers),
                               time.process_time() - cpu + in_workers + cpu_finishing)
    if keep:
        write_explanation(run_dir, attribution)
    return attribution


def _finish(worlds: dict[frozenset[Assumption], World], short: set[frozenset[Assumption]],
            present: tuple[Assumption, ...], ideal_outcome: Outcome, request: RunRequest, yardstick: _Yardstick,
            workers: int) -> tuple[int, float]:
    """Run to their end the cut worlds the answer still needs (`_to_finish`), in ``worlds``; the
    runs made and the processor time the workers spent on them."""
    made, in_workers = 0, 0.0
    for group in _to_finish(worlds, short, present, ideal_outcome):
        jobs = [_Job(s, counterfactual(request, s), None) for s in group]
        made += len(jobs)
        for index, r, in_worker in _run_all(jobs, workers):
            worlds[jobs[index].restored], _ = yardstick.measure(jobs[index].restored, r)
            in_workers += r.cpu_s if in_worker else 0.0
    return made, in_workers


def _to_finish(worlds: Mapping[frozenset[Assumption], World], short: set[frozenset[Assumption]],
               present: tuple[Assumption, ...], ideal_outcome: Outcome) -> Iterator[list[frozenset[Assumption]]]:
    """The cut worlds to run to their end, in groups (``worlds`` is read again after each group has
    been run): those that fell short of the stretch the run drove (their gap is not whole); then,
    when the outcome broke and no single restoration fixes it, the cut sets of two, of three, ...,
    until a set of the size before fixes it (the smallest sets that fix it)."""
    if group := sorted((s for s in short if worlds[s].cut), key=sorted):
        yield group
    if worlds[frozenset()].outcome == ideal_outcome:
        return
    for k in range(1, len(present)):
        if any(w.outcome == ideal_outcome for s, w in worlds.items() if len(s) == k):
            return
        if group := sorted((s for s, w in worlds.items() if len(s) == k + 1 and w.cut), key=sorted):
            yield group


def _run_all(jobs: list[_Job], workers: int) -> Iterator[tuple[int, _Ran, bool]]:
    """The runs of ``jobs``, started in order, each as it ends with its index and whether a worker
    made it, on ``workers`` processes forked from a server that has loaded what a run imports once
    (never forked from this process: a fork of a process with threads can deadlock). This process
    works beside them: it runs the first itself, then, from the end of the queue, each run no worker
    has taken yet — while the server loads (seconds) the workers take none, and after that three
    processes share the rest (put the longest runs last)."""
    def run(i: int) -> _Ran:
        return _run(jobs[i].request, jobs[i].until_s)

    if workers <= 1 or len(jobs) == 1:
        yield from ((i, run(i), False) for i in range(len(jobs)))
        return
    with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=fork_server.context()) as pool:
        futures = {pool.submit(_run, jobs[i].request, jobs[i].until_s): i for i in range(1, len(jobs))}
        yield 0, run(0), False
        for future in reversed(list(futures)):
            if not future.cancel():         # the workers have come this far: the rest is theirs
                break
            yield futures[future], run(futures[future]), False
        for future in as_completed([f for f in futures if not f.cancelled()]):
            yield futures[future], future.result(), True


@dataclass(frozen=True)
class _Yardstick:
    """What every world is measured with: each agent's route frame, the ideal run, and the stretch
    of route (arc length) the explained run drove — so that every world is measured where the run
    itself was (a world that drives on past where the run left the road adds nothing beyond it)."""

    ideal: History
    frames: dict[int, PathFrame]
    stretch: dict[int, float]

    @classmethod
    def of(cls, ideal: History, run: History, scenario: Scenario, problems: PlanningProblemSet) -> _Yardstick:
        frames = {aid: frame for aid in sorted(ideal.driven) if aid in problems.planning_problem_dict
                  and (frame := route_centre(scenario.lanelet_network, problems.planning_problem_dict[aid])) is not None}
        stretch = {}
        for aid, frame in frames.items():
            if aid in run.driven:
                s, _ = lateral_displacement_by_s(ideal.driven[aid], run.driven[aid], frame, GRID_M)
                if len(s):
                    stretch[aid] = float(s[-1])
        return cls(ideal, frames, stretch)

    def measure(self, restored: frozenset[Assumption], ran: _Ran) -> tuple[World, bool]:
        """A world's run against the ideal run: its gap and its lateral tracking error over the
        stretch; and whether it was cut short of the stretch (the grids of the run and of a world
        that drove as far meet at its end: they start where both start)."""
        history = ran.history
        gaps, tracking, fell_short = [], [], False
        for aid, frame in self.frames.items():
            if aid not in history.driven:
                continue
            end = self.stretch.get(aid, np.inf)
            s, dd = lateral_displacement_by_s(self.ideal.driven[aid], history.driven[aid], frame, GRID_M)
            fell_short |= ran.until_s is not None and (not len(s) or s[-1] < end)
            if not len(s):
                continue
            gaps.append(float(np.max(np.abs(dd)[s <= end], initial=0.0)))
            errors = frenet_tracking_errors(history.driven[aid], history.plans.get(aid, []), frame)
            lateral = np.abs(errors.lateral[errors.s <= end])
            tracking.append(float(np.max(lateral[np.isfinite(lateral)], initial=0.0)))
        outcome = None if ran.until_s is not None else Outcome.worst([a.outcome for a in history.agents])
        score = None if ran.scores is None else min(ran.scores, default=0.0)
        return World(restored, outcome, _max(gaps), _max(tracking), score, ran.wall_s, ran.cpu_s, ran.until_s), fell_short


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
                 worlds: dict[frozenset[Assumption], World], ideal: _Ran, ideal_outcome: Outcome, runs: int,
                 wall_s: float, workers: int, cpu_s: float) -> Attribution:
    everything = frozenset(present)
    actual, machine = worlds[frozenset()], worlds[everything]
    assert actual.outcome is not None
    ideal_score = min(ideal.scores or (), default=0.0)
    gap = shapley(present, {s: w.gap_m for s, w in worlds.items()})
    tracking = shapley(present, {s: w.tracking_m for s, w in worlds.items()})
    broken = actual.outcome != ideal_outcome
    alone = {a: worlds[frozenset({a})] for a in present}
    fixes = {a: broken and alone[a].outcome == ideal_outcome for a in present}
    shares = [AssumptionShare(a, gap[a], tracking[a], _score(alone[a]) - _score(actual), fixes[a]) for a in present]
    shares.append(AssumptionShare(BASE, machine.gap_m, machine.tracking_m, ideal_score - _score(machine), False))
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
    alone_sum = sum(actual.gap_m - w.gap_m for w in alone.values())
    agent = next((a for a in record.agents if a.history.outcome != Outcome.GOAL_REACHED), record.agents[0])
    order = sorted(worlds, key=lambda s: (len(s), sorted(s)))
    return Attribution(str(run_dir), record.scenario_id, record.history.backend, agent.history.vehicle.name,
                       actual.outcome, ideal_outcome, actual.gap_m, actual.tracking_m, tuple(shares),
                       tuple(sorted(fixing)), actual.gap_m - machine.gap_m - alone_sum, runs, wall_s,
                       record.history.wall_time_s, workers, tuple(worlds[s] for s in order), cpu_s)


def _score(world: World) -> float:
    """A whole world's score (the ideal run, the run itself, each single restoration and the perfect
    machine are never cut)."""
    assert world.score is not None, f"the world restoring {sorted(world.restored)} was cut"
    return world.score
