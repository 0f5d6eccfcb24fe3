"""Section citations point into docs/, at sections that exist.

Code comments cite the documentation as ``docs/<file>.md`` followed by the section sign and a
number (``3`` or ``2.4``); further numbers may follow in the same citation (``, 2.6`` or
``and 2.6``, each with its own section sign) and belong to the same file. A section exists when a
Markdown heading of that file starts with its number (``## 3. Lockstep``, ``### 2.4 Static layer``).

The code once cited two documents kept outside the repository by an upper-case name, a space and
the section sign; ``test_no_old_form_citations`` keeps that form from coming back.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: where citations are looked for (this file excepted: it describes the forms it looks for)
SCANNED = ("simplebot_navigation", "tests", "bench")
SUFFIXES = {".py", ".md", ".yaml", ".txt"}
SELF = Path(__file__).resolve()

SIGN = "\u00a7"          # the section sign, spelled out so that a search for the old form skips this file
NUMBER = r"\d+(?:\.\d+)*"
CITATION = re.compile(rf"docs/([\w.-]+\.md) {SIGN}({NUMBER})((?:\s*(?:,|and|or)\s*{SIGN}{NUMBER})*)")
FOLLOWING = re.compile(rf"{SIGN}({NUMBER})")
OLD_FORM = re.compile(rf"\b(DESIGN|REFERENCE) {SIGN}({NUMBER})")
HEADING = re.compile(rf"^#{{1,6}}[ \t]+({NUMBER})\.?[ \t]", re.MULTILINE)


def sections(doc: Path) -> list[str]:
    """Section numbers of a Markdown file, in the order of its headings."""
    return HEADING.findall(doc.read_text(encoding="utf-8"))


def scanned_files() -> list[Path]:
    files = [p for folder in SCANNED for p in sorted((ROOT / folder).rglob("*"))
             if p.is_file() and p.suffix in SUFFIXES and p.resolve() != SELF and "__pycache__" not in p.parts]
    return files + [ROOT / "README.md", ROOT / "BENCHMARKS.md"] + sorted(DOCS.glob("*.md"))


def citations(text: str):
    """(line number, file name, section number) of every docs/ citation in text."""
    for match in CITATION.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        yield line, match.group(1), match.group(2)
        for number in FOLLOWING.findall(match.group(3)):
            yield line, match.group(1), number


def unresolved(text: str, where: str) -> list[str]:
    """Citations in text that name a missing docs/ file or section."""
    known: dict[str, set[str]] = {}
    problems = []
    for line, name, number in citations(text):
        if name not in known:
            doc = DOCS / name
            known[name] = set(sections(doc)) if doc.is_file() else set()
            if not doc.is_file():
                problems.append(f"{where}:{line}: docs/{name} does not exist")
                continue
        if known[name] and number not in known[name]:
            problems.append(f"{where}:{line}: docs/{name} has no section {number}")
    return problems


@pytest.mark.parametrize("name", ["design.md", "reference.md", "README.md"])
def test_documents_exist(name):
    assert (DOCS / name).is_file(), f"docs/{name} is missing"


@pytest.mark.parametrize("name", ["design.md", "reference.md"])
def test_section_numbers_are_explicit_and_unique(name):
    numbers = sections(DOCS / name)
    assert numbers, f"docs/{name} has no numbered headings"
    duplicates = sorted({n for n in numbers if numbers.count(n) > 1})
    assert not duplicates, f"docs/{name}: section numbers used twice: {duplicates}"
    # every numbered subsection sits in a numbered section
    missing = sorted({n.rpartition(".")[0] for n in numbers if "." in n} - set(numbers))
    assert not missing, f"docs/{name}: subsections without their section: {missing}"


def test_index_links_exist():
    text = (DOCS / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text)
    assert links
    for link in links:
        assert (DOCS / link).exists(), f"docs/README.md links to {link}, which does not exist"


def test_doc_citations_resolve():
    """Every docs/<file>.md citation in the code, tests, benchmarks and docs names an existing section."""
    problems = []
    for path in scanned_files():
        problems += unresolved(path.read_text(encoding="utf-8", errors="replace"), str(path.relative_to(ROOT)))
    assert not problems, "citations of missing documentation:\n" + "\n".join(problems)


def test_no_old_form_citations():
    """No comment cites the documents that lived outside the repository."""
    found = []
    for path in scanned_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for match in OLD_FORM.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            found.append(f"{path.relative_to(ROOT)}:{line}: {match.group(0)}")
    assert not found, (f"{len(found)} citations of documents outside the repository; cite docs/ instead:\n"
                       + "\n".join(found))
