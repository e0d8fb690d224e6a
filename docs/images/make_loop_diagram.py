"""Draw docs/images/loop.png, the co-simulation loop of `simgap.cosim.loop` as the page "The
fidelities and the loop" explains it: observe -> plan -> latency -> controller and actuators ->
physics -> monitors, once per scenario step dt, with the stages the ideal world skips greyed.

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

# (title, what it does, x centre, whether the ideal world skips it)
STAGES = [
    ("observe", "the planner sees its car\nthrough its localisation\n(drift, an old estimate)", 1.3, True),
    ("plan", "your planner: plan(state, t,\nworld) every replan_every\nsteps; none: brake in lane", 4.1, False),
    ("latency", "the plan reaches the car\nits compute time later,\nin whole cycles (measured)", 6.9, True),
    ("controller and\nactuators", "track the plan in force at\ncontroller_hz; steering and\npedals lag and saturate",
     9.7, True),
    ("physics", "ideal: the car is set onto\nits plan at t + dt; dynamic,\nmujoco: integrate the car", 12.5, False),
    ("monitors", "collision, off road, goal,\ntimeout, diverged: each\nends the agent's run", 15.3, False),
]


def main() -> Path:
    fig, ax = plt.subplots(figsize=(13.5, 4.2))
    ax.set_xlim(-0.1, 16.7)
    ax.set_ylim(-0.9, 4.3)
    ax.axis("off")
    width, height, y = 2.55, 2.1, 1.6
    for title, text, x, skipped in STAGES:
        ax.add_patch(FancyBboxPatch((x - width / 2, y - height / 2), width, height, boxstyle="round,pad=0.05",
                                    fc=PHYSICAL if skipped else BOTH, ec="#333333", lw=1.2,
                                    ls="--" if skipped else "-"))
        ax.text(x, y + 0.62, title, ha="center", va="center", fontsize=11, weight="bold")
        ax.text(x, y - 0.3, text, ha="center", va="center", fontsize=8)
    for (_, _, x0, _), (_, _, x1, _) in zip(STAGES, STAGES[1:]):
        ax.add_patch(FancyArrowPatch((x0 + width / 2 + 0.06, y), (x1 - width / 2 - 0.06, y), arrowstyle="-|>",
                                     mutation_scale=14, lw=1.3, color="#333333"))
    first, last = STAGES[0][2], STAGES[-1][2]
    ax.add_patch(FancyArrowPatch((last, y + height / 2 + 0.08), (first, y + height / 2 + 0.08),
                                 connectionstyle="arc3,rad=0.12", arrowstyle="-|>", mutation_scale=14, lw=1.3,
                                 color="#333333"))
    ax.text((first + last) / 2, 4.05, "every scenario step dt: the next step starts from the states the physics left",
            ha="center", fontsize=9)
    ax.add_patch(FancyBboxPatch((0.3, -0.45), 0.5, 0.3, boxstyle="round,pad=0.02", fc=BOTH, ec="#333333"))
    ax.text(0.95, -0.3, "every world", va="center", fontsize=9)
    ax.add_patch(FancyBboxPatch((3.0, -0.45), 0.5, 0.3, boxstyle="round,pad=0.02", fc=PHYSICAL, ec="#333333",
                                ls="--"))
    ax.text(3.65, -0.3, "the ideal world skips it: its planner sees the true state, its plan drives the car at once, "
            "and the car is set onto the plan\n(a physical world of realism ideal keeps only its controller and its physics)", va="center", fontsize=9)
    fig.savefig(OUT, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return OUT


if __name__ == "__main__":
    print(main())
