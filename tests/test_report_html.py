"""The report's index.html: the Markdown converter on the report's subset, the page a quick report
writes, and the headless-Chromium check of scripts/check_report_html.py."""
import base64
import html as stdhtml
import os
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from castrajectory.cli import html

ROOT = Path(__file__).resolve().parents[1]
CHECK = ROOT / "scripts" / "check_report_html.py"
CHROMIUM = None
sys.path.insert(0, str(ROOT / "scripts"))
try:
    import check_report_html
    CHROMIUM = check_report_html.find_chromium()
finally:
    sys.path.pop(0)
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="Chromium not installed (apt-get install -y chromium): "
                                                              "the HTML check in a real browser is skipped")


class _Tree(HTMLParser):
    """Start tags with attributes, and the text inside each tag name, of an HTML string."""

    def __init__(self, text):
        super().__init__()
        self.tags, self.text, self._open = [], {}, []
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag not in ("img", "meta", "br"):
            self._open.append(tag)

    def handle_endtag(self, tag):
        if tag in self._open:
            while self._open and self._open.pop() != tag:
                pass

    def handle_data(self, data):
        for tag in self._open:
            self.text.setdefault(tag, []).append(data)

    def find(self, name):
        return [a for t, a in self.tags if t == name]


def _png(path, w=3, h=2):
    from PIL import Image
    Image.fromarray(np.full((h, w, 3), 200, np.uint8)).save(path)
    return Path(path).read_bytes()


MD = """# castrajectory report

Intro with `inline <code> & *stars*`, *emphasis*, **strong** and a [link](https://example.org/a?b=1&c=2).
A second line of the same paragraph; 2 * 3 stays and max |E − E₀| keeps its bars.

## A table

| scene | max |L − L₀|/|L₀| | time (s) |
|---|---|---|
| bowl <b> | 1e-14 | 0.12 |
| ball | - | 3 |

```
status: ok  <raw>  *not emphasis*  `not code`
  indented line
```

- first item with `code`
- second item

![a plot](plot.png)

![an animation](anim.gif)

![a movie](movie.mp4)

![gone](missing.png)
"""


def test_markdown_subset_to_html(tmp_path):
    """Headings, paragraphs, a table (bars inside a cell kept), a verbatim code block, a list, inline code,
    emphasis, strong, links; HTML in the Markdown escaped, never passed through."""
    png = _png(tmp_path / "plot.png")
    (tmp_path / "anim.gif").write_bytes(b"GIF89a-fake")
    (tmp_path / "movie.mp4").write_bytes(b"\x00\x00\x00\x18ftypisom-fake")
    body = html.markdown_to_html(MD, base=str(tmp_path))
    tree = _Tree(body)
    assert [t for t, _ in tree.tags if t in ("h1", "h2")] == ["h1", "h2"]
    assert "".join(tree.text["h1"]) == "castrajectory report"
    # the paragraph: two lines joined, inline code verbatim (escaped), emphasis and strong, the link
    p = body.split("<p>")[1].split("</p>")[0]
    assert "<code>inline &lt;code&gt; &amp; *stars*</code>" in p
    assert "<em>emphasis</em>" in p and "<strong>strong</strong>" in p
    assert '<a href="https://example.org/a?b=1&amp;c=2">link</a>' in p
    assert "2 * 3 stays" in p and "max |E − E₀| keeps" in p and "A second line" in p
    # the table: 3 columns in every row, the bars of |L − L₀| inside its header cell, HTML escaped
    assert len(tree.find("table")) == 1 and 'class="table-wrap"' in body
    head = body.split("<thead>")[1].split("</thead>")[0]
    assert head.count("<th>") == 3 and "<th>max |L − L₀|/|L₀|</th>" in head
    rows = body.split("<tbody>")[1].split("</tbody>")[0].split("<tr>")[1:]
    assert [r.count("<td") for r in rows] == [3, 3]
    assert '<td class="nowrap">1e-14</td>' in rows[0]  # a number is never broken at its hyphen
    assert "<td>bowl &lt;b&gt;</td>" in rows[0] and "<b>" not in body
    # the code block: verbatim, escaped, no inline markup inside, indentation kept
    (pre,) = [b for b in body.split("<pre><code>")[1:]]
    pre = pre.split("</code></pre>")[0]
    assert pre == "status: ok  &lt;raw&gt;  *not emphasis*  `not code`\n  indented line"
    assert [len(tree.find(t)) for t in ("ul", "li")] == [1, 2] and "<li>first item with <code>code</code></li>" in body
    # the media: PNG and GIF inlined as data: URIs with their bytes, MP4 as an autoplaying looping video
    imgs = {a["alt"]: a["src"] for a in tree.find("img")}
    assert imgs["a plot"] == "data:image/png;base64," + base64.b64encode(png).decode()
    assert base64.b64decode(imgs["an animation"].split(",", 1)[1]) == b"GIF89a-fake"
    assert imgs["gone"] == "missing.png"  # not found: left as is (the browser check reports it)
    (video,) = tree.find("video")
    assert video["src"].startswith("data:video/mp4;base64,")
    assert base64.b64decode(video["src"].split(",", 1)[1]) == b"\x00\x00\x00\x18ftypisom-fake"
    assert {"controls", "autoplay", "loop", "muted"} <= set(video)
    # an image alone in its paragraph is a figure captioned with its alt text
    assert len(tree.find("figure")) == 4 and "".join(tree.text["figcaption"]).startswith("a plot")


def test_inline_edge_cases():
    assert html.inline("a*b*c and 5 * 6 * 7") == "a*b*c and 5 * 6 * 7"  # no emphasis inside words or around spaces
    assert html.inline("**bold** then *it*") == "<strong>bold</strong> then <em>it</em>"
    assert html.inline("`a | b` & <x>") == "<code>a | b</code> &amp; &lt;x&gt;"
    assert html.split_row("| a | |x| | b |") == ["a", "|x|", "b"]
    assert html.split_row("| a | | c |") == ["a", "", "c"]


def test_page_is_a_whole_document_written_atomically(tmp_path):
    """index.html: a titled UTF-8 document with its stylesheet (wide tables scroll), and no temporary file left."""
    _png(tmp_path / "plot.png")
    path = html.write_index(str(tmp_path), "# My report\n\n![a plot](plot.png)\n\n| a | b |\n|---|---|\n| θ | 1 |\n")
    text = Path(path).read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and "<title>My report</title>" in text and 'charset="utf-8"' in text
    assert ".table-wrap { overflow-x: auto;" in text and "<td class=\"nowrap\">θ</td>" in text
    assert sorted(os.listdir(tmp_path)) == ["index.html", "plot.png"]


# ----------------------------------------------------------------------------- a quick report, in a browser
# (the quick report is tests/conftest.py's session fixture, shared with tests/test_scripts.py)


def test_quick_report_index_html_holds_summary_md(quick_report):
    """index.html has every heading and table of summary.md, and every figure of it inlined (no relative
    src left, each data: URI the bytes of its file); the animations are at least 640 px wide."""
    from PIL import Image

    md = (quick_report / "summary.md").read_text(encoding="utf-8")
    page = (quick_report / "index.html").read_text(encoding="utf-8")
    tree = _Tree(page)
    headings = [ln.lstrip("#").strip() for ln in md.splitlines() if ln.startswith("#")]
    got = [stdhtml.unescape(h) for h in _heading_texts(page)]
    assert got == headings
    assert len(tree.find("table")) == sum(1 for ln in md.splitlines() if ln.startswith("|---"))
    refs = [ln.split("](")[1].rstrip(")") for ln in md.splitlines() if ln.startswith("![")]
    imgs = tree.find("img") + tree.find("video")
    assert len(imgs) == len(refs) and len(refs) > 20
    for ref, el in zip(refs, imgs):
        assert el["src"].startswith("data:"), ref
        assert base64.b64decode(el["src"].split(",", 1)[1]) == (quick_report / ref).read_bytes()
    gifs = [r for r in refs if r.endswith(".gif")]
    assert gifs
    for g in gifs:
        with Image.open(quick_report / g) as im:
            assert im.size[0] >= 640, g


def _heading_texts(page):
    import re
    return [re.sub(r"<[^>]+>", "", m) for m in re.findall(r"<h[1-6]>(.*?)</h[1-6]>", page)]


@needs_chromium
def test_quick_report_loads_in_chromium(quick_report):
    """scripts/check_report_html.py on the quick report: every figure and animation loads in Chromium."""
    p = subprocess.run([sys.executable, str(CHECK), str(quick_report)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.startswith("ok: ") and " videos loaded in " in p.stdout


@needs_chromium
def test_check_reports_what_did_not_load(tmp_path):
    """A corrupt PNG and a figure that is not inlined fail, one line each, exit 1; a GIF and (with ffmpeg)
    an MP4 play."""
    from castrajectory.inspect import plotting

    _png(tmp_path / "good.png", 40, 30)
    (tmp_path / "bad.png").write_bytes(b"not a png")
    t = np.linspace(0.0, 1.0, 40)
    P = np.stack([np.cos(t), np.sin(t)], axis=1)[:, None, :]
    plotting.animate_points(P, t, str(tmp_path / "a.gif"), max_frames=10)
    md = "# page\n\n![good](good.png)\n\n![bad](bad.png)\n\n![absent](absent.png)\n\n![anim](a.gif)\n"
    if plotting.mp4_available():
        plotting.animate_points(P, t, str(tmp_path / "m.mp4"), max_frames=10)
        md += "\n![movie](m.mp4)\n"
    html.write_index(str(tmp_path), md)
    p = subprocess.run([sys.executable, str(CHECK), str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 1, p.stdout + p.stderr
    lines = p.stdout.strip().splitlines()
    assert len(lines) == 3
    assert lines[0].startswith("FAILED image 2 (bad;") and "size 0 x 0" in lines[0]
    assert lines[1].startswith("FAILED image 3 (absent;") and "not a data: URI" in lines[1]
    videos = 1 if plotting.mp4_available() else 0
    assert lines[2].startswith(f"FAILED: 2 of 4 images and {videos} of {videos} videos loaded")


def test_check_exit_2_without_chromium_or_page(tmp_path):
    p = subprocess.run([sys.executable, str(CHECK), str(tmp_path)], capture_output=True, text=True)
    assert p.returncode == 2 and "no index.html" in p.stderr and p.stderr.count("\n") == 1
    (tmp_path / "index.html").write_text("<html><body></body></html>")
    p = subprocess.run([sys.executable, str(CHECK), str(tmp_path), "--chromium", str(tmp_path / "no-such-chromium")],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "Chromium not found" in p.stderr and p.stderr.count("\n") == 1


def test_outputs_get_the_mode_an_ordinary_write_gives(tmp_path):
    """Written through a private temporary file, an output still gets the umask's mode (not 0600)."""
    import stat

    from castrajectory.inspect import files
    old = os.umask(0o022)
    try:
        files.write_text(str(tmp_path / "a.md"), "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "a.md").st_mode) == 0o644
