"""The report of a search: for each strategy, what it spent and what it found — distinct
violated assumptions over the budget, the failures on the parameter map, and the share of
ideal-world passes that fail in the high fidelity."""

from __future__ import annotations

import html
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from simgap.experiment.search.results import HighRun, SearchResults  # noqa: E402
from simgap.experiment.search.spec import DimensionKind  # noqa: E402
from simgap.planning.registry import DEFAULT_PLANNER  # noqa: E402
from simgap.report.plots import COLOURS, STYLES  # noqa: E402
from simgap.report.site import SCRIPT, STYLE, Raw, figure, page, table  # noqa: E402


def _violations(per_strategy: dict[str, list[HighRun]], dims, limit: int = 15) -> list[dict]:
    out = []
    for name, runs in per_strategy.items():
        found = sorted((h.row for h in runs if h.violation), key=lambda r: r.elapsed_s)[:limit]
        for r in found:
            entry = {"strategy": name, "run": Raw(f"<a href='../{html.escape(name)}/{html.escape(r.run.run_dir or '')}"
                                                 f"/run.json'>c{r.candidate:05d}</a>"), "vehicle": r.run.id.fidelity.vehicle,
                     "planner": r.run.id.planner or DEFAULT_PLANNER}
            entry |= {d.name: (r.run.parameters if d.kind is DimensionKind.PARAMETER else r.knobs).get(d.name, math.nan)
                      for d in dims}
            entry["why"] = r.failure_reason
            out.append(entry)
    return out


def _modes(results) -> list[dict]:
    """Each strategy's failure modes, the most common first, with the ranges of the dimensions
    they need and a link to the representative's run."""
    out = []
    for res in results:
        for m in res.modes:
            out.append({"strategy": res.name, "vehicle": m.vehicle, "planner": m.planner, "what broke": m.broke,
                        "needs": ", ".join(m.needs) or "no single dimension", "violations": m.count,
                        "ranges": "; ".join(f"{n} {m.ranges[n][0]:.3g}–{m.ranges[n][1]:.3g}" for n in m.needs),
                        "representative": Raw(f"<a href='../{html.escape(res.name)}/{html.escape(m.representative_run)}"
                                              f"/run.json'>c{m.representative:05d}</a>"),
                        "its values": ", ".join(f"{n} {v:.3g}" for n, v in m.representative_values.items())})
    return out


def _plot_curves(results, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    for k, res in enumerate(results):
        xs = [0.0] + [t / 60.0 for t, _ in res.curve] + [res.wall_s / 60.0]
        ys = [0] + [n for _, n in res.curve] + [res.distinct]
        ax.step(xs, ys, where="post", color=COLOURS[k % len(COLOURS)], linestyle=STYLES[k % len(STYLES)],
                linewidth=2, label=f"{res.name} ({res.distinct})")
    ax.set_xlabel("budget spent [min of wall clock]")
    ax.set_ylabel("distinct violated assumptions")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _map_axes(runs: list[HighRun], dims) -> tuple[int, int]:
    """The two dimensions that separate violations from passes best (difference of means)."""
    if len(dims) < 2:
        return 0, 0
    fail = [h.row for h in runs if h.violation]
    ok = [h.row for h in runs if not h.row.failed]
    if not fail or not ok:
        return 0, 1
    gaps = [abs(np.mean([r.unit[i] for r in fail]) - np.mean([r.unit[i] for r in ok])) for i in range(len(dims))]
    order = np.argsort(gaps)[::-1]
    return int(order[0]), int(order[1])


def _plot_map(per_strategy: dict[str, list[HighRun]], dims, path: Path) -> Path:
    every = [r for rows in per_strategy.values() for r in rows]
    a, b = _map_axes(every, dims)
    n = len(per_strategy)
    fig, axes = plt.subplots(1, n, figsize=(3.3 * n, 3.4), dpi=110, squeeze=False, sharey=True)
    na, loa, hia = dims[a].name, dims[a].low, dims[a].high
    nb, lob, hib = dims[b].name, dims[b].low, dims[b].high
    for ax, (name, rows) in zip(axes[0], per_strategy.items()):
        for group, style in ((lambda h: not h.row.failed, dict(c="#bbbbbb", marker="o", s=10, label="passes")),
                             (lambda h: h.row.failed and not h.violation, dict(c=COLOURS[1], marker="x", s=18, label="fails (ideal unchecked or fails too)")),
                             (lambda h: h.violation, dict(c=COLOURS[2], marker="^", s=24, label="violated assumption"))):
            pts = [h.row for h in rows if group(h)]
            if pts:
                ax.scatter([loa + r.unit[a] * (hia - loa) for r in pts],
                           [lob + r.unit[b] * (hib - lob) for r in pts], **style)
        ax.set_title(f"{name} ({len(rows)} high runs)", fontsize=9)
        ax.set_xlabel(na)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(nb)
    handles, labels = [], []
    for ax in axes[0]:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in labels:
                handles.append(h)
                labels.append(l)
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path)
    plt.close(fig)
    return path


def build_search_report(found: SearchResults) -> Path:
    """Write ``report/index.html`` in the search directory of ``found``."""
    spec, results = found.spec, found.strategies
    out = found.root / "report"
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.css").write_text(STYLE)
    (out / "report.js").write_text(SCRIPT)
    per_strategy = found.high_rows
    summary = []
    for res in results:
        rows = per_strategy[res.name]
        ideal_passes = len(rows) - sum(1 for h in rows if h.ideal_failed)
        summary.append({
            "strategy": res.name, "wall clock [min]": res.wall_s / 60.0, "runs": res.runs,
            "high-fidelity runs": res.high_runs, "high-fidelity failures": res.high_failures,
            "violated assumptions": res.violations, "distinct": res.distinct, "scenarios": res.scenarios,
            "reported (probed)": len(res.reported), "failure modes": len(res.modes),
            "CPU hours": res.cpu_s / 3600.0, "distinct per CPU hour": res.per_cpu_hour,
            "ideal passes failing high [%]": 100.0 * res.violations / ideal_passes if ideal_passes else math.nan,
            "run errors": res.errors})
    dims = spec.dimensions
    planners = ", ".join(html.escape(c.name) for c in spec.planners) if not spec.planner else DEFAULT_PLANNER
    body = [f"<p>Search <b>{spec.name}</b> on <code>{spec.logical}</code> with the planner{'s' if ',' in planners else ''} "
            f"{planners}: ladder "
            + " → ".join(r.backend for r in spec.ladder)
            + f"; objective <code>{spec.objective}</code>; distinct radius {spec.distinct_radius:g} (normalised).</p>"
            "<p><em>Distinct</em> counts violations after de-duplication over every dimension, reality knobs "
            "included; <em>scenarios</em> counts the different roads, starts, vehicles and planners among them (the same "
            "road under other knob settings is one scenario).</p>",
            "<p>A <em>violated assumption</em> passes in the ideal world and fails in the high fidelity. "
            "The ideal world is run where the high fidelity failed; a high-fidelity pass is taken as an "
            "ideal pass for the share below.</p>",
            table(summary, "what each strategy spent and found")]
    if results:
        body.append(figure(_plot_curves(results, out / "failures_over_budget.png").name,
                           "distinct violated assumptions over the budget spent"))
    if any(per_strategy.values()) and len(dims) >= 1:      # one dimension: drawn against itself
        body.append(figure(_plot_map(per_strategy, dims, out / "failure_map.png").name,
                           "high-fidelity runs on the two dimensions that separate violations from passes best",
                           zoom=True))
    body.append("<p>A <em>failure mode</em> groups the distinct violations of one vehicle and planner that broke "
                "the same way (what crossed the failure rule) and need the same dimensions: moving one of those "
                "back to nominal (a knob's default, a parameter's) makes the high-fidelity run stop failing that "
                "way; moving any other does not. Its representative is the member closest to nominal in the "
                "knobs. The search reports the distinct violations it probed, the worst first, within its "
                "budget; <em>reported</em> above counts them.</p>")
    body.append(table(_modes(results), "failure modes (the representative's link opens its high-fidelity run)"))
    body.append(table(_violations(per_strategy, spec.dimensions),
                      "violated assumptions (the first 15 of each strategy; the run links open its record)"))
    body.append(table([{"dimension": d.name, "kind": d.kind.value, "low": d.low, "high": d.high}
                       for d in spec.dimensions],
                      "the search space"))
    return page(out / "index.html", f"search: {spec.name}", body, "")

