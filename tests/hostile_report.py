"""A run whose scenario text tries to make its report fetch or run something (issue 22, item 9), and the check
that its report.html and report.md (as a Markdown viewer renders it) do neither. Used by
tests/test_report_self_contained.py and, in a real browser, tests/test_report_browser.py."""

from __future__ import annotations

import warnings
from html.parser import HTMLParser
from pathlib import Path

HOSTILE = [
    "![pixel](http://{host}/image.png)",
    "[click me](http://{host}/link)",
    "<http://{host}/autolink>",
    "<script>document.title='ran'; fetch('http://{host}/script')</script>",
    "<img src=http://{host}/onerror.png onerror=\"fetch('http://{host}/onerror')\">",
    "&lt;img src=http://{host}/entity.png&gt;",
    "[ref]: http://{host}/definition",
    "![ref] and [ref]",
    "`<img src=http://{host}/in-code.png>` in code",
]
"""Texts that would become an external image, link or script in a naive rendering; ``{host}`` is where a test
server listens."""


def hostile_scenario(host: str) -> dict:
    texts = [t.format(host=host) for t in HOSTILE]
    return {
        "name": "hostile",
        "description": "\n".join(texts),
        "instrument": {"type": "biomass", "name": texts[4]},
        "scene": {"type": "table1_forest", "forest": "boreal_200"},
        "propagation": {"type": "hv_backscatter_error"},
        "retrieval": {"type": "power_law"},
        "requirements": [{"type": "agb_rmse", "max_percent": 20, "name": " ".join(texts[:5])},
                         {"type": "agb_error_bound", "name": texts[6]}],
        "sweep": {"parameters": {"instrument.crosstalk.level_db": [-30.0, -25.0]}},
        "output": {"title": " ".join(texts[:4]), "plots": ["verdicts"]},
        "simulation": {"mode": "analytic"},
    }


def write_hostile_report(folder: Path, host: str = "127.0.0.1:9") -> Path:
    """Run the hostile scenario into ``folder`` (its report.md and report.html); return the folder."""
    import e2esim
    from e2esim.api import NoEffectWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoEffectWarning)  # the names change no number
        e2esim.run(hostile_scenario(host), output=folder)
    return folder


class _Elements(HTMLParser):
    def __init__(self):
        super().__init__()
        self.found: list = []

    def handle_starttag(self, tag, attrs):
        self.found.append((tag, dict(attrs)))


def fetching_elements(html: str) -> list:
    """Every element of ``html`` that could fetch or run something: a script, a link, an embedded frame or
    object, a stylesheet, an image other than a data: URL, any attribute naming a URL or an event handler."""
    parser = _Elements()
    parser.feed(html)
    bad = []
    for tag, attrs in parser.found:
        if tag in ("script", "a", "iframe", "object", "embed", "link", "base", "form", "video", "audio", "source"):
            bad.append((tag, attrs))
        elif tag == "img" and not str(attrs.get("src", "")).startswith("data:image/png;base64,"):
            bad.append((tag, attrs))
        elif any(k.startswith("on") or (k in ("href", "src", "srcset", "action", "background")
                                        and not str(v).startswith("data:image/png;base64,")) for k, v in attrs.items()):
            bad.append((tag, attrs))
    return bad


def markdown_as_a_viewer_renders_it(text: str) -> str:
    """report.md rendered as a permissive Markdown viewer would: CommonMark with raw HTML on, and tables."""
    from markdown_it import MarkdownIt

    return MarkdownIt("commonmark", {"html": True}).enable("table").render(text)


def local_plot_images(rendered_md: str, folder: Path) -> list:
    """The images of rendered report.md that are the run's own PNG files (allowed: they are in its folder)."""
    parser = _Elements()
    parser.feed(rendered_md)
    return [a["src"] for t, a in parser.found if t == "img" and "/" not in a.get("src", "/")
            and a["src"].endswith(".png") and (folder / a["src"]).is_file()]
