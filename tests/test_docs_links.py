"""Every relative link in README.md and the docs resolves inside the repository (a user with
only the repository can follow them), anchors included; the docs' example routine loads."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "examples").glob("*/README.md"))]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(md: Path) -> set[str]:
    text = FENCE.sub("", md.read_text())
    return {slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.*)$", text, re.M)}


def links(md: Path) -> list[str]:
    return LINK.findall(FENCE.sub("", md.read_text()))


def test_slug_matches_github():
    assert slug("Outputs of `gymtrack track <routine> --out <out>`") == "outputs-of-gymtrack-track-routine---out-out"
    assert slug("A worked example: `examples/balance_beam`") == "a-worked-example-examplesbalance_beam"


def test_the_docs_exist():
    names = {p.relative_to(ROOT).as_posix() for p in DOCS}
    assert {"README.md", "docs/formats.md", "docs/your-own-data.md", "examples/balance_beam/README.md"} <= names


@pytest.mark.parametrize("md", DOCS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_resolve_inside_the_repository(md):
    found = links(md)
    if md.name == "README.md" and md.parent == ROOT:
        assert len(found) >= 3  # the Documentation list
    for target in found:
        if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (md.parent / path).resolve() if path else md
        assert dest.exists(), f"{md.name}: link {target!r} points at {dest}, which does not exist"
        assert dest.is_relative_to(ROOT), f"{md.name}: link {target!r} leaves the repository"
        if anchor:
            assert dest.suffix == ".md", f"{md.name}: anchor on a non-markdown target {target!r}"
            assert anchor in anchors(dest), f"{md.name}: no heading for #{anchor} in {dest.name}"


def test_readme_does_not_send_the_reader_outside():
    text = (ROOT / "README.md").read_text()
    assert "../shared/formats.md" not in text and "../shared/paper" not in text
    assert "Enhancing Multi-Camera Gymnast Tracking Through Domain Knowledge Integration" in text


def test_example_routine_loads_with_ground_truth():
    from gymtrack.formats.routine import load_routine

    r = load_routine(ROOT / "examples" / "balance_beam")
    assert len(r.rig) == 4 and r.has_gt and len(r.detections) > 1000
    size = sum(p.stat().st_size for p in (ROOT / "examples").rglob("*") if p.is_file())
    assert size < 2_000_000
