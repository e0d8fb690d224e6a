"""The HTML report of a set of runs: one self-contained folder, opened as a file, no network.

``index.html`` — what was run, headline numbers per planner and fidelity, heatmaps of the largest
lateral displacement over the scenario parameters (the planners side by side; hover a cell for its
values), the runtime table, the time per planning call, outcomes, and the scenarios ranked by their
largest gap. ``scenarios/NAME-all-planners.html`` — a scenario that several planners ran: a row per planner and fidelity,
and d over s, v over t and the paths of every run on shared axes (each planner against its own ideal run).
``scenarios/NAME.html`` — one page per scenario (and planner, when runs have several): parameters, outcome and tracking per fidelity, the gaps against the ideal run, d over
s and v over t (wheel to zoom, drag to pan, double-click to reset) with lane and road edges and every
event marked, per physical run a timeline of why it parted from its plan (tracking error, steering and
acceleration requested against achieved, plan latency, sensing error), the paths from above, error
box plots, criticality of agent pairs, and the run's 2D and 3D pictures and its 3D video where they exist.
"""

from __future__ import annotations

import html
import math
import shutil
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np

from simgap.cosim import REFERENCE, Outcome
from simgap.cosim.fidelity import Realism
from simgap.errors import InputError
from simgap.evaluate.errors import lateral_profile
from simgap.evaluate.route_centre import route_centre
from simgap.evaluate.route_edges import event_places, route_edges
from simgap.evaluate.timeline import agent_timeline
from simgap.experiment.repeats import odds_over_repeats
from simgap.experiment.run_row import RunRow
from simgap.experiment.store import ResultsStore
from simgap.files import atomic_write_text, replace_directory
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.report.collection import ScenarioGroup, collect
from simgap.report.figures import (
    heatmap_colour,
    heatmap_grid,
    plot_error_boxes,
    plot_heatmap,
    plot_paths_from_above,
    runtime_table,
)
from simgap.report.plots import plot_d_over_s, plot_v_over_t, plot_waterfall
from simgap.report.scores import SCORES_NOTE, breakdown_rows, score_drop_maps, score_rows
from simgap.report.timeline import plot_timeline
from simgap.scenario.road_frame import PathFrame

PICTURES = ("side_by_side.png", "scene3d_chase.png", "scene3d_birdseye.png", "scene.png", "scene3d.mp4", "run.gif")

STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; padding: 0 1em; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.85em; }
th, td { border: 1px solid #bbb; padding: 3px 7px; text-align: right; }
th { background: #eee; } td.text { text-align: left; }
.good { color: #006d2c; } .bad { color: #a50f15; font-weight: bold; }
figure { display: inline-block; margin: 0 1em 1em 0; vertical-align: top; max-width: 100%; }
figure.half { max-width: 48%; }
figcaption { font-size: 0.85em; color: #555; }
img, video { max-width: 100%; border: 1px solid #ddd; }
.zoom { overflow: hidden; border: 1px solid #ddd; cursor: zoom-in; }
.zoom img { border: none; transform-origin: 0 0; display: block; }
table.heatmap td { text-align: center; min-width: 3.2em; }
.side { display: flex; flex-wrap: wrap; gap: 1.5em; align-items: flex-start; }
.side > div { max-width: 48%; }
nav { font-size: 0.9em; margin-bottom: 1em; }
.table-box { overflow-x: auto; max-width: 100%; }   /* a wide table scrolls in its own box, not the page */
.table-box table { margin: 0.4em 0; }
"""

SCRIPT = """
document.querySelectorAll('.zoom').forEach(function (box) {
  var img = box.querySelector('img'), s = 1, x = 0, y = 0, drag = null;
  function apply() { img.style.transform = 'translate(' + x + 'px,' + y + 'px) scale(' + s + ')'; }
  box.addEventListener('wheel', function (e) {
    e.preventDefault();
    var r = box.getBoundingClientRect(), px = e.clientX - r.left, py = e.clientY - r.top;
    var k = e.deltaY < 0 ? 1.25 : 0.8, ns = Math.min(12, Math.max(1, s * k));
    x = px - (px - x) * ns / s; y = py - (py - y) * ns / s; s = ns;
    if (s === 1) { x = 0; y = 0; }
    apply();
  }, {passive: false});
  box.addEventListener('mousedown', function (e) { drag = [e.clientX - x, e.clientY - y]; e.preventDefault(); });
  window.addEventListener('mouseup', function () { drag = null; });
  window.addEventListener('mousemove', function (e) { if (drag && s > 1) { x = e.clientX - drag[0]; y = e.clientY - drag[1]; apply(); } });
  box.addEventListener('dblclick', function () { s = 1; x = 0; y = 0; apply(); });
});
window.addEventListener('load', function () {
  var missing = Array.prototype.filter.call(document.images, function (i) { return !i.complete || i.naturalWidth === 0; });
  document.body.setAttribute('data-images', missing.length ? 'missing: ' + missing.map(function (i) { return i.getAttribute('src'); }).join(' ') : 'ok ' + document.images.length);
});
(function () {
  var videos = Array.prototype.slice.call(document.querySelectorAll('video')), failed = [], left = videos.length;
  function report() { document.body.setAttribute('data-videos', failed.length ? 'missing: ' + failed.join(' ') : 'ok ' + videos.length); }
  function settle(video, ok) { if (!ok) { failed.push(video.getAttribute('src')); } if (--left === 0) { report(); } }
  if (!left) { report(); }
  videos.forEach(function (video) {
    if (video.readyState >= 1) { settle(video, true); return; }
    video.addEventListener('loadedmetadata', function () { settle(video, true); }, {once: true});
    video.addEventListener('error', function () { settle(video, false); }, {once: true});
  });
})();
"""

BAD_OUTCOMES = tuple(o.value for o in Outcome if o != Outcome.GOAL_REACHED) + ("failed",)   # "failed": a run that failed


def _fmt(value) -> str:
    if isinstance(value, float):
        return "—" if not math.isfinite(value) else f"{value:.3f}"
    return html.escape(str(value))


def _cell(value) -> str:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"<td>{_fmt(value)}</td>"
    cls = "text good" if value == Outcome.GOAL_REACHED else "text bad" if value in BAD_OUTCOMES else "text"
    return f'<td class="{cls}">{value if isinstance(value, Raw) else _fmt(value)}</td>'


class Raw(str):
    """Already-escaped HTML for a table cell (a link)."""


def table(rows: Sequence[dict], caption: str = "") -> str:
    if not rows:
        return "<p><em>nothing to show</em></p>"
    cols = list(dict.fromkeys(c for r in rows for c in r))
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = "".join("<tr>" + "".join(_cell(r.get(c, "")) for c in cols) + "</tr>" for r in rows)
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f"<div class='table-box'><table>{cap}<tr>{head}</tr>{body}</table></div>"


def figure(src: str, caption: str, zoom: bool = False, half: bool = False) -> str:
    img = f"<img src='{html.escape(src)}' alt='{html.escape(caption)}'>"
    if zoom:
        img = f"<div class='zoom' title='wheel: zoom, drag: pan, double-click: reset'>{img}</div>"
    cls = " class='half'" if half else ""
    return f"<figure{cls}>{img}<figcaption>{html.escape(caption)}</figcaption></figure>"


def video(src: str, caption: str, half: bool = False) -> str:
    """A video that plays in the page (muted, looped, with its controls), captioned like a figure."""
    cls = " class='half'" if half else ""
    return (f"<figure{cls}><video src='{html.escape(src)}' controls muted loop playsinline preload='metadata' "
            f"title='{html.escape(caption)}'></video><figcaption>{html.escape(caption)}</figcaption></figure>")


GENERATOR = "<meta name='generator' content='simgap'>"       # marks every page simgap writes
SCENARIO_PAGES = "scenario pages"           # a phase of the report, as its progress names it


def page(path: Path, title: str, body: Sequence[str], root: str) -> Path:
    text = (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>{GENERATOR}"
            "<link rel='icon' href='data:,'>"
            f"<title>{html.escape(title)}</title><link rel='stylesheet' href='{root}report.css'></head><body>"
            f"<nav><a href='{root}index.html'>overview</a></nav><h1>{html.escape(title)}</h1>"
            + "\n".join(body) + f"<script src='{root}report.js'></script></body></html>")
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(path, text)


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "-" for c in text)


# ------------------------------------------------------------------------------ heatmaps
def _realism_note(groups, fidelities: list[str]) -> str:
    """How real each physical world's cars were, as their run records say."""
    items = []
    for fidelity in fidelities:
        run = next((g.runs[fidelity].run for g in groups if fidelity in g.runs), None)
        if run is None or fidelity == REFERENCE:
            continue
        if run.realism is Realism.IDEAL:
            items.append(f"<li>{html.escape(fidelity)}: a perfect machine (realism ideal): actuators that act at once, "
                         "the exact state observed, plans that take no time</li>")
            continue
        accuracy, cosim = run.settings.sensing_accuracy, run.settings.cosim
        actuators = [n.split(": ", 1)[1] for n in run.history.backend_notes if ": actuators" in n][:1]
        latencies = [a.plan_latency_mean_s for a in run.evaluation.agents if a.plan_latency_mean_s is not None]
        drift = "" if accuracy is None else (f" (drift {accuracy.position_drift_m:g} m, {accuracy.heading_drift_deg:g} "
                                             f"deg, estimate {accuracy.latency_s:g} s old)")
        items.append(
            f"<li>{html.escape(fidelity)}: the real car (realism real): {html.escape(actuators[0] if actuators else 'actuators as its vehicle file')}; "
            f"localisation {html.escape(cosim.sensing.profile.value)}{drift}; "
            f"plan latency {html.escape(str(cosim.latency))}"
            + (f" ({1000 * sum(latencies) / len(latencies):.0f} ms on average in its first run)" if latencies else "")
            + "</li>")
    return f"<p>The physical worlds' cars:</p><ul>{''.join(items)}</ul>" if items else ""


def _varying_parameters(groups: Sequence[ScenarioGroup]) -> list[str]:
    """Numeric parameters that take more than one value, most values first."""
    values: dict[str, set] = {}
    for g in groups:
        for k, v in g.parameters.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                values.setdefault(k, set()).add(float(v))
    return sorted((k for k, v in values.items() if len(v) > 1), key=lambda k: (-len(values[k]), k))


def heatmap_table(points, xlabel: str, ylabel: str, title: str, links: dict,
                  scale: tuple[float, float] | None = None, unit: str = "m") -> str:
    xs, ys, grid = heatmap_grid(points)
    finite = grid[np.isfinite(grid)]
    lo, hi = scale or ((float(finite.min()), float(finite.max())) if len(finite) else (0.0, 0.0))
    rows = [f"<tr><th>{html.escape(ylabel)} \\ {html.escape(xlabel)}</th>"
            + "".join(f"<th>{x:g}</th>" for x in xs) + "</tr>"]
    for i in reversed(range(len(ys))):
        cells = []
        for j, x in enumerate(xs):
            v = grid[i, j]
            bg, fg = heatmap_colour(v, lo, hi)
            tip = f"{xlabel} = {x:g}, {ylabel} = {ys[i]:g}: {v:.3f} {unit}".rstrip() if np.isfinite(v) else "no run"
            text = f"{v:.2f}" if np.isfinite(v) else ""
            href = links.get((x, ys[i]))
            if href and text:
                text = f"<a href='{href}' style='color:{fg}'>{text}</a>"
            cells.append(f"<td style='background:{bg};color:{fg}' title='{html.escape(tip)}'>{text}</td>")
        rows.append(f"<tr><th>{ys[i]:g}</th>" + "".join(cells) + "</tr>")
    lo_bg, lo_fg = heatmap_colour(lo, lo, hi)
    hi_bg, hi_fg = heatmap_colour(hi, lo, hi)
    legend = (f"<p>colour scale: <span style='background:{lo_bg};color:{lo_fg};padding:0 6px'>{lo:.2f} {unit}</span> → "
              f"<span style='background:{hi_bg};color:{hi_fg};padding:0 6px'>{hi:.2f} {unit}</span> "
              "(cividis; hover a cell for its value, click it for the scenario)</p>")
    return (f"<h3>{html.escape(title)}</h3><div class='table-box'><table class='heatmap'>{''.join(rows)}</table></div>"
            f"{legend}")


# ------------------------------------------------------------------------------ pages
def _criticality(entry) -> list[dict]:
    """Most critical TTC, THW, BTN, STN per agent pair, as the run's evaluation holds them."""
    return [asdict(c) for c in entry.run.evaluation.criticality]


def _scenario_page(group: ScenarioGroup, out: Path, assets: Path, compared: bool = False) -> Path:
    """The page of one scenario and planner (``compared``: the scenario has a page comparing its
    planners, linked from this one)."""
    name = _slug(group.name)
    adir = assets / name
    adir.mkdir(parents=True, exist_ok=True)
    rel = f"../assets/{name}/"
    body = [f"<p>planner: <b>{html.escape(group.planner)}</b>"
            + (f" (<a href='{_comparison_name(group.scenario_id)}'>every planner on this scenario, on shared axes</a>)"
               if compared else "") + "</p>",
            "<h2>Parameters</h2>", table([{"parameter": k, "value": v} for k, v in group.parameters.items()]),
            "<h2>Outcome and tracking per fidelity</h2>",
            "<p>Tracking: where each vehicle was against where the plan in force said it would be, in the "
            "route's Frenet frame (lateral, longitudinal). The ideal backend tracks perfectly by construction.</p>",
            table(_outcome_rows(group)),
            "<h2>Against the ideal run</h2>",
            "<p>d: lateral offset from the route's lane centre, compared at equal arc length s; Δv, position and "
            "orientation errors at equal time.</p>", table(_gap_rows(group)),
            "<h2>Scores</h2>", SCORES_NOTE, table(breakdown_rows(group)),
            "<h2>Plots</h2>"]
    agent_ids = sorted({a.id for e in group.runs.values() for a in e.run.history.agents})
    frames = {aid: _route_frame(group, aid) for aid in agent_ids}
    for aid in agent_ids:
        body += _agent_figures(group, aid, frames[aid], adir, rel)
    body += _scenario_figures(group, adir, rel)
    timelines = [f for aid in agent_ids for f in _agent_timelines(group, aid, frames[aid], adir, rel)]
    if timelines:
        body += ["<h2>Why they parted: timelines</h2>",
                 "<p>Per physical run and agent, against time: where the car was against its plan in force "
                 "(lateral and heading), the steering and acceleration its controller asked for against what the "
                 "car did (after its actuators' delays and limits), each plan's latency until it reached the car "
                 "and each planning call's wall time, and how far the state its planner observed was from the "
                 "true one; every event dotted.</p>"] + timelines
    body += _explanations(group, adir, rel)
    crit = [{"fidelity": fidelity} | r for fidelity, entry in group.runs.items() for r in _criticality(entry)]
    if crit:
        body += ["<h2>Criticality of agent pairs (commonroad-crime)</h2>",
                 "<p>Most critical value over the run per ordered pair: smallest TTC and THW, largest BTN and STN.</p>",
                 table(crit)]
    pictures = _pictures(group, adir, rel)
    if pictures:
        body += ["<h2>Pictures</h2>"] + pictures
    return page(out / "scenarios" / f"{name}.html", f"Scenario {group.name}", body, "../")


def _explanations(group: ScenarioGroup, adir: Path, rel: str) -> list[str]:
    """Per explained run (`simgap explain`), the waterfall of its attribution and its table."""
    explained = [(fidelity, e.explanation) for fidelity, e in group.runs.items() if e.explanation is not None]
    if not explained:
        return []
    body = ["<h2>Why they parted: the assumptions that broke</h2>",
            "<p>Each explained run (<code>simgap explain</code>) was run again with each subset of the planner's "
            "assumptions that it broke restored. An assumption's share is its Shapley value over those worlds of the "
            "gap, max |d| against the ideal run: the shares add up to the gap. <code>vehicle_dynamics</code> is the "
            "base, the perfect machine's own gap. A hatched bar: restoring that assumption alone brings the "
            "outcome back to the ideal run's.</p>"]
    for fidelity, a in explained:
        png = plot_waterfall([(str(x.name), x.share_m, x.fixes_outcome) for x in a.assumptions], a.gap_m,
                             adir / f"waterfall_{_slug(fidelity)}.png",
                             f"{group.scenario_id}, {fidelity}: {a.outcome} (ideal: {a.ideal_outcome})")
        body += [f"<h3>{html.escape(fidelity)}</h3><p>{html.escape(a.sentence())}.</p>",
                 figure(rel + png.name, f"{fidelity}: each assumption's share of the {a.gap_m:.3f} m gap", half=True),
                 table([{"assumption": str(x.name), "share of max |d| [m]": x.share_m,
                         "share of lateral tracking [m]": x.tracking_share_m, "score drop": x.score_drop,
                         "restoring it alone fixes the outcome": "yes" if x.fixes_outcome else "no"}
                        for x in a.assumptions]),
                 f"<p>smallest sets whose restoration fixes the outcome: "
                 f"{html.escape('; '.join('{' + ', '.join(s) + '}' for s in a.fixing_sets) or 'none')}; interaction "
                 f"{a.interaction_m:.3f} m; {a.runs} runs in {a.wall_s:.1f} s.</p>"]
    return body


def _assumption_heatmaps(groups: list[ScenarioGroup], xp: str, yp: str) -> list[str]:
    """Which assumption dominates where: per assumption, its share of the gap in each explained run
    over two varying parameters (one colour scale for all)."""
    points: dict[str, list[tuple[float, float, float]]] = {}
    links: dict[tuple[float, float], str] = {}
    for g in groups:
        if xp not in g.parameters or yp not in g.parameters:
            continue
        key = (float(g.parameters[xp]), float(g.parameters[yp]))
        for e in g.runs.values():
            if e.explanation is not None:
                for x in e.explanation.assumptions:
                    points.setdefault(str(x.name), []).append((*key, x.share_m))
                links[key] = f"scenarios/{_slug(g.name)}.html"
    if not points:
        return []
    values = [v for pts in points.values() for *_, v in pts if math.isfinite(v)]
    scale = (min(values), max(values)) if values else (0.0, 0.0)
    xlabel, ylabel = _axis_labels(groups, xp, yp)
    return (["<h2>Which assumption dominates where</h2>",
             "<p>Per assumption, its Shapley share [m] of the gap (max |d| against the ideal run) in each explained "
             f"run, over {html.escape(xp)} × {html.escape(yp)}; one colour scale, {scale[0]:.2f} to {scale[1]:.2f} m. "
             "Where several runs of a scenario were explained, the last one read is shown.</p>"]
            + [f"<div class='side'>{heatmap_table(pts, xlabel, ylabel, name, links, scale)}</div>"
               for name, pts in sorted(points.items())])


def _comparison_name(scenario_id: str) -> str:
    """The file name of the page that compares every planner of a scenario."""
    return f"{_slug(scenario_id)}-all-planners.html"


def _comparison_page(scenario_id: str, groups: list[ScenarioGroup], out: Path, assets: Path) -> Path:
    """One scenario, every planner and fidelity on shared axes: a row per planner and fidelity, d over
    s and v over t of every run in one plot per agent, every run's path from above; each planner's
    gaps are against its own ideal run."""
    name = _slug(scenario_id) + "-all-planners"
    adir = assets / name
    adir.mkdir(parents=True, exist_ok=True)
    rel = f"../assets/{name}/"
    runs = {f"{g.planner} · {fidelity}": (g, entry) for g in groups for fidelity, entry in g.runs.items()}
    rows = []
    for g in groups:
        for fidelity, entry in g.runs.items():
            agents = entry.run.evaluation.agents
            gaps = g.comparisons.get(fidelity, [])
            times = [a.time_to_goal_s for a in agents]
            reached = [t for t in times if t is not None]
            rows.append({"planner": Raw(f"<a href='{_slug(g.name)}.html'>{html.escape(g.planner)}</a>"),
                         "fidelity": fidelity,
                         "outcomes": ", ".join(sorted({a.outcome for a in entry.run.history.agents})),
                         "time to goal [s]": max(reached) if reached and len(reached) == len(times) else "—",
                         "beyond road [m]": max((a.max_road_excursion_m for a in agents), default="—"),
                         "max |d| against its ideal [m]": max((c.lateral_displacement.max for c in gaps), default="—"),
                         "rms |d| against its ideal [m]": max((c.lateral_displacement.rms for c in gaps), default="—"),
                         "wall time [s]": entry.run.history.wall_time_s})
    body = [f"<p>Every planner's runs of this scenario side by side: {len(groups)} planners "
            f"({', '.join(html.escape(g.planner) for g in groups)}), each in every fidelity it ran. Each planner's "
            "gaps are measured against its own ideal run; the plots share their axes, so planners compare by eye. "
            "Each planner's page (linked in the table) has its scores, timelines and pictures.</p>",
            "<h2>Per planner and fidelity</h2>", table(rows), "<h2>Plots</h2>"]
    first = groups[0]
    for aid in sorted({a.id for g in groups for e in g.runs.values() for a in e.run.history.agents}):
        frame = _route_frame(first, aid)
        problem = first.problems.planning_problem_dict.get(aid)
        if frame is not None:
            curves = {}
            for label, (_, e) in runs.items():
                if aid in e.run.history.driven:
                    s, d = lateral_profile(e.run.history.driven[aid], frame)
                    curves[label] = (s[np.argsort(s)], d[np.argsort(s)])
            events = {label: event_places([ev for ev in e.run.history.events if ev.agent_id == aid], {aid: frame})
                      for label, (g, e) in runs.items()}
            plot_d_over_s(curves, adir / f"d_over_s_{aid}.png",
                          f"{scenario_id}, agent {aid}: d over s, every planner and fidelity",
                          _section_shading(groups, aid),
                          route_edges(first.scenario.lanelet_network, problem, frame), events)
            body.append(figure(rel + f"d_over_s_{aid}.png", f"agent {aid}: d over s of every planner and fidelity, "
                               "lane (dashed) and road (solid) edges, events where they happened", zoom=True,
                               half=True))
        trajs = {label: e.run.history.driven[aid] for label, (g, e) in runs.items() if aid in e.run.history.driven}
        plot_v_over_t(trajs, adir / f"v_over_t_{aid}.png", f"{scenario_id}, agent {aid}: v over t, every planner")
        body.append(figure(rel + f"v_over_t_{aid}.png", f"agent {aid}: v over t of every planner and fidelity",
                           zoom=True, half=True))
    plot_paths_from_above(first.scenario, {label: e.run.history for label, (g, e) in runs.items()},
                          adir / "paths.png", f"{scenario_id}: planned and driven paths of every planner")
    body.append(figure(rel + "paths.png", "planned (thin, every 10th plan) and driven (thick) paths of every "
                       "planner and fidelity", zoom=True, half=True))
    return page(out / "scenarios" / _comparison_name(scenario_id), f"Scenario {scenario_id}, every planner", body,
                "../")


def _outcome_rows(group: ScenarioGroup) -> list[dict]:
    """Per fidelity and agent: how the run ended and how closely the vehicle tracked its plans."""
    rows = []
    for fidelity, entry in group.runs.items():
        for agent in entry.run.agents:
            a, t = agent.evaluation, agent.evaluation.tracking
            rows.append({"fidelity": fidelity, "agent": agent.id, "outcome": agent.history.outcome,
                         "time to goal [s]": a.time_to_goal_s if a.time_to_goal_s is not None else "—",
                         "beyond road [m]": a.max_road_excursion_m,
                         "beyond lane [m]": "—" if t is None else t.lane_excursion_m,
                         "planner failures": agent.history.planner_failures,
                         "min distance [m]": a.min_distance_to_traffic_m if a.min_distance_to_traffic_m is not None else "—",
                         "peak a_lat [m/s²]": "—" if t is None else t.comfort.peak_lateral_acceleration,
                         "peak jerk [m/s³]": "—" if t is None else t.comfort.peak_jerk,
                         "tracking lateral rms/max [m]": "—" if t is None else f"{t.lateral.rms:.3f} / {t.lateral.max:.3f}",
                         "tracking longitudinal rms/max [m]":
                             "—" if t is None else f"{t.longitudinal.rms:.3f} / {t.longitudinal.max:.3f}",
                         "wall time [s]": entry.run.history.wall_time_s})
    return rows


def _gap_rows(group: ScenarioGroup) -> list[dict]:
    """Per fidelity and agent: how far its run parted from the ideal run."""
    rows = []
    for fidelity, comps in group.comparisons.items():
        for c in comps:
            row = {"fidelity": fidelity, "agent": c.agent_id, "max |d| [m]": c.lateral_displacement.max,
                   "rms |d| [m]": c.lateral_displacement.rms, "p95 |d| [m]": c.lateral_displacement.p95}
            for kind, agg in c.by_section.items():
                row[f"max |d| {kind} [m]"] = agg.max
            row |= {"max |Δv| [m/s]": c.velocity_error.max, "rms |Δv| [m/s]": c.velocity_error.rms,
                    "max position error [m]": c.position_error.max, "max |Δψ| [rad]": c.orientation_error.max}
            rows.append(row)
    return rows


def _route_frame(group: ScenarioGroup, aid: int) -> PathFrame | None:
    """Agent ``aid``'s route centre line (None: it has no route, or no planning problem)."""
    problem = group.problems.planning_problem_dict.get(aid)
    return route_centre(group.scenario.lanelet_network, problem) if problem is not None else None


def _agent_figures(group: ScenarioGroup, aid: int, frame: PathFrame | None, adir: Path, rel: str) -> list[str]:
    """Agent ``aid``'s d over s (with the road's sections shaded, its lane and road edges and every
    fidelity's events where they happened) and v over t, every fidelity."""
    figures = []
    problem = group.problems.planning_problem_dict.get(aid)
    curves = {f: lateral_profile(e.run.history.driven[aid], frame) for f, e in group.runs.items()
              if frame is not None and aid in e.run.history.driven}
    if curves and frame is not None:
        shading = _section_shading([group], aid)
        sorted_curves = {k: (s[np.argsort(s)], d[np.argsort(s)]) for k, (s, d) in curves.items()}
        events = {f: event_places([ev for ev in e.run.history.events if ev.agent_id == aid], {aid: frame})
                  for f, e in group.runs.items()}
        plot_d_over_s(sorted_curves, adir / f"d_over_s_{aid}.png",
                      f"{group.scenario_id}, agent {aid}: lateral offset d over arc length s", shading,
                      route_edges(group.scenario.lanelet_network, problem, frame), events)
        figures.append(figure(rel + f"d_over_s_{aid}.png", f"agent {aid}: d over s per fidelity, lane (dashed) and "
                              "road (solid) edges, and each run's events where they happened", zoom=True, half=True))
    trajs = {f: e.run.history.driven[aid] for f, e in group.runs.items() if aid in e.run.history.driven}
    plot_v_over_t(trajs, adir / f"v_over_t_{aid}.png", f"{group.scenario_id}, agent {aid}: speed v over time t")
    figures.append(figure(rel + f"v_over_t_{aid}.png", f"agent {aid}: v over t per fidelity", zoom=True, half=True))
    return figures


def _section_shading(groups: Sequence[ScenarioGroup], aid: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The road's sections along agent ``aid``'s route (s, kind per s), as a comparison measured them."""
    return next(((c.s, c.section_along_s) for g in groups for comps in reversed(list(g.comparisons.values()))
                 for c in reversed(comps) if c.agent_id == aid and c.section_along_s is not None), None)


def _agent_timelines(group: ScenarioGroup, aid: int, frame: PathFrame | None, adir: Path, rel: str) -> list[str]:
    """Per physical run, agent ``aid``'s timeline: why it parted from its plan (``frame``: its route's
    centre line)."""
    figures = []
    for fidelity, entry in group.runs.items():
        history = entry.run.history
        if history.backend == REFERENCE or aid not in history.driven:
            continue
        name = f"timeline_{_slug(fidelity)}_{aid}.png"
        plot_timeline(agent_timeline(history.agent(aid), frame), [e for e in history.events if e.agent_id == aid],
                      adir / name, f"{group.scenario_id}, {fidelity}, agent {aid}: why it parted from its plan")
        figures.append(figure(rel + name, f"{fidelity}, agent {aid}: timeline — tracking error, steering and "
                              "acceleration requested against achieved, plan latency, sensing error; events "
                              "dotted", zoom=True, half=True))
    return figures


def _scenario_figures(group: ScenarioGroup, adir: Path, rel: str) -> list[str]:
    """Every fidelity's planned and driven paths from above, and the spread of |d| per fidelity."""
    plot_paths_from_above(group.scenario, {f: e.run.history for f, e in group.runs.items()}, adir / "paths.png",
                          f"{group.scenario_id}: planned and driven paths of every fidelity")
    figures = [figure(rel + "paths.png", "planned (thin, every 10th plan) and driven (thick) paths", zoom=True,
                      half=True)]
    if group.comparisons:
        d_samples = {f: np.concatenate([c.d_b - c.d_a for c in comps]) if comps else np.array([])
                     for f, comps in group.comparisons.items()}
        plot_error_boxes(d_samples, adir / "d_boxes.png", f"{group.scenario_id}: |d| against the ideal run",
                         "|d_fidelity - d_ideal| [m]")
        figures.append(figure(rel + "d_boxes.png", "distribution of the lateral displacement per fidelity", half=True))
    return figures


def _pictures(group: ScenarioGroup, adir: Path, rel: str) -> list[str]:
    """The pictures each run directory holds (scene, animation, 3D pictures and video), copied beside the page."""
    pictures = []
    for fidelity, entry in group.runs.items():
        for pic in PICTURES:
            src = entry.run_dir / pic
            if src.exists():
                target = adir / f"{_slug(fidelity)}_{pic}"
                shutil.copyfile(src, target)
                show = video if target.suffix == ".mp4" else figure
                pictures.append(show(rel + target.name, f"{fidelity}: {pic.rsplit('.', 1)[0].replace('_', ' ')}",
                                     half=True))
    return pictures


def _store_section(rows: list[RunRow]) -> list[str]:
    """What the experiment's results store holds, including runs that left no run directory."""
    by_variant: dict[tuple[str, str], Counter] = {}
    for r in rows:
        variant = (r.id.planner or DEFAULT_PLANNER, r.id.fidelity.label)
        by_variant.setdefault(variant, Counter())[r.status] += 1
    table_rows = [{"planner": p, "fidelity": f, "ok": c.get("ok", 0), "failed": c.get("failed", 0)}
                  for (p, f), c in sorted(by_variant.items())]
    failed = [{"run": r.id.key, "reason": r.failure} for r in rows if r.status != "ok"]
    body = ["<h2>Results store</h2>",
            f"<p>{len(rows)} rows in the experiment's store (one per finished run; "
            "<code>simgap experiment query</code> runs SQL over them).</p>", table(table_rows)]
    if failed:
        body += ["<h3>Failed runs</h3>", table(failed)]
    repeated = [o for o in odds_over_repeats(rows) if o.runs > 1]
    if repeated:
        body += ["<h3>Odds over repeats</h3>",
                 "<p>Each scenario run with several seeds (the spec's <code>repeats</code>): how many runs reached "
                 "every goal or failed, with Wilson 95 % intervals, and the median and 90th percentile over runs of "
                 "the largest lateral offset |d| from the lane's centre [m], with bootstrap 95 % intervals "
                 "(<code>store/odds.parquet</code>).</p>",
                 table([{"scenario": o.scenario, "fidelity": o.fidelity, "planner": o.planner, "runs": o.runs,
                         "goal": str(o.goal), "failure": str(o.failure), "max |d| median": str(o.max_d_median),
                         "max |d| p90": str(o.max_d_p90)} for o in repeated])]
    return body


def build_report(root: Path, out: Path, on_progress: Callable[[str, int, int], None] = lambda *_: None,
                 store_rows: list[RunRow] | None = None) -> Path:
    """Write the report of every run below ``root`` as the directory ``out``; returns
    ``out/index.html``. ``store_rows`` (an experiment's results store) adds what the store holds,
    failures included; ``on_progress(phase, done, total)`` after each run read and each page drawn. The report is built beside ``out`` and swapped into its place whole
    (`simgap.files.replace_directory`), so a report killed half-way leaves the previous one."""
    root, out = Path(root), Path(out)
    if out.resolve() == root.resolve() or out.resolve() in root.resolve().parents:
        raise InputError("the report would replace the runs it draws", file=out,
                         allowed="a folder outside the runs' folder, e.g. a sibling 'report'")
    groups = collect(root, on_progress)
    replace_directory(out, lambda tmp: _write_report(root, groups, tmp, on_progress, store_rows))
    return out / "index.html"


def _write_report(root: Path, groups: list[ScenarioGroup], out: Path, on_progress: Callable[[str, int, int], None],
                  store_rows: list[RunRow] | None) -> None:
    assets = out / "assets"
    assets.mkdir(parents=True, exist_ok=True)
    (out / "report.css").write_text(STYLE)
    (out / "report.js").write_text(SCRIPT)
    by_scenario: dict[str, list[ScenarioGroup]] = {}
    for group in groups:
        by_scenario.setdefault(group.scenario_id, []).append(group)
    on_progress(SCENARIO_PAGES, 0, len(groups))
    for i, group in enumerate(groups):
        _scenario_page(group, out, assets, compared=len(by_scenario[group.scenario_id]) > 1)
        on_progress(SCENARIO_PAGES, i + 1, len(groups))
    for scenario_id, mine in by_scenario.items():
        if len(mine) > 1:
            _comparison_page(scenario_id, mine, out, assets)

    fidelities = sorted({f for g in groups for f in g.runs}, key=lambda f: (f != REFERENCE, f))
    planners = sorted({g.planner for g in groups}, key=lambda p: (p != DEFAULT_PLANNER, p))
    variants = [(p, f) for p in planners for f in fidelities if any(g.planner == p and f in g.runs for g in groups)]
    n_scenarios = len({g.scenario_id for g in groups})
    n_runs = sum(len(g.runs) for g in groups)
    n_failed = sum(e.failed for g in groups for e in g.runs.values())
    params = _varying_parameters(groups)
    body = [f"<p>{n_scenarios} scenarios × {len(fidelities)} fidelities ({', '.join(map(html.escape, fidelities))}) "
            f"× {len(planners)} planner{'s' if len(planners) > 1 else ''} ({', '.join(map(html.escape, planners))}): "
            f"{n_runs} runs from <code>{html.escape(str(root))}</code>; {n_failed} did not reach every goal.</p>",
            _realism_note(groups, fidelities),
            "<h2>Headline numbers</h2>",
            "<p>max |d|: the largest lateral displacement of a run against the ideal run of its scenario with the "
            "same planner, at equal arc length along the route's lane centre.</p>",
            table(_headline_rows(groups, variants)),
            "<h2>Scores per planner and fidelity</h2>", SCORES_NOTE, table(score_rows(groups, variants))]
    if len(params) >= 2:
        body += _heatmaps(groups, fidelities, planners, params[0], params[1], assets)
        body += _score_heatmaps(groups, fidelities, planners, params[0], params[1], assets)
        body += _assumption_heatmaps(groups, params[0], params[1])
    label = {v: f"{v[0]} · {v[1]}" if len(planners) > 1 else v[1] for v in variants}
    entries = {v: [g.runs[v[1]] for g in groups if g.planner == v[0] and v[1] in g.runs] for v in variants}
    wall = {label[v]: [e.run.history.wall_time_s for e in entries[v]] for v in variants}
    phases = {label[v]: [e.run.all_timings for e in entries[v]] for v in variants}
    body += ["<h2>Run times per fidelity</h2>",
             "<p>Wall time of a run (min, max, mean, median, standard deviation; the paper's Table I) and the mean "
             "time of each phase.</p>", table(runtime_table(wall, phases)),
             "<h2>Time per planning call</h2>",
             "<p>Wall time of one call of the planner's <code>plan</code> (every agent, every run): mean, the largest "
             "95th percentile of a run, the longest call; cycles in which the planner raised, and calls over the "
             "loop's <code>planning_budget_s</code> when one was set.</p>",
             table([{"planner": v[0], "fidelity": v[1]} | _planning_row(entries[v]) for v in variants])]
    outcome_rows = []
    for v in variants:
        counts = Counter(a.outcome for e in entries[v] for a in e.run.history.agents)
        outcome_rows.append({"planner": v[0], "fidelity": v[1]} | dict(sorted(counts.items())))
    body += ["<h2>Outcomes (agents)</h2>", table(outcome_rows),
             "<h2>Scenarios, largest gap first</h2>", table(_ranking_rows(groups, params))]
    compared = [sid for sid, mine in by_scenario.items() if len(mine) > 1]
    if compared:
        body.append("<p>Every planner of a scenario on shared axes: " + ", ".join(
            f"<a href='scenarios/{_comparison_name(sid)}'>{html.escape(sid)}</a>" for sid in compared) + ".</p>")
    if store_rows is not None:
        body += _store_section(store_rows)
    page(out / "index.html", "simgap report", body, "")


def _planning_row(entries) -> dict:
    """Time per planning call over ``entries``' agents (ms), exceptions and calls over budget."""
    agents = [a for e in entries for a in e.run.evaluation.agents if a.planning_calls]
    calls = sum(a.planning_calls for a in agents)
    raised = sum(a.planner_exceptions for e in entries for a in e.run.history.agents)
    if not calls:                   # (planners that raised in their constructors)
        return {"calls": 0, "raised": raised}
    return {"calls": calls,
            "mean [ms]": 1000 * sum(a.planning_mean_s * a.planning_calls for a in agents) / calls,
            "largest p95 [ms]": 1000 * max(a.planning_p95_s for a in agents),
            "max [ms]": 1000 * max(a.planning_max_s for a in agents),
            "raised": raised,
            "over budget": sum(a.planning_over_budget for a in agents)}


def _headline_rows(groups: list[ScenarioGroup], variants: list[tuple[str, str]]) -> list[dict]:
    rows = []
    for planner, fidelity in variants:
        mine = [g for g in groups if g.planner == planner]
        entries = [g.runs[fidelity] for g in mine if fidelity in g.runs]
        goals = sum(a.outcome == Outcome.GOAL_REACHED for e in entries for a in e.run.history.agents)
        agents = sum(len(e.run.history.agents) for e in entries)
        gaps = [c.lateral_displacement.max for g in mine for c in g.comparisons.get(fidelity, [])
                if math.isfinite(c.lateral_displacement.max)]
        rows.append({"planner": planner, "fidelity": fidelity, "runs": len(entries),
                     "goals reached": f"{goals}/{agents}",
                     "goal rate": f"{100 * goals / agents:.0f} %" if agents else "—",
                     "median max |d| [m]": float(np.median(gaps)) if gaps else "—",
                     "largest max |d| [m]": max(gaps) if gaps else "—",
                     "mean wall time [s]": float(np.mean([e.run.history.wall_time_s for e in entries]))})
    return rows


def _heatmaps(groups: list[ScenarioGroup], fidelities: list[str], planners: list[str], xp: str, yp: str,
              assets: Path) -> list[str]:
    """Per fidelity, the largest gap against the ideal run over two varying parameters, the planners
    side by side (one colour scale for every fidelity and planner, so colours compare across
    vehicles, backends and planners)."""
    xlabel, ylabel = _axis_labels(groups, xp, yp)
    body = ["<h2>Where the gap is largest</h2>"]
    maps: dict[str, dict[str, tuple]] = {}
    for fidelity in fidelities:
        if fidelity == REFERENCE:
            continue
        for planner in planners:
            points, links = [], {}
            for g in groups:
                if g.planner == planner and fidelity in g.comparisons and xp in g.parameters and yp in g.parameters:
                    gap = max((c.lateral_displacement.max for c in g.comparisons[fidelity]), default=float("nan"))
                    key = (float(g.parameters[xp]), float(g.parameters[yp]))
                    points.append((*key, gap))
                    links[key] = f"scenarios/{_slug(g.name)}.html"
            if points:
                maps.setdefault(fidelity, {})[planner] = (points, links)
    values = [v for per in maps.values() for points, _ in per.values() for *_, v in points if math.isfinite(v)]
    scale = (min(values), max(values)) if values else (0.0, 0.0)
    if sum(len(per) for per in maps.values()) > 1:
        body.append(f"<p>All heatmaps share one colour scale, {scale[0]:.2f} to {scale[1]:.2f} m.</p>")
    for fidelity, per in maps.items():
        tables, pictures = [], []
        if len(planners) > 1:
            body.append(f"<h3>max |d| [m] of {html.escape(fidelity)} against ideal over {html.escape(xp)} × "
                        f"{html.escape(yp)}, per planner</h3>")
        for planner, (points, links) in per.items():
            title = f"max |d| [m] of {fidelity} against ideal over {xp} × {yp}" if len(planners) == 1 else \
                f"max |d| [m], {fidelity}, {planner}"
            shown = f"planner {planner}" if len(planners) > 1 else title
            tables.append(f"<div>{heatmap_table(points, xlabel, ylabel, shown, links, scale)}</div>")
            suffix = f"_{_slug(planner)}" if len(planners) > 1 else ""
            png = plot_heatmap(points, assets / f"heatmap_{_slug(fidelity)}{suffix}.png", title, xlabel, ylabel,
                               "max |d| [m]", scale)
            pictures.append(figure(f"assets/{png.name}", f"{title} (picture)", half=len(per) > 1))
        body += [f"<div class='side'>{''.join(tables)}</div>", "".join(pictures)]
    return body


def _axis_labels(groups: list[ScenarioGroup], xp: str, yp: str) -> tuple[str, str]:
    """The two parameters with their units (as the runs record them)."""
    units = {k: u for g in groups for e in g.runs.values()
             for k, u in e.run.settings.parameter_units.items()}
    xlabel, ylabel = (f"{p} [{units[p]}]" if units.get(p, "-") != "-" else p for p in (xp, yp))
    return xlabel, ylabel


def _score_heatmaps(groups: list[ScenarioGroup], fidelities: list[str], planners: list[str], xp: str, yp: str,
                    assets: Path) -> list[str]:
    """Per fidelity and planner, the score drop from the ideal run over two varying parameters
    (one colour scale, 0 to the largest drop)."""
    maps = score_drop_maps(groups, fidelities, planners, xp, yp)
    if not maps:
        return []
    xlabel, ylabel = _axis_labels(groups, xp, yp)
    scale = (0.0, max([v for points in maps.values() for _, _, v, _ in points if math.isfinite(v)] + [1e-3]))
    body = ["<h2>Where the score drops</h2>",
            f"<p>The closed-loop score of the ideal run minus the run's (its agent that lost most), over "
            f"{html.escape(xp)} × {html.escape(yp)}; one colour scale, 0 to {scale[1]:.2f}.</p>"]
    tables, pictures = [], []
    for (fidelity, planner), points in maps.items():
        title = f"score drop, {fidelity}" + (f", {planner}" if len(planners) > 1 else "")
        links = {(x, y): f"scenarios/{_slug(g.name)}.html" for x, y, _, g in points}
        cells = [(x, y, v) for x, y, v, _ in points]
        tables.append(f"<div>{heatmap_table(cells, xlabel, ylabel, title, links, scale, unit='')}</div>")
        png = plot_heatmap(cells, assets / f"score_drop_{_slug(fidelity)}_{_slug(planner)}.png", title, xlabel,
                           ylabel, "score drop", scale)
        pictures.append(figure(f"assets/{png.name}", f"{title} (picture)", half=len(maps) > 1))
    return body + [f"<div class='side'>{''.join(tables)}</div>", "".join(pictures)]


def _ranking_rows(groups: list[ScenarioGroup], params: list[str]) -> list[dict]:
    """Every scenario, the largest gap first, with the fidelity it is in."""
    ranked = sorted(groups, key=lambda g: -(g.largest_gap()[0] if math.isfinite(g.largest_gap()[0]) else -1))
    rows = []
    for g in ranked:
        gap, fidelity = g.largest_gap()
        outcomes = ", ".join(sorted({a.outcome for e in g.runs.values() for a in e.run.history.agents}))
        rows.append({"scenario": Raw(f"<a href='scenarios/{_slug(g.name)}.html'>"
                                     f"{html.escape(g.scenario_id)}</a>"), "planner": g.planner,
                     "largest max |d| [m]": gap, "in fidelity": fidelity or "—",
                     "parameters": ", ".join(f"{k}={g.parameters[k]:g}" for k in params if k in g.parameters),
                     "outcomes": outcomes})
    return rows


def build_experiment_report(root: Path, on_progress: Callable[[str, int, int], None] = lambda *_: None
                            ) -> Path | None:
    """Write ``root/report`` for the experiment in ``root`` (its runs and its results store);
    None when no run left a run directory (every run failed: nothing to draw)."""
    root = Path(root)
    if not any((root / "runs").rglob("run.json")):
        return None
    return build_report(root / "runs", root / "report", on_progress, store_rows=ResultsStore(root).run_rows())
