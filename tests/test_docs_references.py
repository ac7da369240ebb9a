"""Every reference to a section of a docs page ("docs/flow.md "Flux check"") names one.

Code comments, docstrings, tests, benchmarks, configs and the docs themselves point readers
to a section by its title; a page restructured or a section renamed must not leave them
pointing nowhere. A reference matches a section of that page whose title starts with the quoted
one: a heading (``## Flux check``, numbering such as ``4.`` left out), an emphasised paragraph
or list-item lead (``*Cold start.*``, ``* **Deleted outputs.**``) or a paragraph that opens
with its title and a colon (``Flux balance near a_c*: ...``). A title broken by a line end in
the source is matched by its part on the first line.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = [
    *sorted((ROOT / "src" / "roughflow").rglob("*.py")),
    *sorted((ROOT / "tests").glob("*.py")),
    *sorted((ROOT / "benchmarks").glob("*.py")),
    *sorted((ROOT / "workflow").rglob("*.py")),
    *sorted((ROOT / "workflow").rglob("*.smk")),
    ROOT / "Snakefile",
    *sorted((ROOT / "config").glob("*.yaml")),
    ROOT / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    ROOT / "results" / "README.md",
]
# docs/PAGE.md, then an optional comma, then a quoted title (closed, or cut by the line end)
# (a quote opens a title only before a capital or a backtick: "docs/measured.md's example")
REFERENCE = re.compile(r"docs/([a-z_]+)\.md,? *([\"'])([A-Z`].{1,79}?)(?:\2|$)", re.MULTILINE)
HEADING = re.compile(r"^#{1,6} +(?:\d+\. +)?(.+?) *$", re.MULTILINE)
EMPHASISED_LEAD = re.compile(r"^(?:[-*] +)?\*{1,2}([^*\n]+)\*{1,2}", re.MULTILINE)
COLON_LEAD = re.compile(r"(?:\A|\n\n)([A-Z][^:\n]{2,60}):")


def _plain(text: str) -> str:
    return text.replace("`", "").replace("*", "").strip().rstrip("\"' ")


def _titles(page: Path) -> list[str]:
    text = page.read_text()
    found = HEADING.findall(text) + EMPHASISED_LEAD.findall(text) + COLON_LEAD.findall(text)
    return [_plain(t) for t in found]


def _references() -> list[tuple[str, str, str]]:
    found = []
    for source in SOURCES:
        if not source.is_file():
            continue
        for match in REFERENCE.finditer(source.read_text()):
            page, title = match.group(1), _plain(match.group(3))
            line = source.read_text().count("\n", 0, match.start()) + 1
            found.append((f"{source.relative_to(ROOT)}:{line}", page, title))
    return found


REFERENCES = _references()


def test_references_are_found():
    # the pattern must keep seeing the references the code is known to make
    assert len(REFERENCES) >= 50, REFERENCES


@pytest.mark.parametrize(("where", "page", "title"), REFERENCES,
                         ids=[r[0] for r in REFERENCES])
def test_reference_names_a_section(where, page, title):
    path = ROOT / "docs" / f"{page}.md"
    assert path.is_file(), f"{where}: docs/{page}.md does not exist"
    titles = _titles(path)
    assert any(t.startswith(title) for t in titles), (
        f"{where}: docs/{page}.md has no section titled {title!r}")
