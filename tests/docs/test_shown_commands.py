"""The commands the documentation shows but does not run (a BeamNG server, a Ray cluster, a long
search): each `simgap` command must still exist with every option it is shown with, and each
benchmark or example it names must exist, so that a page cannot drift from the code unseen. The
blocks that do run are checked by test_tutorials (docs/tutorial_blocks.py)."""

from __future__ import annotations

import importlib.util
import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
pytest.importorskip("mkdocs", reason="the docs tools are not installed (make install puts them into .venv)")

BLOCK = re.compile(r"(?:^<!-- (run|file: [^>]*) -->\n)?^```(console|bash|sh|shell)\n(.*?)^```$", re.M | re.S)
# a shown command ends at a pipe, a redirection or the next command
STOP = {"|", "||", "&&", ";", ">", ">>", "2>&1", "&"}


def _cli():
    spec = importlib.util.spec_from_file_location("simgap_docs_generate_cmds", ROOT / "docs" / "hooks" / "generate.py")
    generate = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generate)
    return dict(generate.cli_commands(generate.cli_app()))


def shown_commands(text: str) -> list[str]:
    """The command lines of the page's console blocks that no `<!-- run -->` marks."""
    lines = []
    for marker, _, body in BLOCK.findall(text):
        if marker:
            continue
        joined = body.replace("\\\n", " ")
        for line in joined.splitlines():
            line = line.strip()
            if line.startswith("$ "):
                lines.append(line[2:])
            elif not line.startswith("#") and re.match(r"(simgap|python|\.venv/bin/python|MUJOCO_GL=)", line):
                lines.append(line)
    return lines


def _words(line: str) -> list[str]:
    try:
        words = shlex.split(line, comments=True)
    except ValueError:          # an unbalanced quote in prose-like output: not a command
        return []
    out = []
    for w in words:
        if w in STOP:
            break
        out.append(w)
    return out


PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_shown_command_exists_with_its_options(page):
    commands = _cli()
    checked = 0
    for line in shown_commands(page.read_text()):
        words = [w for w in _words(line) if not re.match(r"^[A-Z_]+=", w)]     # environment assignments
        if not words:
            continue
        if words[0] == "simgap":
            path = next((p for p in sorted(commands, key=len, reverse=True)
                         if words[:len(p.split())] == p.split()), None)
            assert path is not None, f"{page.name}: `{line}` names no simgap command"
            options = {o for param in commands[path].params
                       for o in [*getattr(param, "opts", []), *getattr(param, "secondary_opts", [])]} | {"--help"}
            for w in words[len(path.split()):]:
                if w.startswith("--"):
                    assert w.split("=", 1)[0] in options, f"{page.name}: `{line}`: {path} has no option {w}"
            checked += 1
        elif words[0].endswith("python") and len(words) > 1 and words[1].endswith(".py"):
            script = words[1]
            if script.startswith(("bench/", "examples/", "docs/", "tests/")):
                assert (ROOT / script).is_file(), f"{page.name}: `{line}` names {script}, which does not exist"
                checked += 1
    if page.name in ("beamng.md", "ray.md"):
        assert checked, f"{page.name} shows commands that are not run: at least those must be checked"
