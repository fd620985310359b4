#!/usr/bin/env python3
"""A training report as a real browser draws it (docs/report.md; ctest report_in_browser).

Writes the test cylinder (organsim-test-model), replays a two-tool press of it
with `organsim replay --fast --report` (DISPLAY unset: the pictures need no
display), and has Chromium (headless) draw every chart and picture of the page,
each on a page of its own with the report's own head (its
Content-Security-Policy included), and the whole page served over HTTP. Fails
unless:
- every chart shows its lines and every picture the coloured organ;
- a push of a few tens of millinewtons is drawn at least 20 % of its plot's
  height up (measured on the screenshot's pixels);
- the face-on picture shows the indentation's colour (red) where the point
  pressed deepest lands (metrics.json's `deepest_point_pixel`);
- the page asks the server for nothing but itself and Chromium reports no
  blocked load;
- every picture and chart has a text alternative, and every text colour has a
  contrast of at least 4.5:1 against every background of the page;
- the page prints (Chromium's print to PDF).

    python3 tests/report/check_in_browser.py --build build
"""
import argparse
import functools
import http.server
import json
import os
import re
import subprocess
import sys
import tempfile
import threading

from PIL import Image

# Tool 1 presses hard (about 0.47 N); tool 2 gives the small push of about 20 mN
# that a plot scaled to the limit would flatten.
SESSION = ("# organsim session 1\n0,1,160,0,0\n0.3,1,145,2,0\n0.6,1,160,0,0\n"
           "0,2,80,40,0\n0.3,2,80,28.7,1\n0.6,2,80,40,0\n")


def screenshot(html_path, png_path, size):
    subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    f"--window-size={size}", f"--screenshot={png_path}", html_path],
                   check=True, capture_output=True, timeout=120)
    return Image.open(png_path).convert("RGB")


def contrast(a, b):
    """WCAG 2 contrast ratio of two #rrggbb (or #rgb) colours."""
    def luminance(colour):
        colour = colour.lstrip("#")
        if len(colour) == 3:
            colour = "".join(c * 2 for c in colour)
        channels = [int(colour[k:k + 2], 16) / 255 for k in (0, 2, 4)]
        linear = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in channels]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]
    high, low = sorted((luminance(a), luminance(b)), reverse=True)
    return (high + 0.05) / (low + 0.05)


def text_contrast_failures(page):
    """Text colours (CSS color, SVG text fill) under 4.5:1 against any background the page uses."""
    style = page[page.index("<style>"):page.index("</style>")]
    backgrounds = set(re.findall(r"background:(#[0-9a-fA-F]{3,6})", style)) | {"#fff"}
    texts = set(re.findall(r"[{;]color:(#[0-9a-fA-F]{3,6})", style))
    texts |= set(re.findall(r"<text [^>]*fill=\"(#[0-9a-fA-F]{3,6})\"", page))
    return [f"text colour {t} on {b}: contrast {contrast(t, b):.2f} < 4.5" for t in sorted(texts)
            for b in sorted(backgrounds) if contrast(t, b) < 4.5]


def plot_height_fraction(image, colour, left=71, right=729):
    """How high up its plot the highest pixel of `colour` is drawn (0: the plot's bottom, 1: its top).

    The plot is the chart's grey frame, found on the screenshot as the longest
    vertical run of grey pixels near its left edge."""
    width, height = image.size
    pixels = image.load()
    grey = lambda p: max(p) - min(p) < 8 and max(p) < 215
    best = (0, 0, 0)  # length, first row, last row
    for x in range(left - 6, left + 3):
        run_start = None
        for y in range(height + 1):
            if y < height and grey(pixels[x, y]):
                run_start = y if run_start is None else run_start
            elif run_start is not None:
                best = max(best, (y - run_start, run_start, y - 1))
                run_start = None
    _, top, bottom = best
    target = tuple(int(colour[k:k + 2], 16) for k in (1, 3, 5))
    near = lambda p: sum(abs(p[c] - target[c]) for c in range(3)) < 60
    highest = min((y for y in range(top, bottom + 1) for x in range(left, right) if near(pixels[x, y])),
                  default=None)
    return None if highest is None else (bottom - highest) / (bottom - top)


class Requests(http.server.SimpleHTTPRequestHandler):
    """Serves the report's folder and notes every path asked for."""
    asked = []

    def do_GET(self):
        Requests.asked.append(self.path)
        super().do_GET()

    def log_message(self, *args):
        pass


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
        with open(os.path.join(report, "metrics.json")) as f:
            metrics = json.load(f)
        for k, chart in enumerate(charts):
            if "<title>" not in chart or 'aria-label="Chart of ' not in chart:
                failures.append(f"chart {k} has no text alternative (a <title> and an aria-label)")
        for k, picture in enumerate(pictures):
            if not re.search(r'alt="[^"]{20,}"', picture):
                failures.append(f"picture {k} has no text alternative")
        failures += text_contrast_failures(page)
        if "@media print" not in page:
            failures.append("the page has no print stylesheet")
        face_on = [k for k, view in enumerate(metrics["pictures"]) if "face-on" in view["title"]]
        if len(face_on) != 1 or "deepest_point_pixel" not in metrics["pictures"][face_on[0]]:
            failures.append("metrics.json names no face-on picture with the deepest point's pixel")
        small_pushes = []
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
            small = re.search(r'aria-label="Chart of force \(N\)[^"]*; force sent: \d+ points from \S+ to ([0-9.e+-]+)',
                              element)
            if kind == "chart" and small and 0.005 <= float(small.group(1)) <= 0.05:
                # A tool's own force chart with a small push: its force, sent (#1f77b4) or
                # the model's (#ff7f0e, drawn over it), stands well up the plot.
                peak = float(small.group(1))
                fraction = max(plot_height_fraction(image, "#1f77b4") or 0.0,
                               plot_height_fraction(image, "#ff7f0e") or 0.0)
                small_pushes.append(peak)
                print(f"chart {k}: a {peak * 1e3:.1f} mN push drawn {fraction:.2f} of the plot's height up")
                if fraction < 0.2:
                    failures.append(f"chart {k}: a {peak * 1e3:.1f} mN push is drawn {fraction:.2f} of the plot's "
                                    f"height up, under 20 %")
            if kind == "picture" and k - len(charts) in face_on:
                x, y = (int(v) for v in metrics["pictures"][k - len(charts)]["deepest_point_pixel"])
                r, g, b = image.getpixel((x, y))
                print(f"picture {k}: at the deepest point's pixel ({x}, {y}) the colour is ({r}, {g}, {b})")
                if not (r > g + 60 and r > b + 60):
                    failures.append(f"the face-on picture is not the indentation's red where the point pressed "
                                    f"deepest lands ({x}, {y}): ({r}, {g}, {b})")
        if not small_pushes:
            failures.append("no tool's force chart shows a push of 5-50 mN to measure")
        Requests.asked = []
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                                 functools.partial(Requests, directory=report))
        threading.Thread(target=server.serve_forever, daemon=True).start()
        url = f"http://127.0.0.1:{server.server_address[1]}/index.html"
        drawn = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                                "--enable-logging=stderr", "--v=0", "--window-size=1100,3000",
                                f"--screenshot={os.path.join(work, 'page.png')}", url],
                               capture_output=True, text=True, timeout=120)
        server.shutdown()
        whole = Image.open(os.path.join(work, "page.png")).convert("RGB")
        if coloured_pixels(whole) < 5000:
            failures.append("the whole page looks blank in Chromium")
        # The browser's own favicon request is not the page's.
        asked = [path for path in Requests.asked if path != "/favicon.ico"]
        print(f"the server was asked for: {Requests.asked}")
        if asked != ["/index.html"]:
            failures.append(f"the page asked the server for more than itself: {asked}")
        blocked = [line for line in drawn.stderr.splitlines() if "Refused to" in line]
        if blocked:
            failures.append(f"Chromium blocked {len(blocked)} load(s) of the page: {blocked[0]}")
        pdf = os.path.join(work, "page.pdf")
        subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", f"--print-to-pdf={pdf}",
                        os.path.join(report, "index.html")], check=True, capture_output=True, timeout=120)
        with open(pdf, "rb") as f:
            printed = f.read()
        pages = len(re.findall(rb"/Type\s*/Page[^s]", printed))
        print(f"printed: {pages} pages")
        if pages < 1:
            failures.append("the page does not print")
    for failure in failures:
        print("check_in_browser.py: " + failure, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
