"""Every link between the README and docs pages points at a file that exists and, with an anchor, at a heading of
that file (GitHub's anchors): pages are split and sections moved, and a link left behind is a dead end."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
LINK = re.compile(r"\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def anchors(page: Path) -> set[str]:
    """GitHub's anchors of ``page``'s headings (lower case, punctuation dropped, spaces as dashes, -1 on repeats)."""
    found: set[str] = set()
    counts: dict[str, int] = {}
    for title in re.findall(r"^#+\s+(.*)$", FENCE.sub("", page.read_text()), re.M):
        slug = re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")
        n = counts.get(slug, 0)
        counts[slug] = n + 1
        found.add(slug if n == 0 else f"{slug}-{n}")
    return found


def test_every_docs_link_reaches_its_page_and_heading() -> None:
    dead = []
    for page in PAGES:
        for link in LINK.findall(FENCE.sub("", page.read_text())):
            if link.startswith(("http://", "https://", "mailto:")):
                continue
            path, _, anchor = link.partition("#")
            target = (page.parent / path).resolve() if path else page
            if not target.exists():
                dead.append(f"{page.relative_to(ROOT)}: {link} (no such file)")
            elif anchor and target.suffix == ".md" and anchor not in anchors(target):
                dead.append(f"{page.relative_to(ROOT)}: {link} (no such heading)")
    assert not dead, "\n".join(dead)


def test_the_check_sees_a_dead_anchor(tmp_path: Path) -> None:
    page = tmp_path / "a.md"
    page.write_text("# A page\n\n## Two words, punctuated!\n")
    assert anchors(page) == {"a-page", "two-words-punctuated"}
