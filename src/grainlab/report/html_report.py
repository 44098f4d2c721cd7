"""A Markdown report as one self-contained HTML file: the Markdown rendered by markdown-it
(CommonMark with tables), each figure it links to embedded as a base64 data URI, so the file
can be mailed or opened anywhere with its figures inline."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

STYLE = """body { font-family: sans-serif; max-width: 72em; margin: 2em auto; padding: 0 1em;
line-height: 1.45; color: #222 }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em }
th, td { border: 1px solid #bbb; padding: 0.25em 0.5em; text-align: left; vertical-align: top }
th { background: #eee }
img { max-width: 100%; border: 1px solid #ddd }
code { background: #f4f4f4; padding: 0 0.2em }"""

IMAGE = re.compile(r'<img src="([^":]+?\.png)"')
"""A figure linked by a relative path (not a URL) in the rendered HTML."""


def markdown_html(text: str, folder: str | Path, title: str) -> str:
    """The HTML page of the Markdown ``text`` whose figures are PNG files relative to
    ``folder`` (embedded; a figure that is missing stays a link)."""
    from markdown_it import MarkdownIt

    body = MarkdownIt("commonmark").enable("table").render(text)
    folder = Path(folder)

    def embedded(match: re.Match) -> str:
        path = folder / html.unescape(match.group(1))
        if not path.is_file():
            return match.group(0)
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        return f'<img src="data:image/png;base64,{data}"'

    body = IMAGE.sub(embedded, body)
    return (f"<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<title>{html.escape(title)}</title>\n<style>\n{STYLE}\n</style>\n</head>\n"
            f"<body>\n{body}</body>\n</html>\n")


def write_html_report(markdown_path: str | Path, title: str) -> Path:
    """Write ``report.html`` beside the Markdown report at ``markdown_path``; its path."""
    markdown_path = Path(markdown_path)
    path = markdown_path.with_suffix(".html")
    path.write_text(markdown_html(markdown_path.read_text(encoding="utf-8"),
                                  markdown_path.parent, title), encoding="utf-8")
    return path
