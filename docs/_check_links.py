"""Every link inside the built site leads somewhere: each ``href`` and ``src`` of every page of
``docs/_build/html`` that points into the site names a file that exists and, if it has a
``#fragment``, an element with that id in it. Links out of the site (http, mailto) are listed
with their count, not fetched: the check must pass offline. Exit status 1 on a broken link.

    python docs/_check_links.py [docs/_build/html]
"""

from __future__ import annotations

import sys
from collections import defaultdict
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit


class _Page(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs) -> None:
        for name, value in attrs:
            if name in ("id", "name") and value:
                self.ids.add(value)
            if value and ((name == "href" and tag in ("a", "link")) or
                          (name == "src" and tag in ("img", "script"))):
                self.links.append(value)


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8", errors="replace"))
    return page


def _pages(site: Path) -> list[Path]:
    """The site's pages (not the theme's templates under _static)."""
    return [path for path in site.rglob("*.html") if "_static" not in path.relative_to(site).parts]


def broken_links(site: Path) -> tuple[list[str], dict[str, int]]:
    """(broken links as 'page: link (why)', links out of the site by scheme)."""
    pages = {path: _parse(path) for path in _pages(site)}
    broken, outside = [], defaultdict(int)
    for path, page in pages.items():
        for link in page.links:
            parts = urlsplit(link)
            if parts.scheme or link.startswith("//"):
                outside[parts.scheme or "//"] += 1
                continue
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            where = f"{path.relative_to(site)}: {link}"
            if not target.exists():
                broken.append(f"{where} (no such file)")
                continue
            if parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{where} (no element with id {parts.fragment!r})")
    return broken, dict(outside)


def main(argv: list[str]) -> int:
    site = Path(argv[1] if len(argv) > 1 else Path(__file__).parent / "_build" / "html")
    if not (site / "index.html").exists():
        print(f"no built site in {site}: run `make docs` first")
        return 1
    broken, outside = broken_links(site)
    n_pages = len(_pages(site))
    for line in broken:
        print("broken:", line)
    print(f"{n_pages} pages, {len(broken)} broken links inside the site; links out of the "
          f"site (not fetched): {outside or 'none'}")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
