"""The report is self-contained in fact (issue 22, item 9): Markdown images and links, autolinks and raw HTML in
scenario text (description, title, names) become neither external elements of report.html nor of report.md as
a Markdown viewer renders it; they show as the text that was written. The same run in a real browser, with a
server counting requests: tests/test_report_browser.py."""

import html as html_module
import re
from html.parser import HTMLParser

import pytest
from hostile_report import fetching_elements, local_plot_images, markdown_as_a_viewer_renders_it, write_hostile_report

from e2esim.report.blocks import Badge, Heading, Paragraph, Table
from e2esim.report.render import to_html, to_markdown


@pytest.fixture(scope="module")
def hostile_run(tmp_path_factory):
    return write_hostile_report(tmp_path_factory.mktemp("hostile") / "run")


class _Text(HTMLParser):
    def __init__(self):
        super().__init__()
        self.parts = []

    def handle_data(self, data):
        self.parts.append(data)


def _shown_text(page: str) -> str:
    parser = _Text()
    parser.feed(page)
    return " ".join(" ".join(parser.parts).split())


def test_report_html_has_no_external_element_and_forbids_them(hostile_run):
    page = (hostile_run / "report.html").read_text(encoding="utf-8")
    assert fetching_elements(page) == []
    assert ("<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; "
            "style-src 'unsafe-inline'\">") in page


def test_report_md_as_a_viewer_renders_it_has_no_external_element(hostile_run):
    rendered = markdown_as_a_viewer_renders_it((hostile_run / "report.md").read_text(encoding="utf-8"))
    plots = local_plot_images(rendered, hostile_run)
    assert [e for e in fetching_elements(rendered) if not (e[0] == "img" and e[1].get("src") in plots)] == []
    assert "127.0.0.1:9" in rendered  # the hostile text is there, as text


def test_the_hostile_text_is_shown_as_written(hostile_run):
    page = (hostile_run / "report.html").read_text(encoding="utf-8")
    rendered = markdown_as_a_viewer_renders_it((hostile_run / "report.md").read_text(encoding="utf-8"))
    for shown in (_shown_text(page), _shown_text(rendered)):
        assert "![pixel](http://127.0.0.1:9/image.png)" in shown
        assert "[click me](http://127.0.0.1:9/link)" in shown
        assert "<script>document.title='ran'; fetch('http://127.0.0.1:9/script')</script>" in shown
        assert "onerror=\"fetch('http://127.0.0.1:9/onerror')\">" in shown
        assert "[ref]: http://127.0.0.1:9/definition" in shown


@pytest.mark.parametrize("text", ["![x](http://h/x.png)", "[a](http://h/)", "<img src=x onerror=alert(1)>",
                                  "<http://h/>", "a\n\n<script>alert(1)</script>", "`` a`<b>` `` <i>x</i>",
                                  "\\<img src=x>", "[r]: http://h/\n\n![r]", "**PASS** [r]"])
@pytest.mark.parametrize("where", ["heading", "paragraph", "cell"])
def test_no_text_becomes_an_element_in_either_rendering(tmp_path, text, where):
    block = {"heading": Heading(2, text), "paragraph": Paragraph(text),
             "cell": Table(("a", "b"), ((Badge("PASS", text), text),))}[where]
    blocks = [Heading(1, "t"), Paragraph("[r]: http://h/definition"), block, Paragraph("[r] ![r]")]
    assert fetching_elements(to_html(blocks, tmp_path)) == []
    rendered = markdown_as_a_viewer_renders_it(to_markdown(blocks))
    assert fetching_elements(rendered) == [], rendered
    assert not re.search(r"<(script|img|a|i)[ >]", rendered.replace("&lt;", "")), rendered


def test_the_reports_own_markdown_still_renders():
    blocks = [Paragraph("**PASS** AGB RMSE <= 20 %: `agb_t_ha` in [0, 1] of σ_hv, *assumed*")]
    page = to_html(blocks, ".")
    assert ('<span class="badge pass">PASS</span> AGB RMSE &lt;= 20 %: <code>agb_t_ha</code> in [0, 1] of σ_hv, '
            "<em>assumed</em>") in page
    assert to_markdown(blocks).startswith("**PASS** AGB RMSE <= 20 %: `agb_t_ha` in \\[0, 1] of σ_hv, *assumed*")
    assert html_module.unescape(markdown_as_a_viewer_renders_it(to_markdown(blocks))).startswith(
        "<p><strong>PASS</strong> AGB RMSE <= 20 %: <code>agb_t_ha</code> in [0, 1] of σ_hv, <em>assumed</em>")
