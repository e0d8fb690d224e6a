"""A small self-contained HTML page: what was run, outcomes, cross-fidelity gaps, pictures.

Every image sits next to the page and is linked relatively, so the folder opens as a file with
no network access.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 4px 8px; text-align: right; }
th { background: #eee; } td.text { text-align: left; }
img { max-width: 100%; border: 1px solid #ddd; margin: 4px 0; }
.good { color: #006d2c; } .bad { color: #a50f15; font-weight: bold; }
figure { display: inline-block; margin: 0 1em 1em 0; vertical-align: top; max-width: 48%; }
figcaption { font-size: 0.85em; color: #555; }
"""


@dataclass
class Section:
    title: str
    rows: list[dict] = field(default_factory=list)       # one table
    images: list[tuple[str, str]] = field(default_factory=list)   # (relative path, caption)
    text: str = ""


def _cell(value) -> str:
    if isinstance(value, float):
        return f"<td>{value:.3f}</td>"
    text = html.escape(str(value))
    if value == "goal_reached":
        return f'<td class="text good">{text}</td>'
    if value in ("collision", "off_road", "planner_failure", "timeout", "diverged", "failed"):
        return f'<td class="text bad">{text}</td>'
    return f'<td class="text">{text}</td>'


def table(rows: Sequence[dict]) -> str:
    if not rows:
        return ""
    cols = list(rows[0])
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = "".join("<tr>" + "".join(_cell(r.get(c, "")) for c in cols) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def write_page(path: Path, title: str, intro: str, sections: Sequence[Section]) -> Path:
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
             f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1><p>{intro}</p>"]
    for sec in sections:
        parts.append(f"<h2>{html.escape(sec.title)}</h2>")
        if sec.text:
            parts.append(f"<p>{sec.text}</p>")
        parts.append(table(sec.rows))
        for src, caption in sec.images:
            parts.append(f"<figure><img src='{html.escape(src)}' alt='{html.escape(caption)}'>"
                         f"<figcaption>{html.escape(caption)}</figcaption></figure>")
    parts.append("</body></html>")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text("\n".join(parts))
    tmp.replace(path)
    return path
