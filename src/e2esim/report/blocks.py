"""The pieces a report is made of, rendered to Markdown and HTML by ``e2esim.report.render``.

Text in paragraphs and table cells is Markdown (``code``, **bold**); a verdict is a ``Badge`` so that both
renderings style PASS and FAIL the same way everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

MAX_INLINE_ROWS = 20
"""Tables longer than this go into a collapsible section (HTML <details>), after the plots."""


@dataclass(frozen=True)
class Heading:
    level: int
    text: str


@dataclass(frozen=True)
class Paragraph:
    text: str  # Markdown


@dataclass(frozen=True)
class Table:
    header: tuple
    rows: tuple


@dataclass(frozen=True)
class Image:
    file: str  # PNG in the run folder
    caption: str


@dataclass(frozen=True)
class Warning:
    text: str  # why a requested plot or table is missing


@dataclass(frozen=True)
class Details:
    """A collapsible section: ``summary`` shown, ``blocks`` inside."""

    summary: str
    blocks: tuple


@dataclass(frozen=True)
class Badge:
    """A verdict in a table cell or a sentence: ``status`` PASS, FAIL or N/A, then ``text``."""

    status: str
    text: str = ""

    def __str__(self) -> str:
        return f"**{self.status}** {self.text}".strip()


STATUS_WORDS = {"pass": "PASS", "fail": "FAIL", "not_applicable": "N/A"}


def status_badge(status: str, text: str = "") -> Badge:
    """The badge of a verdict's ``status`` ("pass", "fail", "not_applicable")."""
    return Badge(STATUS_WORDS[status], text)


def fmt(x, digits=4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def table_blocks(title: str, table: Table, intro: str = "") -> list:
    """A titled table: inline when short, else collapsed with its row count in the summary."""
    lead = [Paragraph(intro)] if intro else []
    if len(table.rows) <= MAX_INLINE_ROWS:
        return [Heading(3, title), *lead, table]
    return [Details(f"{title} ({len(table.rows)} rows)", (*lead, table))]
