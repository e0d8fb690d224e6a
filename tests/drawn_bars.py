"""Progress bars as a command drew them on a captured standard error (``SIMGAP_PROGRESS=always``),
read back line by line, and the check that standard output is the same with and without them."""

from __future__ import annotations

import re

ESCAPES = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
TIMES = re.compile(r"\d+(?:\.\d+)? s\b")                     # a command's own wall times on stdout
BAR = re.compile(r"^(?P<phase>.+?) +[━╸╺ ]+ (?P<counts>.+?) +(?P<elapsed>\d+:\d\d:\d\d) elapsed, "
                 r"(?P<left>\d+:\d\d:\d\d|-:--:--) left$")


def drawn(stderr: str) -> dict[str, list[re.Match]]:
    """Every bar line drawn on ``stderr``, by phase, in the order drawn."""
    lines = ESCAPES.sub("", stderr).replace("\r", "\n").splitlines()
    bars: dict[str, list[re.Match]] = {}
    for line in lines:
        if (m := BAR.match(line.strip())) is not None:
            bars.setdefault(m["phase"], []).append(m)
    return bars


def same_stdout(with_bars: str, without: str) -> None:
    """Standard output with bars drawn is without any of them, and the same as without (but for times)."""
    assert "\x1b[" not in with_bars and "elapsed," not in with_bars
    assert TIMES.sub("T s", with_bars) == TIMES.sub("T s", without)
