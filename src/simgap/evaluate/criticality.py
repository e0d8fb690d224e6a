"""Criticality of a driven scenario, per ordered agent pair, from commonroad-crime.

The driven scenario holds every agent as a dynamic obstacle (`simgap.cosim.driven_scenario`).
For each pair (ego, other) the measures are evaluated every ``every`` steps and the most
critical value is kept: the smallest time-to-collision (TTC) and time headway (THW), the
largest brake threat number (BTN) and steer threat number (STN). A step at which CriMe cannot
evaluate a measure (for instance a vehicle between lanelets) is skipped and counted.
"""

from __future__ import annotations

import copy
import logging
import math
import os
import pickle
import sys
import tempfile
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import permutations
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.cosim.driven_scenario import driven_scenario
from simgap.cosim.history import AGENT_ID_OFFSET, History

# measure name -> (CriMe class name, True when smaller values are more critical)
MEASURES = {"ttc": ("TTC", True), "thw": ("THW", True), "btn": ("BTN", False), "stn": ("STN", False)}


@dataclass(frozen=True)
class PairCriticality:
    ego_id: int
    other_id: int
    measure: str
    worst: float          # inf / 0 when the pair never came into conflict
    at_t: float | None
    skipped_steps: int


def pair_criticality(driven: Scenario, obstacle_ids: dict[int, int], every: int = 5,
                     measures: tuple[str, ...] = tuple(MEASURES)) -> list[PairCriticality]:
    """``obstacle_ids``: agent id -> its obstacle id in ``driven``."""
    with _one_builder():                                         # slow to import: only when measured
        import commonroad_crime.measure as crime_measures
    from commonroad_crime.data_structure.configuration import CriMeConfiguration

    if len(obstacle_ids) < 2:
        return []
    driven.assign_obstacles_to_lanelets()
    with _quiet(), _lanes_smoothed_once(), _copied_from_bytes(driven):
        return _pairs(driven, obstacle_ids, every, measures, crime_measures, CriMeConfiguration)


@contextmanager
def _copied_from_bytes(driven: Scenario):
    """CriMe deep-copies the scenario into every measure it builds (ten per pair: TTC builds a
    headway, BTN and STN a required acceleration, each with its own): most of a pair's time. Each
    measure still gets a copy of its own (they change theirs), but read from the scenario pickled
    once here: the same objects, in about half the time of `copy.deepcopy`'s walk."""
    from commonroad_crime.data_structure import base

    pickled = pickle.dumps(driven, protocol=pickle.HIGHEST_PROTOCOL)
    base.copy = SimpleNamespace(
        deepcopy=lambda obj, memo=None: pickle.loads(pickled) if obj is driven else copy.deepcopy(obj, memo))
    try:
        yield
    finally:
        base.copy = copy


@contextmanager
def _lanes_smoothed_once():
    """CriMe smooths a lanelet's centre line and borders (a B-spline fit) each time a measure asks for
    the lane's width and orientation at a position: at every step, for every measure and pair, the
    same three polylines again (five sixths of a pair's time). The fit depends on the polyline
    alone: kept here for the duration of a call, each copied out, so every value is what it was."""
    from commonroad_crime.utility import solver

    smooth = solver.smoothing_reference_path
    fitted: dict[tuple, np.ndarray] = {}

    def once(reference_path, smooth_factor=None, weight_coefficient=None):
        path = np.asarray(reference_path)
        key = (path.shape, path.dtype.str, path.tobytes(), smooth_factor, weight_coefficient)
        if key not in fitted:
            fitted[key] = smooth(reference_path, smooth_factor, weight_coefficient)
        return fitted[key].copy()

    solver.smoothing_reference_path = once
    try:
        yield
    finally:
        solver.smoothing_reference_path = smooth


@contextmanager
def _one_builder():
    """One process at a time through CriMe's first import: commonroad-reach compiles a Cython module
    there (pyximport, into ~/.pyxbld, again whenever its source is newer than the build), and a
    second process loading it while the first writes it fails (an experiment's workers, the test
    suite's)."""
    import fcntl

    lock = Path(tempfile.gettempdir()) / "simgap-pyximport.lock"
    with open(lock, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@contextmanager
def _quiet():
    """CriMe's libraries talk on the process's standard output and error (LAPACK's complaints about
    DLASCL, logged errors of its lane smoothing) where a measure is undefined; the measure is then
    skipped and counted, and they are silenced here."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    try:
        with open(os.devnull, "w") as null, warnings.catch_warnings():
            for fd in saved:
                os.dup2(null.fileno(), fd)
            warnings.simplefilter("ignore")
            logging.disable(logging.CRITICAL)
            yield
    finally:
        logging.disable(logging.NOTSET)
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)


def _pairs(driven, obstacle_ids, every, measures, crime_measures, CriMeConfiguration) -> list[PairCriticality]:
    out = []
    for ego, other in permutations(sorted(obstacle_ids), 2):
        ego_obs = driven.obstacle_by_id(obstacle_ids[ego])
        other_obs = driven.obstacle_by_id(obstacle_ids[other])
        last = min(_last_step(ego_obs), _last_step(other_obs))
        for name in measures:
            cls_name, smaller_is_worse = MEASURES[name]
            worst, at, skipped = (math.inf if smaller_is_worse else 0.0), None, 0
            steps = range(0, last + 1, every)
            if ego_obs.prediction is None:          # an agent that never moved (it had not entered the road)
                out.append(PairCriticality(ego, other, name, worst, at, len(steps)))
                continue
            config = CriMeConfiguration()
            config.update(ego_id=obstacle_ids[ego], sce=driven)
            measure = getattr(crime_measures, cls_name)(config)
            for k in steps:
                try:
                    value = float(measure.compute(obstacle_ids[other], k, verbose=False))
                except Exception:  # CriMe raises assorted errors where a measure is undefined
                    skipped += 1
                    continue
                if math.isnan(value):
                    skipped += 1
                    continue
                if (value < worst) if smaller_is_worse else (value > worst):
                    worst, at = value, k * driven.dt
            out.append(PairCriticality(ego, other, name, worst, at, skipped))
    return out


def run_criticality(history: History, scenario: Scenario) -> tuple[PairCriticality, ...]:
    """`pair_criticality` of every agent pair of ``history`` in its driven scenario (none for one agent)."""
    if len(history.agents) < 2:
        return ()
    driven = driven_scenario(scenario, history)
    return tuple(pair_criticality(driven, {a.id: AGENT_ID_OFFSET + a.id for a in history.agents}))


def _last_step(obstacle) -> int:
    prediction = obstacle.prediction
    if prediction is None:
        return obstacle.initial_state.time_step
    return prediction.trajectory.state_list[-1].time_step
