"""Criticality of a driven scenario, per ordered agent pair, from commonroad-crime.

The driven scenario holds every agent as a dynamic obstacle (see `export.driven_scenario`).
For each pair (ego, other) the measures are evaluated every ``every`` steps and the most
critical value is kept: the smallest time-to-collision (TTC) and time headway (THW), the
largest brake threat number (BTN) and steer threat number (STN). A step at which CriMe cannot
evaluate a measure (for instance a vehicle between lanelets) is skipped and counted.
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import asdict, dataclass
from itertools import permutations
from pathlib import Path
from typing import Iterable

from commonroad.common.file_reader import CommonRoadFileReader
from commonroad.scenario.scenario import Scenario

from simgap.cosim.record import AGENT_ID_OFFSET

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
    import commonroad_crime.measure as crime_measures           # slow to import: only when measured
    from commonroad_crime.data_structure.configuration import CriMeConfiguration

    if len(obstacle_ids) < 2:
        return []
    driven.assign_obstacles_to_lanelets()
    out = []
    for ego, other in permutations(sorted(obstacle_ids), 2):
        ego_obs = driven.obstacle_by_id(obstacle_ids[ego])
        other_obs = driven.obstacle_by_id(obstacle_ids[other])
        last = min(_last_step(ego_obs), _last_step(other_obs))
        for name in measures:
            cls_name, smaller_is_worse = MEASURES[name]
            config = CriMeConfiguration()
            config.update(ego_id=obstacle_ids[ego], sce=driven)
            measure = getattr(crime_measures, cls_name)(config)
            worst, at, skipped = (math.inf if smaller_is_worse else 0.0), None, 0
            for k in range(0, last + 1, every):
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        logging.disable(logging.WARNING)
                        value = float(measure.compute(obstacle_ids[other], k, verbose=False))
                except Exception:  # CriMe raises assorted errors where a measure is undefined
                    skipped += 1
                    continue
                finally:
                    logging.disable(logging.NOTSET)
                if math.isnan(value):
                    skipped += 1
                    continue
                if (value < worst) if smaller_is_worse else (value > worst):
                    worst, at = value, k * driven.dt
            out.append(PairCriticality(ego, other, name, worst, at, skipped))
    return out


def run_criticality(run_dir: Path, agent_ids: Iterable[int]) -> list[dict]:
    """`pair_criticality` of the driven scenario a run directory holds (``driven.xml``), as rows."""
    agent_ids = list(agent_ids)
    if len(agent_ids) < 2:
        return []
    driven, _ = CommonRoadFileReader(str(Path(run_dir) / "driven.xml")).open()
    return [asdict(r) for r in pair_criticality(driven, {aid: AGENT_ID_OFFSET + aid for aid in agent_ids})]


def _last_step(obstacle) -> int:
    prediction = obstacle.prediction
    if prediction is None:
        return obstacle.initial_state.time_step
    return prediction.trajectory.state_list[-1].time_step
