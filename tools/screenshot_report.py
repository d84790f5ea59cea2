"""Render the HTML report of shipped scenarios in a real headless browser and take a screenshot of each.

    python tools/screenshot_report.py                                  # biomass_default and biomass_calibration
    python tools/screenshot_report.py --scenario nisar_lband --out /tmp/shots --quick

Each scenario is run into a temporary folder (``--quick``: smaller Monte Carlo sizes), its report.html is
opened by Chromium from the system packages (Debian: ``apt-get install chromium``) with no network, and the
page is saved as ``<out>/report_<scenario>.png``. The script then checks that the page rendered: the
screenshot is not blank and every plot embedded in the HTML decodes. Exit status 0 when every page renders,
1 when one does not, 2 when Chromium is missing.
"""

from __future__ import annotations

import argparse
import base64
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENARIOS = ("biomass_default", "biomass_calibration")
QUICK = ["--set", "simulation.realisations=400", "--set", "simulation.looks=2000"]
BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def find_browser() -> str | None:
    return next((shutil.which(name) for name in BROWSERS if shutil.which(name)), None)


def run_scenario(name: str, folder: Path, quick: bool) -> Path:
    cmd = [sys.executable, "-m", "e2esim", "run", str(ROOT / "scenarios" / f"{name}.yaml"), "-o", str(folder),
           "--force", "--no-progress", *(QUICK if quick else [])]
    subprocess.run(cmd, check=True, cwd=ROOT, capture_output=True, text=True)
    return folder / "report.html"


def screenshot(browser: str, page: Path, png: Path, width: int = 1400, height: int = 4000, scale: float = 1.0) -> None:
    """Chromium's own screenshot of ``page`` (headless, no sandbox, no network services, a fresh profile)."""
    with tempfile.TemporaryDirectory(prefix="e2esim-chromium-") as profile:
        cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
               "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
               "--hide-scrollbars", f"--force-device-scale-factor={scale}", f"--screenshot={png}",
               f"--window-size={width},{height}", page.resolve().as_uri()]
        subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=120)


def check_page(page: Path, png: Path) -> list:
    """Problems found: a blank screenshot, an embedded image that does not decode as PNG."""
    import matplotlib.image as mpimg
    import numpy as np

    problems = []
    pixels = mpimg.imread(png)
    if pixels.ndim < 3 or float(np.std(pixels[..., :3])) < 0.01:
        problems.append(f"{png.name}: the screenshot is blank")
    for i, data in enumerate(re.findall(r'src="data:image/png;base64,([^"]+)"', page.read_text(encoding="utf-8"))):
        if not base64.b64decode(data).startswith(b"\x89PNG"):
            problems.append(f"{page}: embedded image {i} is not a PNG")
    return problems


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", action="append", help="scenario name in scenarios/ (repeatable)")
    parser.add_argument("--out", type=Path, default=Path("screenshots"), help="folder for the PNGs")
    parser.add_argument("--quick", action="store_true", help="smaller Monte Carlo sizes")
    parser.add_argument("--height", type=int, default=4000, help="page height in pixels")
    parser.add_argument("--scale", type=float, default=1.0, help="device scale factor (0.5: half-size PNG)")
    args = parser.parse_args(argv)
    browser = find_browser()
    if browser is None:
        print("no Chromium found (apt-get install chromium)", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    problems = []
    with tempfile.TemporaryDirectory(prefix="e2esim-report-") as tmp:
        for name in args.scenario or DEFAULT_SCENARIOS:
            page = run_scenario(name, Path(tmp) / name, args.quick)
            png = args.out / f"report_{name}.png"
            screenshot(browser, page, png, height=args.height, scale=args.scale)
            found = check_page(page, png)
            problems += found
            print(f"{name}: {png} ({png.stat().st_size // 1024} KB){'; ' + '; '.join(found) if found else ''}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
