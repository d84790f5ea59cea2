"""Render the report blocks (``e2esim.report.document``) as report.md and as a self-contained report.html
with the plots embedded, so a person can open it in a browser from anywhere.

The HTML comes from a Jinja2 template (``templates/report.html.j2``, autoescaped); the Markdown of paragraphs
and table cells is rendered by markdown-it-py (CommonMark, raw HTML off), and verdict badges are styled the
same way everywhere.

Report text holds scenario text (a description, names, labels). Both renderings go through
``e2esim.report.safe_markdown``: code spans and emphasis stay, while images, links, autolinks and raw HTML
show as literal text, so report.md opened in any Markdown viewer and report.html in a browser fetch nothing and
run nothing (issue 22). The HTML parser has the link, image, autolink and HTML rules switched off as well; the
only image of report.html is a plot embedded as a data: URL, and its Content-Security-Policy forbids
every other source.
"""

from __future__ import annotations

import base64
import re
from pathlib import Path

from jinja2 import Environment, PackageLoader, select_autoescape
from markdown_it import MarkdownIt
from markupsafe import Markup, escape

from e2esim.atomic import write_text_atomic
from e2esim.report.blocks import Badge, Details, Heading, Image, Paragraph, Table, Warning
from e2esim.report.document import build_report
from e2esim.report.safe_markdown import literal, one_line, safe_inline

_MD = MarkdownIt("commonmark", {"html": False}).disable(["link", "image", "autolink", "html_inline", "html_block"])
_ENV = Environment(loader=PackageLoader("e2esim.report", "templates"), autoescape=select_autoescape(["j2", "html"]),
                   trim_blocks=True, lstrip_blocks=True)


def to_markdown(blocks) -> str:
    out = []
    for b in blocks:
        if isinstance(b, Heading):
            out += ["#" * b.level + " " + literal(b.text), ""]
        elif isinstance(b, Paragraph):
            out += [safe_inline(b.text), ""]
        elif isinstance(b, Table):
            out.append("| " + " | ".join(_md_cell(h) for h in b.header) + " |")
            out.append("|" + "---|" * len(b.header))
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("")
        elif isinstance(b, Image):
            out += [f"![{literal(b.caption)}]({b.file})", "", f"*{literal(b.caption)}*", ""]
        elif isinstance(b, Warning):
            out += [f"> **Warning:** {safe_inline(b.text)}", ""]
        elif isinstance(b, Details):
            out += [f"<details><summary>{escape(one_line(b.summary))}</summary>", "", to_markdown(b.blocks),
                    "</details>", ""]
    return "\n".join(out)


def _md_cell(cell) -> str:
    return safe_inline(cell).replace("|", "\\|")


_PLAIN = re.compile(r"[^\\`*_\[\]!<>&\n\r\0]*")
"""Text with no character that CommonMark's inline rules act on: markdown-it would only escape its quotes."""
_INWORD_UNDERSCORE = re.compile(r"(?<=[0-9A-Za-z])_(?=[0-9A-Za-z])")
"""An underscore between letters or digits (``agb_t_ha``) neither opens nor closes emphasis (CommonMark 0.31,
6.2, rules 2 and 4: it is both left- and right-flanking, with no punctuation beside it)."""


def _inline(text: str) -> Markup:
    text = str(text)
    if _PLAIN.fullmatch(_INWORD_UNDERSCORE.sub("", text)):  # most cells (numbers, names): skip the 0.1 ms parse
        return Markup(text.replace('"', "&quot;"))
    return Markup(_MD.renderInline(safe_inline(text)))


def _cell(cell) -> Markup:
    if isinstance(cell, Badge):
        css = {"PASS": "pass", "FAIL": "fail"}.get(cell.status, "na")
        return Markup(f'<span class="badge {css}">{escape(cell.status)}</span> ') + _inline(cell.text)
    return _inline(cell)


def _paragraph_html(text: str) -> Markup:
    # a conclusion starts with its badge, written "**PASS**" in Markdown
    for status, css in (("PASS", "pass"), ("FAIL", "fail"), ("N/A", "na")):
        if text.startswith(f"**{status}** "):
            return Markup(f'<span class="badge {css}">{status}</span> ') + _inline(text[len(status) + 5:])
    return _inline(text)


def _view(blocks, folder: Path) -> list:
    """Plain dicts for the template, with Markdown already turned into safe HTML."""
    out = []
    for b in blocks:
        if isinstance(b, Heading):
            out.append({"kind": "heading", "level": b.level, "text": b.text})
        elif isinstance(b, Paragraph):
            out.append({"kind": "paragraph", "html": _paragraph_html(b.text),
                        "conclusion": b.text.startswith(("**PASS**", "**FAIL**", "**N/A**"))})
        elif isinstance(b, Table):
            out.append({"kind": "table", "header": [_inline(h) for h in b.header],
                        "rows": [[_cell(c) for c in row] for row in b.rows]})
        elif isinstance(b, Image):
            data = base64.b64encode((folder / b.file).read_bytes()).decode("ascii")
            out.append({"kind": "image", "data": data, "caption": b.caption})
        elif isinstance(b, Warning):
            out.append({"kind": "warning", "html": _inline(b.text)})
        elif isinstance(b, Details):
            out.append({"kind": "details", "summary": b.summary, "blocks": _view(b.blocks, folder)})
    return out


def to_html(blocks, folder: Path) -> str:
    title = next((b.text for b in blocks if isinstance(b, Heading)), "e2esim report")
    return _ENV.get_template("report.html.j2").render(title=title, blocks=_view(blocks, Path(folder)))


def write_report(result, folder: Path, plots: list, warnings: list = ()) -> None:
    """Write report.md and report.html into ``folder``."""
    blocks = build_report(result, plots, warnings)
    write_text_atomic(folder / "report.md", to_markdown(blocks))
    write_text_atomic(folder / "report.html", to_html(blocks, folder))
