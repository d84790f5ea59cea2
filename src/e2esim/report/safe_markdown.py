"""Report text made safe for Markdown viewers and browsers alike: scenario text (a description, a title, a site or
requirement name) reaches the report, and a Markdown image, link or raw HTML in it would make a viewer fetch
or run something (issue 22, item 9).

``safe_inline`` keeps what the report's own text uses, code spans, emphasis and strong emphasis, and turns
everything else into literal text: an image ``![a](http://host/x.png)``, a link, an autolink ``<http://...>``
and raw HTML ``<script>``, ``<img onerror=...>`` show as the characters that were written, backslash-escaped so
that no CommonMark reader, with raw HTML on or off, makes an element of them. ``literal`` escapes all Markdown
(for text the HTML report shows as plain text: headings, captions). Both give one line.

The text is parsed by markdown-it (CommonMark, raw HTML recognised, as a permissive viewer would) and written
back from its tokens, so the escaping follows the parser's reading rather than a pattern of its own.
"""

from __future__ import annotations

import re

from markdown_it import MarkdownIt

_PARSER = MarkdownIt("commonmark", {"html": True})

_SPECIAL = re.compile(r"[\\`*_\[<&~]|^\s*([#>+-]|\d{1,9}[.)])")
"""Text with none of these needs no parsing: characters with a meaning in CommonMark's inline syntax (``~``
for a fence), and what starts a block."""
_INWORD_UNDERSCORE = re.compile(r"(?<=[^\W_])_(?=[^\W_])")
"""An underscore between letters or digits (``agb_t_ha``, ``σ_hv``) neither opens nor closes emphasis
(CommonMark 0.31, 6.2): left as it is, so that names stay readable in report.md."""
_ESCAPE = re.compile(r"(?<![^\W_])_|_(?![^\W_])|[\\`*\[~]|<(?=[A-Za-z/!?])|&(?=#?[0-9A-Za-z]+;)")
"""What ``_escape`` backslash-escapes: every character that can open an inline construct (an underscore only
where it can, ``<`` only where a tag or an autolink can follow, ``&`` only where it starts an entity). ``]`` and
``!`` need no escape once every ``[`` has one: no link or image can form without it."""
_BLOCK_START = re.compile(r"^(#{1,6}(?=\s|$)|>|[-+](?=\s|$|-)|\d{1,9}(?=[.)](\s|$)))")
"""What would make the start of a line a heading, a quote, a list item or a thematic break (``-0.3`` is none)."""


def one_line(text) -> str:
    """``text`` with every line break and run of blanks as one space, stripped."""
    return " ".join(str(text).split())


def literal(text) -> str:
    """Markdown that shows ``text`` exactly, as one line: every character with a Markdown meaning escaped."""
    return _block_safe(_escape(one_line(text)))


def safe_inline(text) -> str:
    """Markdown (one line) that keeps the code spans, emphasis and strong emphasis of ``text`` and shows every
    image, link, autolink and piece of raw HTML in it as literal text."""
    text = one_line(text)
    if not _SPECIAL.search(_INWORD_UNDERSCORE.sub("", text)):  # most cells: numbers and names
        return _block_safe(text)
    return _block_safe("".join(_write(_PARSER.parseInline(text)[0].children or [])))


def _write(tokens) -> list:
    """The Markdown of each token, in order (one string per token)."""
    out = []
    for tok in tokens:
        kind = tok.type
        if kind == "text":
            out.append(_escape(tok.content))
        elif kind in ("softbreak", "hardbreak"):
            out.append(" ")
        elif kind == "code_inline":
            out.append(_code_span(tok.content))
        elif kind in ("em_open", "em_close", "strong_open", "strong_close"):
            out.append(tok.markup)
        elif kind == "link_open":
            out.append("\\<" if tok.markup == "autolink" else "\\[")
        elif kind == "link_close":
            out.append(">" if tok.markup == "autolink" else "")
        elif kind == "image":
            alt = "".join(_write(tok.children or []))
            out.append(f"!\\[{alt}]({_escape(str(tok.attrs.get('src', '')))})")
        else:  # html_inline, and anything a later markdown-it may add: its text, literally
            out.append(_escape(tok.content))
    return _close_links(tokens, out)


def _close_links(tokens, out: list) -> list:
    """Put ``](target)`` after the text of each link (its ``link_close`` wrote nothing); links do not nest."""
    href = ""
    for i, tok in enumerate(tokens):
        if tok.type == "link_open" and tok.markup != "autolink":
            href = str(tok.attrs.get("href", ""))
        elif tok.type == "link_close" and tok.markup != "autolink":
            out[i] = f"]({_escape(href)})"
    return out


def _escape(text: str) -> str:
    return _ESCAPE.sub(lambda m: "\\" + m.group(0), text)


def _code_span(content: str) -> str:
    """A code span of ``content``: a fence longer than any run of backticks inside it, and where a backtick or a
    blank is at an end, a space inside each fence (which CommonMark strips again)."""
    fence = "`" * (max((len(run) for run in re.findall(r"`+", content)), default=0) + 1)
    pad = " " if content[:1] in ("`", " ") or content[-1:] in ("`", " ") else ""
    return f"{fence}{pad}{content}{pad}{fence}"


def _block_safe(text: str) -> str:
    """``text`` with a backslash before what would start a block at the start of a line (after the digits of
    an ordered list's number)."""
    return _BLOCK_START.sub(lambda m: m.group(0) + "\\" if m.group(0)[0].isdigit() else "\\" + m.group(0), text,
                            count=1)
