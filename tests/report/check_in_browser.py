#!/usr/bin/env python3
"""A training report as a real browser draws it (docs/report.md; ctest report_in_browser).

Writes the test cylinder (organsim-test-model), replays a two-tool press of it
with `organsim replay --fast --report` (no display: the pictures need none), and has
Chromium (headless) draw every chart and picture of the page, each on a page of
its own with the report's own head (its Content-Security-Policy included), and
a screenshot of the whole page. Fails unless every chart shows its lines and
every picture shows the coloured organ: nothing missing, nothing blank.

    python3 tests/report/check_in_browser.py --build build
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

from PIL import Image

SESSION = ("# organsim session 1\n0,1,160,0,0\n0.3,1,145,2,0\n0.6,1,160,0,0\n"
           "0,2,80,40,0\n0.3,2,80,26,1\n0.6,2,80,40,0\n")


def screenshot(html_path, png_path, size):
    subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    f"--window-size={size}", f"--screenshot={png_path}", html_path],
                   check=True, capture_output=True, timeout=120)
    return Image.open(png_path).convert("RGB")


def coloured_pixels(image):
    """Pixels that are clearly neither white nor grey (a line's or the organ's colour)."""
    return sum(1 for r, g, b in image.getdata() if max(r, g, b) - min(r, g, b) > 60)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", required=True)
    args = parser.parse_args()
    organsim = os.path.join(args.build, "tools", "organsim")
    make_model = os.path.join(args.build, "tests", "organsim-test-model")
    failures = []
    with tempfile.TemporaryDirectory() as work:
        model, session, report = (os.path.join(work, name) for name in ("cylinder.organ", "press.session", "report"))
        subprocess.run([make_model, "cylinder", "-o", model], check=True, capture_output=True)
        with open(session, "w") as f:
            f.write(SESSION)
        environment = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
        subprocess.run([organsim, "replay", model, session, "--fast", "--report", report, "--quiet"], check=True,
                       capture_output=True, env=environment)
        with open(os.path.join(report, "index.html")) as f:
            page = f.read()
        head = page[:page.index("<body>")]
        charts = re.findall(r"<svg.*?</svg>", page, re.S)
        pictures = re.findall(r"<img [^>]*>", page)
        if len(charts) != 8:  # both tools' forces, force, depth, speed per tool, and the volume
            failures.append(f"{len(charts)} charts on the page, expected 8")
        if len(pictures) != 4:
            failures.append(f"{len(pictures)} pictures on the page, expected 4 (front, right, above, face-on)")
        if page.find("<h2>Summary</h2>") > page.find("<svg"):
            failures.append("the summary does not come before the charts")
        for k, element in enumerate(charts + pictures):
            kind = "chart" if k < len(charts) else "picture"
            html = os.path.join(work, f"element_{k}.html")
            with open(html, "w") as f:
                f.write(head + "<body style=\"margin:0\">" + element + "</body></html>\n")
            image = screenshot(html, os.path.join(work, f"element_{k}.png"), "1000,420")
            coloured = coloured_pixels(image)
            needed = 150 if kind == "chart" else 2000
            print(f"{kind} {k}: {coloured} coloured pixels")
            if coloured < needed:
                failures.append(f"{kind} {k} looks blank in Chromium ({coloured} coloured pixels, expected "
                                f">= {needed})")
        whole = screenshot(os.path.join(report, "index.html"), os.path.join(work, "page.png"), "1100,3000")
        if coloured_pixels(whole) < 5000:
            failures.append("the whole page looks blank in Chromium")
    for failure in failures:
        print("check_in_browser.py: " + failure, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
