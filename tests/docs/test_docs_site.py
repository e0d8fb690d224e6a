"""The documentation site: built strictly (a broken link, a missing page or anchor fails), its
reference tables say the code's defaults, its tutorials print what the code prints, and its pages
load in a real headless browser with nothing fetched from the web."""

from __future__ import annotations

import contextlib
import html
import importlib.util
import json
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
import simgap_command

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytest.importorskip("mkdocs", reason="the docs tools are not installed (make install puts them into .venv)")


def _module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


generate = _module("simgap_docs_generate", ROOT / "docs" / "hooks" / "generate.py")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1",
               PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    warnings = [line for line in proc.stderr.splitlines() if line.startswith(("WARNING", "ERROR"))]
    assert proc.returncode == 0 and not warnings, proc.stderr[-4000:]
    return out


def _rows(page: str) -> dict[str, str]:
    """field name → the text of its default cell, from a generated settings table."""
    rows = {}
    for m in re.finditer(r"<tr>\s*<td><code>([^<]+)</code></td>\s*<td>.*?</td>\s*<td>(.*?)</td>", page, re.S):
        rows.setdefault(html.unescape(m.group(1)), html.unescape(re.sub(r"<[^>]+>", "", m.group(2))).strip())
    return rows


MODELS = {"reference/loop-settings.html": ["simgap.cosim.loop:CosimSettings", "simgap.evaluate.settings:EvaluationSettings",
                                         "simgap.evaluate.settings:ScoreSettings"],
          "reference/planner-settings.html": ["simgap.planning.settings:FrenetSettings"],
          "reference/vehicles.html": ["simgap.vehicles.catalogue:Vehicle"],
          "reference/search-specs.html": ["simgap.experiment.search.spec:SearchSpec"]}


def test_every_documented_default_is_the_codes(site):
    for page, models in MODELS.items():
        rows = _rows((site / page).read_text())
        for target in models:
            for name, field in generate.model_fields(generate.resolve(target)):
                expected = re.sub(r"`", "", generate.default_text(field))
                assert name in rows, f"{page}: {target} field {name} is not documented"
                assert rows[name] == expected, f"{page}: {name} documented as {rows[name]!r}, the code's is {expected!r}"
    backends = (site / "reference/backend-settings.html").read_text()
    for name in generate.BACKEND_MODELS:
        assert f"<code>{name}</code>" in backends
    from simgap.sim.registry import BACKENDS
    assert set(BACKENDS) <= set(generate.BACKEND_MODELS)


def test_every_command_and_option_is_in_the_cli_reference(site):
    page = html.unescape((site / "reference/cli.html").read_text())
    for path, command in generate.cli_commands(generate.cli_app()):
        assert f"{path}" in page, path
        for param in command.params:
            for opt in getattr(param, "opts", []):
                if opt.startswith("-"):
                    assert opt in page, f"{path} {opt}"


def test_knobs_and_validation_tables_come_from_the_code_and_the_results(site):
    from simgap.experiment.knobs import KNOBS
    knobs = (site / "reference/knobs.html").read_text()
    assert all(f"<code>{name}</code>" in knobs for name in KNOBS)
    results = (site / "validation/results.html").read_text()
    for f in (ROOT / "bench" / "results").glob("*.json"):
        assert f.name in results
        json.loads(f.read_text())


def test_the_protocol_specification_is_a_page_included_from_its_one_copy(site):
    page = html.unescape((site / "reference/planner-protocol.html").read_text())
    readme = (ROOT / "planner-protocol" / "README.md").read_text()
    for heading in re.findall(r"^## (.+)$", readme, re.M):
        assert heading in page, heading
    assert 'href="#file-simgap_planner-proto"' in page                     # the .proto, appended and linked
    assert "message PlanRequest {" in re.sub(r"<[^>]+>", "", page)
    assert (ROOT / "docs" / "reference" / "planner-protocol.md").read_text().strip().startswith("<!-- gen:include")


def test_the_api_page_lists_every_field_a_planner_sees(site):
    import dataclasses

    import simgap_planner

    article = (site / "reference/api.html").read_text().split('class="md-content"')[1]
    page = html.unescape(re.sub(r"<[^>]+>", "", article))
    section = page.split("Every field a planner sees")[1].split("\nPlanners")[0]
    for name, ours in generate.SDK_TYPES.items():
        sdk_type = getattr(simgap_planner, name)
        assert f"{name}" in section and ours in section, name
        documented = [f.name for f in dataclasses.fields(sdk_type) if "doc" in f.metadata] \
            if dataclasses.is_dataclass(sdk_type) else list(simgap_planner.STATE_FIELDS)
        documented += [n for n, v in vars(sdk_type).items() if isinstance(v, property) and v.__doc__]
        for field in documented:
            assert re.search(rf"^{re.escape(field)}$", section, re.M), f"{name}.{field} is not listed"
    assert "max_steer\nfloat\nlargest road-wheel steering angle [rad]" in section     # a row: name, type, meaning


def test_the_loop_page_draws_the_loop_and_names_stay_whole(site):
    page = (site / "concepts/fidelities.html").read_text()
    assert '<img alt="The co-simulation loop' in page and (site / "images" / "loop.png").stat().st_size > 10_000
    assert 400 <= len(re.sub(r"<[^>]+>", " ", page.split('class="md-content"')[1].split("</article>")[0]).split())
    # a knob name in the text is kept on one line; a code block's text is left as it is
    knobs = (site / "tutorials/search.html").read_text()
    assert re.search(r'<span class="whole"><code>[\w-]+</code></span>', knobs)
    assert '<span class="whole">' not in "".join(re.findall(r"<pre>.*?</pre>", page, re.S))
    assert "white-space: nowrap" in (site / "stylesheets" / "extra.css").read_text()


def test_validation_tables_are_the_results_files_figures(site):
    validation = _module("simgap_docs_validation", ROOT / "docs" / "hooks" / "validation.py")
    study = json.loads((ROOT / "bench" / "results" / "planner_study.json").read_text())
    table = [line for line in validation.planner_table("planner_study.json").splitlines()[2:] if line.startswith("|")]
    assert len(table) == len(study["rows"])
    for line, row in zip(table, study["rows"]):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[1] == row["planner"] and cells[2] == f"{row['goals_ideal']}/{row['agents']}"
        assert cells[7] == f"{row['gap_max_m']:.3f}" and cells[10] == f"{row['ms_per_call_mean']:.1f}"
    planners = (site / "validation/planners.html").read_text()
    assert "copied by hand" not in planners.lower() and f"{study['rows'][0]['ms_per_call_p95']:.1f}" in planners
    # one world's row of a file holding two is that world's row of the whole table, and the only one
    both = validation.recorded_table("recorded_corpus_cost_order_latency_100ms.json").splitlines()
    ideal = validation.recorded_table("recorded_corpus_cost_order_latency_100ms.json,ideal").splitlines()
    assert [line for line in ideal if line.startswith("| ideal |")] == [line for line in both
                                                                         if line.startswith("| ideal |")]
    assert not [line for line in ideal if line.startswith("| mujoco |")]
    # a printed section is the benchmark's own lines, from its heading to the next blank line
    printed = "\n".join(json.loads((ROOT / "bench" / "results" / "paper_study.json").read_text())["printed"])
    section = validation.printed_section("paper_study.json,Scores").split("```")[1].splitlines()[3:]
    assert section[0].startswith("Scores") and "\n".join(section) + "\n\n" in printed + "\n\n"
    scenarios = json.loads((ROOT / "bench" / "results" / "real_scenarios.json").read_text())
    table = validation.real_scenarios_table("real_scenarios.json").splitlines()
    for world, rate in scenarios["goal_rates"].items():
        row = next(line for line in table if line.startswith(f"| {world} |"))
        missed = [line.split()[0] for line in scenarios["printed"]
                  if re.match(rf"\S+\s+{world}\s+(?!goal_reached)\w+ ", line)]
        assert f"| {rate['goals']} / {rate['agents']} " in row and len(missed) == rate["agents"] - rate["goals"]
        assert all(f"`{name}`" in row for name in missed)
    export = (site / "tutorials/export.html").read_text()
    for row in json.loads((ROOT / "bench" / "results" / "export.json").read_text())["rows"]:
        assert re.search(rf"<td>{re.escape(row['map'])}</td>\s*<td[^>]*>{row['roads']}</td>", export), row["map"]


def test_the_attribution_page_counts_what_its_results_file_holds():
    """The paper study's explanations: the counts on the page are the rows' (runs explained, adding up within
    5 %, dominant assumption per car), one table row per explained run, and the cost ratio is each row's wall
    times'."""
    validation = _module("simgap_docs_validation", ROOT / "docs" / "hooks" / "validation.py")
    data = json.loads((ROOT / "bench" / "results" / "attribution_paper_curves.json").read_text())
    rows, page = data["rows"], validation.attribution_table("attribution_paper_curves.json")
    assert f"**{len(rows)} explained**" in page
    assert f"the shares of {sum(r['adds_up'] for r in rows)} of {len(rows)} add up" in page
    for car in {r["vehicle"] for r in rows}:
        mine = [r["dominant"] for r in rows if r["vehicle"] == car]
        counts = sorted(((mine.count(a), a) for a in set(mine)), reverse=True)
        assert f"{car} ({len(mine)} explained): " in page and all(f"`{a}` {n}" in page for n, a in counts)
    table = [line for line in page.splitlines() if line.startswith("| r=")]
    assert len(table) == len(rows)
    header = next(line for line in page.splitlines() if line.startswith("| curve")).split(" | ")
    ratio, cut = header.index("wall ratio"), header.index("cut")
    for line, r in zip(table, rows):
        cells = line.split(" | ")
        assert cells[ratio] == f"{r['wall_s'] / r['run_wall_s']:.1f}"
        assert cells[cut] == str(sum(w["until_s"] is not None for w in r["explanation"]["worlds"]))


def test_bench_readme_lists_every_benchmark_and_no_benchmark_imports_tests():
    table = (ROOT / "bench" / "README.md").read_text()
    assert not list((ROOT / "bench").glob("*.py")), "a benchmark belongs in the folder of its subject"
    scripts = sorted((ROOT / "bench").glob("*/*.py"))
    assert scripts
    for script in scripts:
        name = script.relative_to(ROOT).as_posix()
        assert f"`{name}`" in table, name
        source = script.read_text()
        assert not re.search(r"^\s*(from|import)\s+tests\b|sys\.path.*tests", source, re.M), name
        assert not re.search(r"sys\.path\.(insert|append)", source), f"{name} reaches code through sys.path"
    for f in (ROOT / "bench" / "results").glob("*.json"):
        assert f"results/{f.name}" in table, f.name


def test_every_tutorial_runs_commands():
    blocks = _module("simgap_docs_tutorials", ROOT / "docs" / "tutorial_blocks.py")
    tutorials = {f"tutorials/{page.name}" for page in (ROOT / "docs" / "tutorials").glob("*.md")}
    assert tutorials <= set(blocks.PAGES), f"tutorials whose commands no test runs: {tutorials - set(blocks.PAGES)}"
    for page in blocks.PAGES:
        assert "<!-- run -->" in (ROOT / "docs" / page).read_text(), f"{page} has no executed block"


TUTORIAL_PAGES = _module("simgap_docs_tutorials", ROOT / "docs" / "tutorial_blocks.py").PAGES


def _unquoted(command: str) -> str:
    """``command`` with every quoted stretch blanked (what a shell reads as operators is what is left)."""
    return re.sub(r"'[^']*'|\"(?:[^\"\\]|\\.)*\"", lambda m: " " * len(m.group()), command)


def _shell_parts(command: str) -> tuple[list[str], str | None] | None:
    """A tutorial line as ``A && B && ...``, the last of which may pipe its output into a shell
    command (``simgap run ... | grep ...``): (the commands, the pipe's tail or None); None for
    anything else a shell reads (redirections, variables, ``;``, an environment before the command)."""
    bare = _unquoted(command)
    if re.search(r"[;<>$`*?(){}#~\\]|(?<!&)&(?!&)|\|\|", bare) or re.match(r"\s*\w+=", bare):
        return None
    pipe = bare.find("|")
    tail = command[pipe + 1:].strip() if pipe >= 0 else None
    head, head_bare = (command[:pipe], bare[:pipe]) if pipe >= 0 else (command, bare)
    cuts = [m.start() for m in re.finditer("&&", head_bare)]
    parts = [head[a:b].strip() for a, b in zip([0] + [c + 2 for c in cuts], cuts + [len(head)])]
    return parts, tail


@pytest.mark.parametrize("page", TUTORIAL_PAGES)
def test_the_tutorials_print_what_the_page_shows(page):
    blocks = _module("simgap_docs_tutorials", ROOT / "docs" / "tutorial_blocks.py")

    def run(command: str, cwd: Path, env: dict[str, str]) -> tuple[str, int]:
        """Each ``simgap ARGS`` of a line (alone, chained with ``&&``, or piped into a shell command)
        in a fork of the command server (the same process a reader's shell starts, without
        importing simgap again); anything else with bash."""
        parts = _shell_parts(command)
        if parts is None or not any(p.split()[0] == "simgap" for p in parts[0]):
            return blocks.bash(command, cwd, env)
        commands, tail = parts
        printed = ""
        for part in commands:
            if part.split()[0] != "simgap":
                out, code = blocks.bash(part, cwd, env)
                printed += out
            else:
                proc = simgap_command.simgap(*shlex.split(part)[1:], cwd=cwd, env=env)
                code = proc.returncode
                if tail is not None and part is commands[-1]:      # its output into the pipe's tail
                    piped = subprocess.run(["bash", "-c", tail], input=proc.stdout, cwd=cwd, env=env,
                                           capture_output=True, text=True, timeout=300)
                    return printed + piped.stdout + proc.stderr + piped.stderr, piped.returncode
                printed += proc.stdout + proc.stderr
            if code != 0:
                break
        return printed, code

    assert blocks.main([page], run) == 0


def test_a_tutorial_line_is_cut_where_a_shell_cuts_it():
    assert _shell_parts("simgap generate t --out s/ && simgap run s/t.xml") == (["simgap generate t --out s/",
                                                                               "simgap run s/t.xml"], None)
    assert _shell_parts("""simgap run a.xml --json | grep -E '"(fingerprint|seed)"'""") == \
        (["simgap run a.xml --json"], """grep -E '"(fingerprint|seed)"'""")
    assert _shell_parts('simgap experiment query s "SELECT round(x, 1) FROM runs"') == \
        (['simgap experiment query s "SELECT round(x, 1) FROM runs"'], None)
    for other in ("simgap run a 2>&1; echo $?", "X=1 simgap run a", "ls runs 2>/dev/null | wc -l", "simgap run a || true",
                  "simgap run a &"):
        assert _shell_parts(other) is None, other


def test_no_page_fetches_anything_from_the_web_and_search_has_every_page(site):
    pages = sorted(site.rglob("*.html"))
    assert len(pages) >= 30
    for page in pages:
        text = page.read_text()
        external = re.findall(r'<(?:script|img|link|iframe)[^>]+(?:src|href)="(https?://[^"]+)"', text)
        assert not [u for u in external if not u.startswith("https://github.com")], f"{page}: {external}"
        for src in re.findall(r'<img[^>]+src="([^"]+)"', text):
            assert (page.parent / src.split("#")[0]).resolve().exists(), f"{page}: image {src}"
    index = json.loads((site / "search" / "search_index.json").read_text())
    locations = {d["location"].split("#")[0] for d in index["docs"]}
    assert {"getting-started.html", "reference/cli.html", "validation/results.html"} <= locations
    assert any("road_friction" in d["text"] for d in index["docs"])


@pytest.fixture
def served(site):
    """The site over HTTP on this machine (its search loads its index with fetch, which file:// refuses)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1",
                               "--directory", str(site)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(50):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                time.sleep(0.1)
        yield f"http://127.0.0.1:{port}"
    finally:
        server.terminate()
        server.wait(timeout=10)


class _Chromium:
    """Headless chromium driven over the DevTools protocol: one browser for every page a test opens."""

    def __init__(self, ws):
        self._ws, self._calls = ws, iter(range(1, 1_000_000))
        self.events: list[dict] = []           # what the page reported between calls (console, errors)

    def call(self, method: str, **params) -> dict:
        number = next(self._calls)
        self._ws.send(json.dumps({"id": number, "method": method, "params": params}))
        while (message := json.loads(self._ws.recv())).get("id") != number:
            if "method" in message:
                self.events.append(message)
        return message.get("result", {})

    def evaluate(self, expression: str):
        return self.call("Runtime.evaluate", expression=expression, returnByValue=True)["result"].get("value")

    def open(self, url: str, timeout: float = 60, settle: float = 0.5) -> None:
        """``url`` loaded, and ``settle`` seconds more for what its scripts report late."""
        deadline = time.monotonic() + timeout
        self.call("Page.navigate", url=url)
        while self.evaluate("document.readyState") != "complete" and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(settle)
        self.evaluate("0")                     # the events of the pause read

    def console(self) -> list[str]:
        """What the page wrote to its console, threw, or logged as an error or warning, since the last call."""
        found = []
        for event in self.events:
            params = event.get("params", {})
            if event["method"] == "Runtime.consoleAPICalled":
                found.append(f"console.{params['type']}: " + " ".join(str(a.get("value", a.get("description")))
                                                                    for a in params.get("args", [])))
            elif event["method"] == "Runtime.exceptionThrown":
                found.append(f"exception: {params['exceptionDetails'].get('text')}")
            elif event["method"] == "Log.entryAdded" and params["entry"]["level"] in ("error", "warning"):
                found.append(f"{params['entry']['level']}: {params['entry']['text']}")
        self.events.clear()
        return found


@contextlib.contextmanager
def _chromium(profile: Path) -> Iterator[_Chromium]:
    from websockets.sync.client import connect

    proc = subprocess.Popen([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                             "--disable-background-networking", "--disable-component-update", "--disable-sync",
                             f"--user-data-dir={profile}", "--remote-debugging-port=0", "about:blank"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        endpoint = next(m for line in proc.stderr if (m := re.search(r"DevTools listening on ws://[\d.]+:(\d+)/", line)))
        with urllib.request.urlopen(f"http://127.0.0.1:{endpoint.group(1)}/json/list") as answer:
            page = next(t["webSocketDebuggerUrl"] for t in json.loads(answer.read()) if t["type"] == "page")
        with connect(page, max_size=None) as ws:
            browser = _Chromium(ws)
            browser.call("Runtime.enable")
            browser.call("Log.enable")
            yield browser
    finally:
        proc.terminate()
        proc.wait(timeout=10)


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (make test installs it)")
def test_pages_load_in_chromium_without_console_errors(served, tmp_path):
    pytest.importorskip("websockets", reason="the DevTools client needs websockets (in requirements.lock)")
    with _chromium(tmp_path / "profile") as browser:
        browser.open("data:text/html,<script>console.error('seen')</script>", settle=0)   # what is watched
        assert browser.console() == ["console.error: seen"]
        for name in ["index.html", "getting-started.html", "reference/cli.html", "reference/api.html",
                     "validation/results.html", "concepts/fidelities.html", "reference/planner-protocol.html"]:
            browser.open(f"{served}/{name}")
            seen = browser.console()
            assert not seen, f"{name}: {seen}"
            dom = browser.evaluate("document.documentElement.outerHTML")
            assert 'class="md-content"' in dom and "md-nav" in dom, f"{name} did not render"


def _search_in_chromium(url: str, query: str, profile: Path, timeout: float = 60) -> tuple[str, list[str]]:
    """Opens ``url`` in headless chromium, types ``query`` into the site's search box (over the
    DevTools protocol) and waits for results: (the result list's heading, the results' links)."""
    with _chromium(profile) as browser:
        deadline = time.monotonic() + timeout
        browser.open(url, timeout, settle=0)
        browser.evaluate("document.querySelector('[data-md-component=search-query]').focus()")
        browser.call("Input.insertText", text=query)           # typed into the focused search box
        while True:
            links = browser.evaluate("[...document.querySelectorAll('.md-search-result__item a')].map(a => a.href)")
            heading = browser.evaluate("document.querySelector('.md-search-result__meta').textContent.trim()")
            if links or time.monotonic() > deadline:
                return heading, links
            time.sleep(0.5)


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (make test installs it)")
def test_search_finds_pages_offline_in_chromium(served, tmp_path):
    """The built site's search box, served from this machine with nothing from the web. (Material's
    search loads its index in a web worker with fetch, which chromium refuses from file://: opened
    as files, the search box stays at 'Initializing search'; served with `python -m http.server -d
    site`, it works.)"""
    pytest.importorskip("websockets", reason="the DevTools client needs websockets (in requirements.lock)")
    heading, links = _search_in_chromium(f"{served}/index.html", "road_friction", tmp_path / "profile")
    assert links, f"no search results; the search says {heading!r}"
    pages = {link.split("?")[0].removeprefix(served + "/") for link in links}
    assert "reference/knobs.html" in pages, pages
    assert all(link.startswith(served) for link in links)
