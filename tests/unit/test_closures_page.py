"""docs/closures.md is generated from the closure registry (issue 18 item 4):
:func:`granflow.rheology.docs.closures_markdown`. The committed page must equal the generated
text; the failure message gives the regeneration command."""
from __future__ import annotations

from pathlib import Path

from granflow.rheology import CLOSURES
from granflow.rheology.docs import closures_markdown, main
from _scripts import ROOT

PAGE = ROOT / "docs" / "closures.md"
REGENERATE = "python -m granflow.rheology.docs docs/closures.md"


def stale(page: Path) -> str | None:
    """Why ``page`` is not the generated page (with the command that regenerates it), or None."""
    generated = closures_markdown()
    committed = page.read_text(encoding="utf-8") if page.exists() else ""
    if committed == generated:
        return None
    old, new = committed.splitlines(), generated.splitlines()
    first = next((i for i, (a, b) in enumerate(zip(old, new)) if a != b), min(len(old), len(new)))
    return (f"{page.name} is stale (first difference at line {first + 1}): regenerate it with "
            f"`{REGENERATE}` from the repository root")


def test_docs_closures_md_is_the_generated_page():
    problem = stale(PAGE)
    assert problem is None, problem


def test_the_stale_check_fails_on_an_edited_or_missing_page(tmp_path):
    page = tmp_path / "closures.md"
    assert "regenerate it with `python -m granflow.rheology.docs" in stale(page)  # missing
    main([str(page)])
    assert stale(page) is None
    page.write_text(page.read_text().replace("mu_i", "mu_j", 1))
    assert "stale (first difference at line" in stale(page)


def test_the_page_lists_every_closure_with_its_options():
    text = closures_markdown()
    for name in CLOSURES:
        assert f"### `{name}`" in text
    assert "| `delta_deg` | 25 | internal friction angle [deg] |" in text
