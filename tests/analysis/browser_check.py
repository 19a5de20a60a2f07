"""Loads a report in headless Chromium and prints what a reader would see, as JSON.

Usage: /usr/bin/python3 browser_check.py REPORT.html WORKDIR [--print | --layout ID...]
Prints {"console_errors": [...], "dom": "...", "plots_done": bool, "screenshot": path,
"nonblank_plot_fraction": float, "alerts": [...]}; with --print what printed_last_column
finds, with --layout what layout() measures; used by the analysis tests.
"""
import json
import os
import struct
import subprocess
import sys
import zlib

CHROMIUM = "/usr/bin/chromium"


def chromium(args, workdir, timeout=90):
    base = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--no-first-run", "--user-data-dir=" + os.path.join(workdir, "profile"),
            "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000"]
    return subprocess.run(base + args, capture_output=True, text=True, timeout=timeout)


def decode_png(path):
    """RGB rows of an 8-bit RGB/RGBA non-interlaced PNG (what Chromium writes)."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and ctype in (2, 6) and interlace == 0, (depth, ctype, interlace)
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return width, height, bpp, rows


def printed_last_column(report, workdir, last="verdict", before="fixed", dpi=100):
    """Prints the report to PDF (Chromium's print-to-PDF, the page's print styles), finds
    the parameter table's header row (the word `last` with `before` left of it on the same
    line, from pdftotext's word boxes) and looks at that spot of the page rendered to PNG
    by pdftoppm: dark pixels there mean the last column was printed, not cut off.
    Returns {"pdf", "pages", "found", "inside_page", "dark_pixels"}."""
    pdf = os.path.join(workdir, "report.pdf")
    chromium(["--print-to-pdf=" + pdf, "--no-pdf-header-footer", "file://" + os.path.abspath(report)], workdir,
             timeout=180)
    out = {"pdf": pdf, "pages": 0, "found": False, "inside_page": False, "dark_pixels": 0}
    if not os.path.exists(pdf):
        return out
    box = subprocess.run(["pdftotext", "-bbox", pdf, "-"], capture_output=True, text=True, timeout=120).stdout
    import re
    pages = re.split(r"<page ", box)[1:]
    out["pages"] = len(pages)
    for number, page in enumerate(pages, start=1):
        pw, ph = (float(v) for v in re.search(r'width="([0-9.]+)" height="([0-9.]+)"', page).groups())
        words = [(float(a), float(b), float(c), float(d), t) for a, b, c, d, t in re.findall(
            r'<word xMin="([0-9.]+)" yMin="([0-9.]+)" xMax="([0-9.]+)" yMax="([0-9.]+)">([^<]*)</word>', page)]
        for (x0, y0, x1, y1, t) in words:
            if t != last:
                continue
            # A header cell may wrap: "before" within a line or so above or below.
            if not any(w[4] == before and abs(w[1] - y0) < 15 and w[2] < x0 for w in words):
                continue
            out["found"] = True
            out["inside_page"] = x1 <= pw and y1 <= ph
            stem = os.path.join(workdir, "page")
            subprocess.run(["pdftoppm", "-png", "-r", str(dpi), "-f", str(number), "-l", str(number), "-singlefile",
                            pdf, stem], check=True, timeout=120)
            w, h, bpp, rows = decode_png(stem + ".png")
            k = dpi / 72.0
            dark = 0
            for y in range(int(y0 * k), min(h, int(y1 * k) + 1)):
                row = rows[y]
                for x in range(int(x0 * k), min(w, int(x1 * k) + 1)):
                    if max(row[x * bpp], row[x * bpp + 1], row[x * bpp + 2]) < 110:
                        dark += 1
            out["dark_pixels"] = dark
            return out
    return out


# A4 landscape less the report's 10 mm margins (report.css @page), in CSS px (96 per inch).
PRINTABLE_WIDTH_PX = round((297 - 2 * 10) / 25.4 * 96)
FIRST_SCREEN = (1280, 800)  # a laptop's browser window

MEASURE = """<script>
window.addEventListener("load", () => {
  const width = document.documentElement.clientWidth, out = {width, height: window.innerHeight, cut: [], at: {}};
  document.querySelectorAll("table").forEach((t, i) => {
    const r = t.getBoundingClientRect();
    if (r.width > 0 && (r.right > width + 0.5 || r.left < -0.5 || t.scrollWidth > t.clientWidth + 1))
      out.cut.push({index: i, id: t.id, first_row: (t.rows[0] ? t.rows[0].textContent : "").slice(0, 120),
                    right: r.right, scroll_width: t.scrollWidth});
  });
  for (const id of IDS) {
    const e = document.getElementById(id);
    if (e) { const r = e.getBoundingClientRect(); out.at[id] = {top: r.top, bottom: r.bottom, text: e.textContent}; }
  }
  const pre = document.createElement("pre");
  pre.id = "layout-check";
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


def measured(html, workdir, name, size, ids):
    """Loads `html` with MEASURE added in a window of `size` and returns what it measured."""
    path = os.path.join(workdir, name)
    with open(path, "w") as f:
        f.write(html.replace("</body>", MEASURE.replace("IDS", json.dumps(ids)) + "</body>", 1))
    dom = chromium(["--dump-dom", "--hide-scrollbars", f"--window-size={size[0]},{size[1]}", "file://" + path],
                   workdir).stdout
    import html as html_lib
    import re
    found = re.search(r'<pre id="layout-check">(.*?)</pre>', dom, re.S)
    return json.loads(html_lib.unescape(found.group(1))) if found else None


def layout(report, workdir, ids):
    """What the report's layout shows a reader: `cut`, the tables wider than the printed page
    (the report with its print rules applied, in a window as wide as an A4 landscape page's
    printable area: a table wider than that is cut off the PDF), and `first_screen`, for
    each of `ids` its text and whether it lies within the first screen of a 1280×800
    window (the report as shown on screen)."""
    html = open(report).read()
    assert "@media print {" in html, "the report has no print rules"
    printed = measured(html.replace("@media print {", "@media all {"), workdir, "as_printed.html",
                       (PRINTABLE_WIDTH_PX, 1600), [])
    screen = measured(html, workdir, "as_shown.html", FIRST_SCREEN, ids)
    return {"printable_width_px": PRINTABLE_WIDTH_PX, "print_width_measured": printed and printed["width"],
            "cut": printed["cut"] if printed else None,
            "first_screen": {i: {"text": a["text"], "inside": a["top"] >= 0 and a["bottom"] <= screen["height"]}
                             for i, a in (screen["at"] if screen else {}).items()}}


def main():
    report, workdir = os.path.abspath(sys.argv[1]), sys.argv[2]
    os.makedirs(workdir, exist_ok=True)
    if len(sys.argv) > 3 and sys.argv[3] == "--print":
        print(json.dumps(printed_last_column(report, workdir)))
        return
    if len(sys.argv) > 3 and sys.argv[3] == "--layout":
        print(json.dumps(layout(report, workdir, sys.argv[4:])))
        return
    url = "file://" + report
    dom = chromium(["--dump-dom", url], workdir)
    # Console messages: "[...:CONSOLE(line)] "text", source: ..." on stderr.
    console = [l for l in dom.stderr.splitlines() if ":CONSOLE" in l or "Uncaught" in l]
    # Chromium's log does not say a console message's level reliably; the report logs
    # nothing, so every console message (console.error, uncaught exception, CSP
    # violation, failed load) counts as an error.
    errors = list(console)
    alerts = [l for l in dom.stderr.splitlines() if "alert" in l.lower() and "CONSOLE" in l]
    shot = os.path.join(workdir, "screenshot.png")
    sc = chromium(["--screenshot=" + shot, "--window-size=1280,1600", "--hide-scrollbars", url], workdir)
    w, h, bpp, rows = decode_png(shot)
    # Share of plot-canvas pixels that are neither white nor near-white: uPlot draws
    # lines on a white canvas, so an empty plot area would give ~0.
    coloured = 0
    total = 0
    for row in rows[::4]:
        for x in range(0, w * bpp, bpp * 4):
            r, g, b = row[x], row[x + 1], row[x + 2]
            total += 1
            if max(r, g, b) - min(r, g, b) > 40:  # saturated: plot lines, not text
                coloured += 1
    print(json.dumps({
        "console": console,
        "console_errors": errors + [l for l in sc.stderr.splitlines() if ":CONSOLE" in l],
        "alerts": alerts,
        "dom": dom.stdout,
        "screenshot": shot,
        "width": w, "height": h,
        "coloured_fraction": coloured / max(1, total),
    }))


if __name__ == "__main__":
    main()
