"""The HTML report in a real browser (issue 11, Build item 9): headless Chromium renders the reports of two
shipped scenarios and takes screenshots (tools/screenshot_report.py; slow). A report whose scenario text tries to
fetch or run something fetches and runs nothing (issue 22, item 9). Skipped without Chromium."""

import http.server
import shutil
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import ClassVar

import pytest
from hostile_report import markdown_as_a_viewer_renders_it, write_hostile_report

ROOT = Path(__file__).resolve().parents[1]
BROWSER = next((shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome") if shutil.which(b)), None)


@pytest.mark.slow
@pytest.mark.skipif(not any(shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome")),
                    reason="no Chromium (apt-get install chromium)")
def test_two_reports_render_in_chromium(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "screenshot_report.py"), "--quick", "--out",
                           str(tmp_path)], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for name in ("biomass_default", "biomass_calibration"):
        png = tmp_path / f"report_{name}.png"
        assert png.stat().st_size > 50_000  # a rendered page with tables and plots, not an empty one


class _Recorder(http.server.BaseHTTPRequestHandler):
    requests: ClassVar[list] = []

    def do_GET(self):
        type(self).requests.append(self.path)
        self.send_response(200)
        self.send_header("Content-Type", "image/png")
        self.end_headers()

    def log_message(self, *args):
        pass


def _dom(browser: str, page: Path) -> str:
    """The page's DOM after loading and running it (headless Chromium, fresh profile, 3 s of page time)."""
    with tempfile.TemporaryDirectory(prefix="e2esim-chromium-") as profile:
        proc = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                               "--disable-background-networking", "--disable-component-update", "--disable-sync",
                               f"--user-data-dir={profile}", "--virtual-time-budget=3000", "--dump-dom",
                               page.resolve().as_uri()], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.skipif(not BROWSER, reason="no Chromium (apt-get install chromium)")
def test_a_hostile_report_makes_the_browser_fetch_and_run_nothing(tmp_path):
    """Issue 22, item 9: Markdown images and links, autolinks and raw HTML in scenario text made a headless
    browser fetch four resources from a local server. Now neither report.html nor report.md (rendered as a
    permissive Markdown viewer would, raw HTML on) makes Chromium request anything or run a script."""
    _Recorder.requests = []
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Recorder)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        folder = write_hostile_report(tmp_path / "run", host=f"127.0.0.1:{server.server_address[1]}")
        viewer = folder / "report_md_rendered.html"
        viewer.write_text(markdown_as_a_viewer_renders_it((folder / "report.md").read_text(encoding="utf-8")),
                          encoding="utf-8")
        doms = {page.name: _dom(BROWSER, page) for page in (folder / "report.html", viewer)}
    finally:
        server.shutdown()
        server.server_close()
    assert _Recorder.requests == []
    for name, dom in doms.items():
        assert "ran</title>" not in dom and "<script" not in dom, name
        assert "![pixel](http://127.0.0.1:" in dom, name  # shown as text
