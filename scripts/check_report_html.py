#!/usr/bin/env python
"""Check that a report's ``index.html`` shows every figure and plays every animation in a real browser.

    python scripts/check_report_html.py DIR [--chromium PATH] [--budget-ms 10000]

Renders ``DIR/index.html`` in headless Chromium (the Debian package, ``apt-get install chromium``)
and checks that every ``<img>`` loaded (``complete`` and ``naturalWidth > 0``) and every
``<video>`` has a frame (``readyState >= 2`` and ``videoWidth > 0``).  The page is copied to a fresh
temporary folder with a small script added that writes the result into the DOM, which Chromium's
``--dump-dom`` prints; so a figure that is not inlined in the page (a relative ``src``) fails too,
as it would for a reader who received the page alone.

Prints one line per failure and a summary.  Exit codes: 0 every image and video loaded; 1 some did
not (or the page gave no result); 2 bad input: no ``DIR/index.html``, or no Chromium (one line).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

#: Executables tried, in order, when ``--chromium`` is not given.
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "/usr/bin/chromium")

MARKER = "castrajectory-check-result"

#: Added before ``</body>``: after the load event, wait for every video to have a frame (or fail),
#: then write ``{"images": [...], "videos": [...]}`` into ``<pre id=MARKER>``.
PROBE = """
<script>
(function () {
  function src(el) { var s = el.currentSrc || el.getAttribute('src') || ''; return s.slice(0, 60); }
  function finish() {
    var images = Array.prototype.map.call(document.images, function (im, i) {
      return {index: i, alt: im.alt || '', src: src(im), ok: im.complete && im.naturalWidth > 0,
              width: im.naturalWidth, height: im.naturalHeight};
    });
    var videos = Array.prototype.map.call(document.querySelectorAll('video'), function (v, i) {
      return {index: i, alt: v.title || '', src: src(v), ok: v.readyState >= 2 && v.videoWidth > 0,
              width: v.videoWidth, height: v.videoHeight, readyState: v.readyState,
              error: v.error ? v.error.code : null};
    });
    var pre = document.createElement('pre');
    pre.id = 'MARKER';
    pre.textContent = JSON.stringify({images: images, videos: videos});
    document.body.appendChild(pre);
  }
  window.addEventListener('load', function () {
    var pending = Array.prototype.filter.call(document.querySelectorAll('video'), function (v) {
      return v.readyState < 2 && !v.error;
    });
    if (!pending.length) { finish(); return; }
    var left = pending.length, done = false;
    function one() { if (--left === 0 && !done) { done = true; finish(); } }
    pending.forEach(function (v) {
      v.addEventListener('loadeddata', one, {once: true});
      v.addEventListener('error', one, {once: true});
    });
    setTimeout(function () { if (!done) { done = true; finish(); } }, 8000);
  });
})();
</script>
""".replace("MARKER", MARKER)


def find_chromium(given: str | None = None) -> str | None:
    """The Chromium executable: ``given`` if it runs from PATH or as a path, else the first candidate found."""
    for name in ([given] if given else CANDIDATES):
        path = shutil.which(name) or (name if os.path.isfile(name) and os.access(name, os.X_OK) else None)
        if path:
            return path
    return None


def render(chromium: str, page: str, budget_ms: int = 10000, timeout_s: float = 180.0) -> str:
    """The DOM of ``page`` (a file path) after Chromium ran it for ``budget_ms`` of virtual time."""
    with tempfile.TemporaryDirectory(prefix="check-report-profile-") as profile:
        cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--disable-dev-shm-usage", "--autoplay-policy=no-user-gesture-required", "--mute-audio",
               f"--user-data-dir={profile}", f"--virtual-time-budget={int(budget_ms)}", "--dump-dom",
               "file://" + os.path.abspath(page)]
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout_s)
    return p.stdout


def check(folder: str, chromium: str, budget_ms: int = 10000):
    """``(failures, summary, result)``: one line per image or video that did not load, a summary line,
    and the page's own result (``None`` when the page gave none)."""
    with open(os.path.join(folder, "index.html"), encoding="utf-8") as fh:
        text = fh.read()
    at = text.lower().rfind("</body>")
    probed = (text[:at] + PROBE + text[at:]) if at >= 0 else text + PROBE
    with tempfile.TemporaryDirectory(prefix="check-report-page-") as tmp:
        page = os.path.join(tmp, "index.html")  # alone: whatever is not inlined does not load
        with open(page, "w", encoding="utf-8") as fh:
            fh.write(probed)
        dom = render(chromium, page, budget_ms)
    m = re.search(rf'<pre id="{MARKER}">(.*?)</pre>', dom, re.S)
    if not m:
        return (["the page gave no result (Chromium did not finish loading it within the budget, or crashed)"],
                "0 checked", None)
    import html as _html
    result = json.loads(_html.unescape(m.group(1)))
    failures = []
    for kind in ("images", "videos"):
        for el in result[kind]:
            if el["ok"]:
                continue
            why = "not a data: URI (the page is not self-contained)" if not el["src"].startswith("data:") \
                else f"size {el['width']} x {el['height']}" + (f", readyState {el.get('readyState')}, "
                                                                f"error {el.get('error')}" if kind == "videos" else "")
            failures.append(f"FAILED {kind[:-1]} {el['index'] + 1} ({el['alt'] or 'no alt'}; src {el['src'][:40]}…): "
                            f"did not load: {why}")
    ni, nv = len(result["images"]), len(result["videos"])
    oi = sum(e["ok"] for e in result["images"])
    ov = sum(e["ok"] for e in result["videos"])
    summary = f"{oi} of {ni} images and {ov} of {nv} videos loaded in {os.path.basename(chromium)}"
    return failures, summary, result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="check_report_html.py", description=__doc__.splitlines()[0])
    p.add_argument("folder", metavar="DIR", help="the report's folder (holds index.html)")
    p.add_argument("--chromium", metavar="PATH", help="the Chromium executable (default: chromium on PATH)")
    p.add_argument("--budget-ms", type=int, default=10000, help="virtual time Chromium gives the page (ms)")
    args = p.parse_args(argv)
    if not os.path.isfile(os.path.join(args.folder, "index.html")):
        print(f"check_report_html: no index.html in {args.folder}", file=sys.stderr)
        return 2
    chromium = find_chromium(args.chromium)
    if chromium is None:
        print("check_report_html: Chromium not found (install the Debian package: apt-get install -y chromium)",
              file=sys.stderr)
        return 2
    try:
        failures, summary, _ = check(args.folder, chromium, args.budget_ms)
    except subprocess.TimeoutExpired:
        failures, summary = ["Chromium did not finish within its time limit"], "0 checked"
    for line in failures:
        print(line)
    print(("ok: " if not failures else "FAILED: ") + summary)
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
