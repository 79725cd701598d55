"""The repository's own files stay what they claim to be.

On 2026-12-06 an editing script replaced an empty string in CHANGELOG.md, which inserted one
entry between every two characters of the file (96 kB became 93.7 MB) and nothing failed.
These checks read the text files of a checkout (the folders below, without the caches and
run outputs that .gitignore keeps out; bench's results JSON files are read too, being small)
and fail on such a file: a text file above 2 MB (the largest committed result, a bed
comparison's JSON, is 1.5 MB) and a CHANGELOG entry written twice.
"""

from __future__ import annotations

import collections
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TEXT_SUFFIXES = {".md", ".py", ".toml", ".json", ".csv", ".txt", ".cfg", ".in", ".sh"}
FOLDERS = ("src", "tests", "docs", "bench", "reference", ".ci")
# Written by runs and ignored by git (.gitignore): not part of a checkout.
GENERATED = {"__pycache__", ".pytest_cache", "out", "build", "dist", ".venv"}
MAX_TEXT_BYTES = 2_000_000


def _checkout_text_files():
    files = [p for p in ROOT.iterdir() if p.is_file() and p.suffix in TEXT_SUFFIXES]
    for folder in FOLDERS:
        for p in (ROOT / folder).rglob("*"):
            rel = p.relative_to(ROOT)
            if any(part in GENERATED or part.endswith(".egg-info") for part in rel.parts):
                continue
            if p.is_file() and p.suffix in TEXT_SUFFIXES:
                files.append(p)
    return files


def test_the_checkout_has_the_files_these_checks_read():
    names = {p.relative_to(ROOT).as_posix() for p in _checkout_text_files()}
    for expected in ("README.md", "CHANGELOG.md", "docs/model.md", "pyproject.toml",
                     "src/bsrflow/cli.py"):
        assert expected in names
    # the license pyproject.toml declares is in the checkout and in the package's metadata files
    assert "BSD 3-Clause License" in (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert 'license-files = ["LICENSE"]' in (ROOT / "pyproject.toml").read_text(encoding="utf-8")


def test_no_text_file_is_larger_than_2_mb():
    too_large = {
        p.relative_to(ROOT).as_posix(): p.stat().st_size
        for p in _checkout_text_files()
        if p.stat().st_size > MAX_TEXT_BYTES
    }
    assert too_large == {}


def _changelog_entries(text: str) -> list[str]:
    """The bullet entries of CHANGELOG.md: a line starting with "- " and its indented
    continuation lines."""
    entries: list[list[str]] = []
    current: list[str] | None = None
    for line in text.splitlines():
        if line.startswith("- "):
            current = [line]
            entries.append(current)
        elif line.startswith("  ") and current is not None:
            current.append(line)
        else:
            current = None
    return ["\n".join(e) for e in entries]


def test_changelog_entries_split_as_written():
    text = "# Changelog\n\n- one\n  more\n- two\n\n## older\n\n- three\n"
    assert _changelog_entries(text) == ["- one\n  more", "- two", "- three"]


def test_no_changelog_entry_is_written_twice():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert text.startswith("# Changelog\n")
    entries = _changelog_entries(text)
    assert len(entries) > 10
    repeated = {e[:80]: n for e, n in collections.Counter(entries).items() if n > 1}
    assert repeated == {}
    # Every line of the file is a heading, a blank line or part of an entry.
    stray = [
        line for line in text.splitlines()
        if line and not line.startswith(("#", "- ", "  "))
    ]
    assert stray == []


def _github_anchor(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: link markup dropped, lower case, punctuation but
    hyphens removed, spaces as hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.lstrip("#").strip()).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def test_github_anchor_of_headings():
    assert _github_anchor("## Schemes: `seed` and `accurate`") == "schemes-seed-and-accurate"
    assert _github_anchor("## What differs (see [docs/model.md](docs/model.md))") == (
        "what-differs-see-docsmodelmd")


def test_markdown_links_inside_the_repository_resolve():
    """Every relative link of README.md and of every docs/*.md names a file that exists, and every
    #anchor a heading of that file."""
    broken = []
    docs = ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))
    assert len(docs) >= 6, docs
    for doc in docs:
        path = ROOT / doc
        for target in re.findall(r"\]\(([^)\s]+)\)", path.read_text(encoding="utf-8")):
            if target.startswith(("http://", "https://", "mailto:")):
                continue
            file_part, _, anchor = target.partition("#")
            linked = (path.parent / file_part).resolve() if file_part else path
            if not linked.exists():
                broken.append(f"{doc}: {target} (no such file)")
                continue
            if anchor:
                headings = {
                    _github_anchor(line) for line in linked.read_text(encoding="utf-8").splitlines()
                    if line.startswith("#")
                }
                if anchor not in headings:
                    broken.append(f"{doc}: {target} (no such heading)")
    assert broken == []
