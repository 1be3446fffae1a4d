"""Screenshot of a comparison report for the README (docs/report.png), with headless Chromium.

    python scripts/report_screenshot.py [--report reports/demo] [--out docs/report.png]
        [--demo] [--width 1280] [--height 2100] [--scale 0.75]

``--demo`` first runs ``omnislam demo`` (into reports/demo and runs/demo under the current
folder, reusing what an earlier demo left there). The page is opened from disk
(``file://.../index.html``, self-contained), the top ``--width`` x ``--height`` CSS pixels are
captured at device scale 1, scaled by ``--scale`` and written as a 256-colour PNG (the report is
flat colours and text; the README's image should stay small).

Needs Chromium (Debian: ``apt-get install -y chromium``) and Pillow (installed with matplotlib).
Bad input (no report, no browser): one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_browser() -> str | None:
    return next((path for name in BROWSERS if (path := shutil.which(name))), None)


def screenshot(page: Path, out: Path, width: int, height: int, scale: float) -> int:
    """Capture ``page`` into ``out``; returns the PNG's size [bytes]."""
    from PIL import Image

    browser = find_browser()
    if browser is None:
        raise SystemExit(
            f"{sys.argv[0]}: no Chromium found ({', '.join(BROWSERS)}); "
            "install it, e.g. apt-get install -y chromium"
        )
    with tempfile.TemporaryDirectory(prefix="omnislam-shot-") as tmp:
        raw = Path(tmp) / "raw.png"
        command = [
            browser,
            "--headless",
            "--disable-gpu",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
            f"--user-data-dir={tmp}/profile",
            f"--window-size={width},{height}",
            f"--screenshot={raw}",
            page.resolve().as_uri(),
        ]
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            command.insert(1, "--no-sandbox")  # Chromium refuses to sandbox as root
        done = subprocess.run(command, capture_output=True, text=True, timeout=300)
        if done.returncode != 0 or not raw.is_file():
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            raise SystemExit(f"{sys.argv[0]}: {browser} failed ({done.returncode}): {last}")
        with Image.open(raw) as image:
            image = image.convert("RGB")
            if scale != 1.0:
                size = (round(image.width * scale), round(image.height * scale))
                image = image.resize(size, Image.Resampling.LANCZOS)
            out.parent.mkdir(parents=True, exist_ok=True)
            image.quantize(colors=256, method=Image.Quantize.FASTOCTREE).save(
                out, format="PNG", optimize=True
            )
    return out.stat().st_size


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", default="reports/demo", help="report folder (index.html)")
    parser.add_argument("--out", default="docs/report.png", help="PNG to write")
    parser.add_argument("--demo", action="store_true", help="run `omnislam demo` first")
    parser.add_argument("--width", type=int, default=1280, help="window width [CSS px]")
    parser.add_argument("--height", type=int, default=2100, help="captured height [CSS px]")
    parser.add_argument("--scale", type=float, default=0.75, help="scale of the written PNG")
    args = parser.parse_args(argv)
    report = Path(args.report)
    if args.demo:
        demo = [sys.executable, "-m", "omnislam", "demo", "--out", str(report), "--overwrite"]
        if subprocess.run(demo).returncode != 0:
            print(f"{sys.argv[0]}: omnislam demo failed", file=sys.stderr)
            return 2
    page = report / "index.html"
    if not page.is_file():
        print(f"{page}: no report here (run `omnislam demo` or pass --demo)", file=sys.stderr)
        return 2
    try:
        size = screenshot(page, Path(args.out), args.width, args.height, args.scale)
    except SystemExit as exc:
        print(exc, file=sys.stderr)
        return 2
    print(f"{args.out}: {size / 1024:.0f} KB screenshot of {page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
