"""Runs the tutorials' blocks and keeps their printed output what the code prints.

In a page, a line ``<!-- run -->`` before a ```` ```console ```` block makes it executable: each line
starting with ``$ `` is a command, run with bash in a scratch folder of the page (the page's blocks
run in order, in the same folder, which links the repository's ``tests``, ``examples`` and ``bench``), and what follows it is its output. A line ``<!-- file: NAME -->``
before a code block writes the block to NAME in that folder first (a planner the next command runs).

    python docs/tutorial_blocks.py --write     # run every block, write the output into the pages
    python docs/tutorial_blocks.py             # run every block, exit 1 where a page differs

Wall times differ from run to run: they are compared as placeholders (see ``VOLATILE``), and a
table's padding is not compared. Everything else must match.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
PAGES = ["getting-started.md", "tutorials/validate-your-planner.md", "tutorials/planners-in-a-process.md",
         "tutorials/scenarios-and-runs.md", "tutorials/logical-scenarios.md", "tutorials/experiments.md",
         "tutorials/search.md", "tutorials/recorded-traffic.md", "tutorials/export.md", "tutorials/opendrive-in.md",
         "tutorials/3d-roads.md", "tutorials/ray.md", "tutorials/beamng.md"]
LINKED = ["tests", "examples", "bench"]       # the repository's folders a page's commands name, as from its root
BLOCK = re.compile(r"^<!-- (run|file: ([\w./-]+)) -->\n```(\w*)\n(.*?)^```$", re.M | re.S)
VOLATILE = [(re.compile(r"\d+(?:\.\d+)?/\d+(?:\.\d+)?/\d+(?:\.\d+)?"), "T"),        # plan [ms] mean/p95/max
            (re.compile(r"wall time [^;\n]*"), "wall time T"),
            (re.compile(r"\bin \d+(?:\.\d+)? s\b"), "in T s"),
            (re.compile(r"\(\d+(?:\.\d+)? s\)"), "(T s)"),
            (re.compile(r"(?<=; )\d+(?:\.\d+)? s$", re.M), "T s"),                     # an experiment's wall time
            (re.compile(r"\b\d+:\d\d:\d\d\b"), "H:MM:SS"),                                 # progress bars' clocks
            (re.compile(r'"(wall_time_s|planning_(?:mean|p95|max)_s|planning_over_budget|planning|execution|'
                        r'monitoring|scoring|validation|io|physics|tyres|control)": [\d.e-]+'), r'"\1": T'),
            (re.compile(r"^(│ (?:grid|random|lhs|bo|multi_fidelity) +│) +[\d.]+ (│.*│) +[\d.]+ │$", re.M),
             r"\1 T \2 T │"),                                                           # a search's min, per CPU-h
            (re.compile(r"^([\w-]+_s\d+ +\w+ +\w+) +\d+(?:\.\d+)?", re.M), r"\1 T")]          # real_scenarios' wall time
WIDTH = "110"


def normalise(text: str) -> str:
    for pattern, placeholder in VOLATILE:
        text = pattern.sub(placeholder, text)
    return re.sub(r"[\s\u2500-\u257f]+", " ", text).strip()


def _env() -> dict[str, str]:
    env = dict(os.environ, COLUMNS=WIDTH, NO_COLOR="1", TERM="dumb", MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src")] + [p for p in [env.get("PYTHONPATH")] if p])
    return env


#: how a block's command runs: (command, folder, environment) -> (what it printed, its exit code)
Runner = Callable[[str, Path, dict[str, str]], tuple[str, int]]


def bash(command: str, cwd: Path, env: dict[str, str]) -> tuple[str, int]:
    """``command`` run with bash, as a reader runs it."""
    proc = subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    return proc.stdout + proc.stderr, proc.returncode


def run_page(page: Path, scratch: Path, run: Runner = bash) -> tuple[str, list[tuple[str, str]]]:
    """(the page with every block's output as printed now, [(documented, printed)] of each block)."""
    text = page.read_text()
    blocks: list[tuple[str, str]] = []

    def block(m: re.Match) -> str:
        marker, name, lang, body = m.group(1), m.group(2), m.group(3), m.group(4)
        if name:
            (scratch / name).parent.mkdir(parents=True, exist_ok=True)
            (scratch / name).write_text(body)
            return m.group(0)
        commands = [line[2:] for line in body.splitlines() if line.startswith("$ ")]
        printed = []
        for command in commands:
            output, code = run(command, scratch, _env())
            output = output.rstrip()
            if code != 0:
                output += f"\n[exit {code}]"
            printed += [f"$ {command}"] + ([output] if output else [])
        new = "\n".join(printed) + "\n"
        blocks.append((body, new))
        return f"<!-- {marker} -->\n```{lang}\n{new}```"

    return BLOCK.sub(block, text), blocks


def main(argv: list[str] | None = None, run: Runner = bash) -> int:
    """Run the pages' blocks (``run``: how a command runs; the tests pass one that runs ``simgap``
    commands in a process forked from a server that has imported simgap, which prints the same)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write the printed output into the pages")
    parser.add_argument("pages", nargs="*", default=PAGES, help="pages under docs/ (default: all tutorials)")
    args = parser.parse_args(argv)
    differ = 0
    for name in args.pages:
        page = DOCS / name
        with tempfile.TemporaryDirectory(prefix="simgap-tutorial-") as scratch:
            for folder in LINKED:
                (Path(scratch) / folder).symlink_to(ROOT / folder)
            new_text, blocks = run_page(page, Path(scratch), run)
        if args.write:
            page.write_text(new_text)
            print(f"{name}: {len(blocks)} blocks written")
            continue
        for documented, printed in blocks:
            if normalise(documented) != normalise(printed):
                differ += 1
                print(f"{name}: a block's output differs from the page\n--- page:\n{documented}--- printed now:\n{printed}")
        if any("[exit " in printed for _, printed in blocks):
            differ += 1
            print(f"{name}: a command failed")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
