"""Draw docs/images/loop.png, the co-simulation loop of `simgap.cosim.loop` as the page "The
fidelities and the loop" explains it: observe -> plan -> latency -> controller and actuators ->
physics -> monitors, once per scenario step dt, the stages the ideal world skips dashed.

Run it again after changing the loop: ``python docs/images/make_loop_diagram.py``.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

OUT = Path(__file__).with_name("loop.png")
BOTH, PHYSICAL = "#dbe9f6", "#fde0c5"     # stages of every world; stages the ideal world skips

# (title, what it does, box centre, whether the ideal world skips it), round the loop clockwise
STAGES = [
    ("1 observe", "the planner sees its car\nthrough its localisation:\na drifting, late estimate",
     (2.0, 4.0), True),
    ("2 plan", "plan(state, t, world) every\nreplan_every steps; no\nplan: brake in lane", (6.0, 4.0),
     False),
    ("3 latency", "the plan reaches the car its\ncompute time later, in whole\ncycles (measured) or fixed",
     (10.0, 4.0), True),
    ("4 controller, actuators", "track the plan in force at\ncontroller_hz; steering and\npedals lag and saturate",
     (10.0, 1.0), True),
    ("5 physics", "ideal: the car is set onto its\nplan at t + dt; dynamic, mujoco,\nbeamng: the car's dynamics",
     (6.0, 1.0), False),
    ("6 monitors", "collision, off road, goal,\ntimeout, diverged: each\nends its agent's run", (2.0, 1.0), False),
]
WIDTH, HEIGHT = 3.3, 1.9


def _arrow(ax, start: tuple[float, float], end: tuple[float, float], **style) -> None:
    ax.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=16, lw=1.4, color="#333333", **style))


def main() -> Path:
    fig, ax = plt.subplots(figsize=(9.5, 5.4))
    ax.set_xlim(0.1, 11.9)
    ax.set_ylim(-1.4, 5.1)
    ax.axis("off")
    for title, text, (x, y), skipped in STAGES:
        ax.add_patch(FancyBboxPatch((x - WIDTH / 2, y - HEIGHT / 2), WIDTH, HEIGHT, boxstyle="round,pad=0.05",
                                    fc=PHYSICAL if skipped else BOTH, ec="#333333", lw=1.2,
                                    ls="--" if skipped else "-"))
        ax.text(x, y + 0.6, title, ha="center", va="center", fontsize=11, weight="bold")
        ax.text(x, y - 0.25, text, ha="center", va="center", fontsize=9)
    gap = 0.08
    for (_, _, (x0, y0), _), (_, _, (x1, y1), _) in zip(STAGES, STAGES[1:]):
        if y0 == y1:                      # along a row
            sign = 1 if x1 > x0 else -1
            _arrow(ax, (x0 + sign * (WIDTH / 2 + gap), y0), (x1 - sign * (WIDTH / 2 + gap), y1))
        else:                             # down the right-hand side
            _arrow(ax, (x0, y0 - HEIGHT / 2 - gap), (x1, y1 + HEIGHT / 2 + gap))
    (x_last, y_last), (x_first, y_first) = STAGES[-1][2], STAGES[0][2]
    _arrow(ax, (x_last, y_last + HEIGHT / 2 + gap), (x_first, y_first - HEIGHT / 2 - gap))
    ax.text(x_first + 0.12, (y_first + y_last) / 2, "next dt", ha="left", va="center", fontsize=9, style="italic")
    ax.add_patch(FancyBboxPatch((0.3, -0.89), 0.45, 0.28, boxstyle="round,pad=0.02", fc=BOTH, ec="#333333"))
    ax.text(0.9, -0.75, "every world", va="center", fontsize=9)
    ax.add_patch(FancyBboxPatch((3.0, -0.89), 0.45, 0.28, boxstyle="round,pad=0.02", fc=PHYSICAL, ec="#333333",
                                ls="--"))
    ax.text(3.6, -0.75, "the ideal world skips it: its planner sees the true state, its plan drives the car\n"
            "at once, and the car is set onto the plan (a physical world of realism ideal keeps\n"
            "only its controller and its physics)", va="center", fontsize=9)
    fig.savefig(OUT, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return OUT


if __name__ == "__main__":
    print(main())
