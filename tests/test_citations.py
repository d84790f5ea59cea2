"""Every source the project cites is public or in the repository (issue 21, item 11).

The report's "Sources of the module presets" (module docstrings), its assumptions table (the comments of
``e2esim.budget.presets``) and docs/theory/ground-cancellation.md cited notes that are not part of the repository
(the project's research notes, a mission-facts file beside the checkout). This scans every text file the project
ships or shows (docs, README, sources and their docstrings, report templates, scenarios, examples, tools, tests)
for references to such material, for paths that leave the repository, and for markdown links and internal names
that do not resolve."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("README.md", "docs", "src", "scenarios", "examples", "tools", "benchmarks", "tests")
SUFFIXES = {".md", ".py", ".yaml", ".yml", ".j2", ".html", ".toml", ".txt", ".cfg"}
SKIPPED = {".venv", "__pycache__", ".git", "node_modules", "build", "dist"}

UNPUBLISHED = {
    r"research[ _-]notes?": "the project's research notes are not published",
    r"mission-facts": "the mission-facts file is not part of the repository",
    r"(?<![\w.:/])/(?:work|home|Users)/[\w.-]+": "an absolute path on the author's machine",
    r"(?:\.\./)+shared/": "a folder beside the checkout, not in the repository",
    r"\bunpublished (?:notes?|memo|report)\b": "an unpublished note",
    r"\binternal (?:notes?|memo|report)\b": "an internal note",
}
"""Pattern -> why a citation of it is not allowed."""


def _files():
    for entry in SCANNED:
        path = ROOT / entry
        paths = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
        for p in paths:
            if p.suffix in SUFFIXES and not SKIPPED & set(p.relative_to(ROOT).parts) and p != Path(__file__):
                yield p


def _lines(path):
    return path.read_text(encoding="utf-8", errors="replace").splitlines()


def test_the_scan_sees_the_report_sources():
    names = {p.relative_to(ROOT).as_posix() for p in _files()}
    assert {"docs/theory/ground-cancellation.md", "src/e2esim/budget/presets.py", "src/e2esim/report/document.py",
            "src/e2esim/stack/sites.py", "src/e2esim/report/templates/report.html.j2", "README.md"} <= names


@pytest.mark.parametrize("pattern", sorted(UNPUBLISHED))
def test_no_citation_of_unpublished_or_internal_material(pattern):
    found = [f"{p.relative_to(ROOT)}:{n}: {line.strip()}" for p in _files()
             for n, line in enumerate(_lines(p), 1) if re.search(pattern, line, re.IGNORECASE)]
    assert not found, UNPUBLISHED[pattern] + ":\n" + "\n".join(found)


def test_the_patterns_find_what_they_are_for():
    cited = ("(research notes Section 3)", "../shared/reference/mission-facts.md", "`/work/notes/research_12_13.md`",
             "an internal memo of the team")
    for text in cited:
        assert any(re.search(p, text, re.IGNORECASE) for p in UNPUBLISHED), text
    for text in ("docs/errata.md", "github.com/BioPAL/BPS", "Quegan et al. (2019), abstract", "e/m_e over c"):
        assert not any(re.search(p, text, re.IGNORECASE) for p in UNPUBLISHED), text


def test_relative_markdown_links_resolve_inside_the_repository():
    broken = []
    for p in _files():
        if p.suffix != ".md":
            continue
        for n, line in enumerate(_lines(p), 1):
            for target in re.findall(r"\]\(([^)\s]+)\)", line):
                if re.match(r"[a-z][a-z0-9+.-]*:|#", target):
                    continue  # a URL or an anchor
                resolved = (p.parent / target.split("#")[0]).resolve()
                if ROOT not in resolved.parents or not resolved.exists():
                    broken.append(f"{p.relative_to(ROOT)}:{n}: {target}")
    assert not broken, "links to files that are not in the repository:\n" + "\n".join(broken)


def test_the_seed_papers_named_by_number_are_defined_in_the_errata():
    """'seed 000' and the like name the published seed papers; docs/errata.md says which paper each is."""
    defined = set(re.findall(r"^## .*\(\d{4}\), seed (\d{3})$", (ROOT / "docs" / "errata.md").read_text(), re.M))
    assert defined == {"000", "003", "004"}
    used = {(m, p.relative_to(ROOT).as_posix()) for p in _files() for line in _lines(p)
            for m in re.findall(r"\bseed (\d{3})\b", line)}
    assert {m for m, _ in used} <= defined, sorted(u for u in used if u[0] not in defined)
