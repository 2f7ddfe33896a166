"""The report's ``index.html``: its ``summary.md`` as one self-contained page.

The report writes a small, known subset of Markdown, and :func:`markdown_to_html` converts exactly
that subset (no dependency):

- ATX headings ``#`` … ``######``;
- paragraphs (consecutive non-blank lines), and ``- `` bullet lists;
- pipe tables: a header row, a ``|---|---|`` separator row, body rows.  Cells are separated by a
  ``|`` with white space on both sides (or at either end of the row), so a ``|`` that touches a
  character, as in ``max |E − E₀|``, stays in the cell's text;
- fenced code blocks (three backticks), kept verbatim;
- inline code (backticks), emphasis ``*…*`` and strong ``**…**``, links ``[text](url)`` and images
  ``![alt](src)``; an image alone in a paragraph becomes a figure captioned with its ``alt``.

Everything else is text (HTML in the Markdown is escaped, never passed through).  With ``base``, the
folder the Markdown's relative paths are read from, every local PNG, GIF, JPEG or SVG is inlined as
a ``data:`` URI and every MP4 becomes a ``<video controls autoplay loop muted>`` with a ``data:``
URI, so the page needs nothing beside it; a file that cannot be read keeps its plain relative
``src`` (and :mod:`scripts/check_report_html.py <check_report_html>` reports it as not loaded).
"""
from __future__ import annotations

import base64
import html
import os
import re
from typing import Callable, List, Optional

from ..inspect import files

#: Media type of each file extension that is inlined.
MEDIA_TYPES = {".png": "image/png", ".gif": "image/gif", ".jpg": "image/jpeg", ".jpeg": "image/jpeg",
               ".svg": "image/svg+xml", ".mp4": "video/mp4"}

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; line-height: 1.45;
       max-width: 72rem; margin: 0 auto; padding: 1rem 1.5rem 4rem; color: #1b1b1b; }
h1, h2, h3 { line-height: 1.2; } h2 { border-bottom: 1px solid #ddd; padding-bottom: .2em; margin-top: 2em; }
.table-wrap { overflow-x: auto; margin: 1em 0; }
table { border-collapse: collapse; font-size: .9em; }
th, td { border: 1px solid #ccc; padding: .25em .55em; vertical-align: top; text-align: left; }
th { background: #f3f3f3; } td.nowrap { white-space: nowrap; } tr:nth-child(even) td { background: #fafafa; }
pre { background: #f6f8fa; padding: .7em 1em; overflow-x: auto; font-size: .85em; line-height: 1.3; }
code { font-family: ui-monospace, "SFMono-Regular", Menlo, Consolas, monospace; font-size: .92em; }
p code { background: #f3f3f3; padding: 0 .2em; border-radius: 3px; }
figure { margin: 1em 0; } figcaption { color: #555; font-size: .9em; margin-top: .2em; }
img, video { max-width: 100%; height: auto; }
""".strip()

_FENCE = re.compile(r"^\s*```")
_HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
_SEPARATOR = re.compile(r"^\s*\|?\s*:?-{3,}:?\s*(\|\s*:?-{3,}:?\s*)*\|?\s*$")
_BULLET = re.compile(r"^\s*[-*+]\s+(.*)$")
_CELL_SPLIT = re.compile(r"(?<=\s)\|(?=\s)")
_IMAGE = re.compile(r"!\[([^\]]*)\]\(([^)\s]+)\)")
_LINK = re.compile(r"\[([^\]]+)\]\(([^)\s]+)\)")
_CODE = re.compile(r"`([^`]+)`")
_STRONG = re.compile(r"(?<![\w*])\*\*(?=\S)(.+?)(?<=\S)\*\*(?![\w*])")
_EM = re.compile(r"(?<![\w*])\*(?=[^\s*])(.+?)(?<=[^\s*])\*(?![\w*])")


def data_uri(path: str) -> Optional[str]:
    """``data:<type>;base64,…`` of the file at ``path``, or ``None`` when it cannot be read or its
    extension is not in :data:`MEDIA_TYPES`."""
    kind = MEDIA_TYPES.get(os.path.splitext(path)[1].lower())
    if kind is None:
        return None
    try:
        with open(path, "rb") as fh:
            payload = fh.read()
    except OSError:
        return None
    return f"data:{kind};base64,{base64.b64encode(payload).decode('ascii')}"


def _resolver(base: Optional[str]) -> Callable[[str], str]:
    """``src -> src`` for the page: a local file under ``base`` inlined as a data: URI, else unchanged."""
    def resolve(src: str) -> str:
        if base is None or re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", src) or src.startswith("/"):
            return src
        return data_uri(os.path.join(base, src)) or src
    return resolve


def _media(alt: str, src: str, resolve: Callable[[str], str]) -> str:
    """An ``<img>``, or a ``<video>`` for an MP4 (alt and src raw, not yet escaped)."""
    url = html.escape(resolve(src), quote=True)
    if src.lower().endswith(".mp4"):
        return (f'<video controls autoplay loop muted playsinline src="{url}" title="{html.escape(alt, quote=True)}">'
                f"{html.escape(alt)}</video>")
    return f'<img src="{url}" alt="{html.escape(alt, quote=True)}" loading="eager">'


def inline(text: str, resolve: Callable[[str], str] = lambda s: s) -> str:
    """One line of Markdown text as HTML: code spans (verbatim), images, links, strong and emphasis;
    everything else escaped."""
    slots: List[str] = []

    def keep(fragment: str) -> str:
        slots.append(fragment)
        return f"\x00{len(slots) - 1}\x00"

    text = _CODE.sub(lambda m: keep(f"<code>{html.escape(m.group(1))}</code>"), text)
    text = _IMAGE.sub(lambda m: keep(_media(m.group(1), m.group(2), resolve)), text)
    text = _LINK.sub(lambda m: keep(f'<a href="{html.escape(m.group(2), quote=True)}">') + m.group(1) + keep("</a>"),
                     text)
    text = html.escape(text, quote=False)
    text = _STRONG.sub(r"<strong>\1</strong>", text)
    text = _EM.sub(r"<em>\1</em>", text)
    return re.sub(r"\x00(\d+)\x00", lambda m: slots[int(m.group(1))], text)


def split_row(line: str) -> List[str]:
    """The cells of a table row (see the module docstring for where a ``|`` separates cells)."""
    s = line.strip()
    if s.startswith("|"):
        s = s[1:]
    if s.endswith("|") and (len(s) == 1 or s[-2].isspace()):
        s = s[:-1]
    return [c.strip() for c in _CELL_SPLIT.split(" " + s + " ")]


def _table(rows: List[str], resolve) -> str:
    head, body = split_row(rows[0]), [split_row(r) for r in rows[2:]]
    out = ['<div class="table-wrap"><table>', "<thead><tr>"
           + "".join(f"<th>{inline(c, resolve)}</th>" for c in head) + "</tr></thead>", "<tbody>"]
    for cells in body:
        # a cell without spaces (a number such as 3.93e-06, a name) is never broken at its hyphens
        out.append("<tr>" + "".join(("<td>" if " " in c else '<td class="nowrap">') + inline(c, resolve) + "</td>"
                                    for c in cells) + "</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)


def markdown_to_html(markdown: str, base: Optional[str] = None) -> str:
    """The body HTML of ``markdown`` (the subset in the module docstring); local media inlined from
    the folder ``base`` when given."""
    resolve = _resolver(base)
    lines = markdown.splitlines()
    out: List[str] = []
    para: List[str] = []

    def flush() -> None:
        if not para:
            return
        text = " ".join(s.strip() for s in para)
        para.clear()
        alone = _IMAGE.fullmatch(text)
        if alone:
            out.append(f"<figure>{_media(alone.group(1), alone.group(2), resolve)}"
                       f"<figcaption>{inline(alone.group(1))}</figcaption></figure>")
        else:
            out.append(f"<p>{inline(text, resolve)}</p>")

    i = 0
    while i < len(lines):
        line = lines[i]
        if _FENCE.match(line):
            flush()
            j = i + 1
            while j < len(lines) and not _FENCE.match(lines[j]):
                j += 1
            out.append("<pre><code>" + html.escape("\n".join(lines[i + 1:j])) + "</code></pre>")
            i = j + 1
            continue
        m = _HEADING.match(line)
        if m:
            flush()
            level = len(m.group(1))
            out.append(f"<h{level}>{inline(m.group(2), resolve)}</h{level}>")
            i += 1
            continue
        if line.lstrip().startswith("|") and i + 1 < len(lines) and _SEPARATOR.match(lines[i + 1]):
            flush()
            j = i + 2
            while j < len(lines) and lines[j].lstrip().startswith("|"):
                j += 1
            out.append(_table(lines[i:j], resolve))
            i = j
            continue
        if _BULLET.match(line):
            flush()
            items = []
            while i < len(lines) and _BULLET.match(lines[i]):
                items.append(_BULLET.match(lines[i]).group(1))
                i += 1
            out.append("<ul>" + "".join(f"<li>{inline(t, resolve)}</li>" for t in items) + "</ul>")
            continue
        if not line.strip():
            flush()
        else:
            para.append(line)
        i += 1
    flush()
    return "\n".join(out)


def page(markdown: str, base: Optional[str] = None, title: Optional[str] = None) -> str:
    """A whole HTML document of ``markdown`` (title: its first heading unless given), styled inline."""
    if title is None:
        m = next((_HEADING.match(ln) for ln in markdown.splitlines() if _HEADING.match(ln)), None)
        title = m.group(2) if m else "report"
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{html.escape(title)}</title>\n<style>\n{STYLE}\n</style>\n</head>\n<body>\n"
            f"{markdown_to_html(markdown, base)}\n</body>\n</html>\n")


def write_index(folder: str, markdown: str, name: str = "index.html") -> str:
    """Write ``folder/name`` (atomically): ``markdown`` as a self-contained page, its media read from
    ``folder``.  Returns the path."""
    path = os.path.join(folder, name)
    text = page(markdown, base=folder)

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
    files.write_atomically(path, write)
    return path
