"""ASAM's Quality Checker on written files: the OpenDRIVE bundle (``asam-qc-opendrive``) on a .xodr,
the OpenSCENARIO bundle (``asam-qc-openscenarioxml``) on a .xosc, every checker of the bundle.

The checkers pin older numpy, lxml, xmlschema and pyclothoids than simgap does, so they live in a
virtual environment of their own (``make qc`` builds ``.venv-qc`` beside the checkout from
``requirements-qc.lock``; ``SIMGAP_QC_VENV`` points elsewhere) and run as a subprocess; their
result file (XQAR) is read here with ElementTree.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

_BUNDLES = {".xodr": ("qc_opendrive", "xodrBundle"), ".xosc": ("qc_openscenario", "xoscBundle")}
_LEVELS = {"1": "error", "2": "warning", "3": "information"}


class QualityCheckerMissing(RuntimeError):
    """ASAM's Quality Checker is not installed where simgap looks for it."""


@dataclass(frozen=True)
class CheckerResult:
    """One checker of a bundle: its id, status (completed, skipped, error) and issues by level."""

    checker: str
    status: str
    errors: int
    warnings: int
    summary: str


@dataclass(frozen=True)
class QualityReport:
    """A bundle's verdict on one file."""

    file: Path
    bundle: str
    checkers: tuple[CheckerResult, ...]
    rules: dict[str, int]                 # rule UID -> issues (errors and warnings)

    @property
    def errors(self) -> int:
        return sum(c.errors for c in self.checkers)

    @property
    def warnings(self) -> int:
        return sum(c.warnings for c in self.checkers)

    @property
    def skipped(self) -> list[CheckerResult]:
        return [c for c in self.checkers if c.status != "completed"]


def qc_environment() -> Path:
    """Where the checkers' virtual environment is (``SIMGAP_QC_VENV``, else ``.venv-qc`` of the checkout)."""
    return Path(os.environ.get("SIMGAP_QC_VENV") or Path(__file__).resolve().parents[3] / ".venv-qc")


def checker_command(suffix: str) -> Path:
    """The bundle's command for files ending in ``suffix``; QualityCheckerMissing if not installed."""
    command = qc_environment() / "bin" / _BUNDLES[suffix][0]
    if not command.exists():
        raise QualityCheckerMissing(f"ASAM's Quality Checker is not installed ({command} is missing; "
                                    "'make qc' installs it into .venv-qc)")
    return command


def check(path: str | Path, timeout_s: float = 600.0) -> QualityReport:
    """Every checker of the bundle for ``path`` (.xodr or .xosc), run on it."""
    path = Path(path).resolve()
    if path.suffix not in _BUNDLES:
        raise ValueError(f"{path.name}: ASAM's Quality Checker bundles read .xodr and .xosc files")
    command = checker_command(path.suffix)
    bundle = _BUNDLES[path.suffix][1]
    with tempfile.TemporaryDirectory(prefix="simgap-qc-") as tmp:
        config, result = Path(tmp) / "config.xml", Path(tmp) / "result.xqar"
        config.write_text(f'<?xml version="1.0" encoding="UTF-8"?>\n<Config>\n'
                          f'  <Param name="InputFile" value={quoteattr(str(path))}/>\n'
                          f'  <CheckerBundle application="{bundle}">\n'
                          f'    <Param name="resultFile" value={quoteattr(str(result))}/>\n'
                          f'  </CheckerBundle>\n</Config>\n')
        proc = subprocess.run([str(command), "-c", str(config)], cwd=tmp, capture_output=True, text=True,
                              timeout=timeout_s)
        if proc.returncode != 0 or not result.exists():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"{command.name} failed on {path.name} (exit {proc.returncode}): {tail[0]}")
        return _report(path, bundle, ET.parse(result).getroot())


def _report(path: Path, bundle: str, root: ET.Element) -> QualityReport:
    checkers: list[CheckerResult] = []
    rules: dict[str, int] = {}
    for checker in root.iter("Checker"):
        levels = [_LEVELS.get(issue.get("level", ""), "information") for issue in checker.iter("Issue")]
        for issue in checker.iter("Issue"):
            if issue.get("level") in ("1", "2"):
                rule = issue.get("ruleUID", checker.get("checkerId", ""))
                rules[rule] = rules.get(rule, 0) + 1
        checkers.append(CheckerResult(checker.get("checkerId", ""), checker.get("status", ""),
                                      levels.count("error"), levels.count("warning"), checker.get("summary", "")))
    return QualityReport(path, bundle, tuple(checkers), rules)
