"""The HTML report in a real browser (issue 11, Build item 9): headless Chromium renders the reports of two
shipped scenarios and takes screenshots (tools/screenshot_report.py). Slow; skipped without Chromium."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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
