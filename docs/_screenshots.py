"""Screenshots of three pages of the built site (getting started, a tutorial, an API page),
taken by a headless Chromium and written as small PNG files.

    python docs/_screenshots.py [OUT]        (after `make docs`; default OUT: docs/screenshots)

Chromium is not a dependency of grainlab: on Debian, `apt-get install chromium`."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from PIL import Image

HERE = Path(__file__).resolve().parent
PAGES = {"getting-started": "getting-started.html",
         "tutorial-triaxial-microstructure": "tutorials/triaxial-microstructure.html",
         "api-discrete-run": "reference/generated/grainlab.lab.discrete_run.html"}
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--window-size=1400,1600")


def take(site: Path, out: Path) -> list[Path]:
    """One PNG per page of :data:`PAGES` in ``out``; returns their paths."""
    browser = next((shutil.which(name) for name in BROWSERS if shutil.which(name)), None)
    if browser is None:
        raise SystemExit("no Chromium found (" + ", ".join(BROWSERS) + "): on Debian, "
                         "`apt-get install chromium`")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with tempfile.TemporaryDirectory() as profile:
        for name, page in PAGES.items():
            if not (site / page).exists():
                raise SystemExit(f"{site / page} is missing: run `make docs` first")
            path = out / f"{name}.png"
            subprocess.run([browser, *FLAGS, f"--user-data-dir={profile}",
                            f"--screenshot={path}", (site / page).resolve().as_uri()],
                           check=True, capture_output=True, timeout=120)
            # a palette of 256 colours: the pages are mostly flat colours and text
            Image.open(path).convert("RGB").quantize(256).save(path, optimize=True)
            written.append(path)
    return written


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "screenshots"
    for shot in take(HERE / "_build" / "html", target):
        print(shot, f"{shot.stat().st_size / 1024:.0f} KiB")
