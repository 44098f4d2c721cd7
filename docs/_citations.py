"""The page "Citing grainlab" written from CITATION.cff (so the citation is written once):
the software's entry as BibTeX, and the works each feature reproduces."""

from __future__ import annotations

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def _authors(entry: dict) -> str:
    names = []
    for author in entry.get("authors", []):
        if "family-names" in author:
            names.append(f"{author['family-names']}, {author.get('given-names', '')}".strip(", "))
        else:
            names.append(author["name"])
    return " and ".join(names)


def _reference_row(entry: dict) -> str:
    where = entry.get("journal") or entry.get("institution", {}).get("name", "")
    doi = f" [doi:{entry['doi']}](https://doi.org/{entry['doi']})" if entry.get("doi") else ""
    work = (f"{_authors(entry).replace(' and ', '; ')} ({entry['year']}). "
            f"*{' '.join(entry['title'].split())}*." + (f" {where}." if where else "") + doi)
    return f"| {work} | {' '.join(entry.get('notes', '').split())} |"


def write_citations(path: Path, citation: Path = ROOT / "CITATION.cff") -> None:
    """Write the generated part of the citing page to ``path`` from ``citation``."""
    data = yaml.safe_load(citation.read_text(encoding="utf-8"))
    bibtex = "\n".join([
        "@software{grainlab,",
        f"  title   = {{{data['title']}}},",
        f"  author  = {{{_authors(data)}}},",
        f"  version = {{{data['version']}}},",
        f"  license = {{{data['license']}}},",
        "}"])
    lines = [" ".join(data["message"].split()), "", "```bibtex", bibtex, "```", "",
             "## The works grainlab reproduces", "",
             "| work | what grainlab takes from it |", "|---|---|"]
    lines += [_reference_row(entry) for entry in data.get("references", [])]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
