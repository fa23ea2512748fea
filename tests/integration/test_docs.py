"""Documentation stays in step with the code."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from _scripts import load_script

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)


def test_options_reference_is_current():
    mod = load_script("docs/make_reference.py", "make_reference")
    committed = (ROOT / "docs" / "closures.md").read_text()
    assert committed == mod.render(), "docs/closures.md is stale: run python docs/make_reference.py"


def test_readme_opens_with_the_two_commands():
    lines = [ln for ln in (ROOT / "README.md").read_text().splitlines() if ln.strip()]
    assert lines[0] == "# granflow"
    assert lines[1] == "```bash"
    assert lines[2].startswith('pip install -e ".[dev]" && granflow ')
    assert lines[3] == 'pip install -e ".[dev]" && pytest'


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text()
    assert 'pip install -e ".[dev]"' in ci
    assert "\npytest\n" in ci


def test_docstring_examples_run():
    """Doctests of the public modules (numpydoc Examples sections)."""
    mods = ["granflow.rheology.base", "granflow.rheology.derive", "granflow.rheology", "granflow.diagnostics",
            "granflow.output.accessor"]
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "--doctest-modules", "-p", "no:cacheprovider",
                          *[str(ROOT / "src" / (m.replace(".", "/") + ("/__init__.py" if m == "granflow.rheology" else ".py")))
                            for m in mods]], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stdout + res.stderr


# --- links (issue 16 item 10): the project's docs are self-contained --------------------------
import re  # noqa: E402

#: Markdown files of the project's documentation.
DOC_FILES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md"),
                    *(ROOT / "validation").rglob("*.md"), *(ROOT / "benchmarks").rglob("*.md")])
LINK = re.compile(r"\]\(([^)\s]+)\)")
MODEL_SECTION_REF = re.compile(r"model\.md\)?\s*§\s*(\d+)(?:\.(\d+))?")


def _relative_links(path: Path) -> list[str]:
    links = LINK.findall(path.read_text(encoding="utf-8"))
    # a path has a dot or a slash (this skips math such as "[E_k + E_p](t)")
    return [ln for ln in links if not re.match(r"^[a-z]+:", ln) and not ln.startswith("#")
            and ("." in ln or "/" in ln)]


def test_every_relative_link_resolves_inside_the_repository():
    bad = []
    for doc in DOC_FILES:
        for link in _relative_links(doc):
            target = (doc.parent / link.split("#")[0]).resolve()
            inside = target == ROOT or ROOT in target.parents
            if not inside or not target.exists():
                bad.append(f"{doc.relative_to(ROOT)}: {link}")
    assert not bad, "broken or out-of-tree links:\n" + "\n".join(bad)


def test_no_document_points_into_shared():
    hits = [f"{p.relative_to(ROOT)}:{i}" for p in DOC_FILES + sorted((ROOT / "validation").rglob("*.py"))
            + sorted((ROOT / "benchmarks").rglob("*.py")) + sorted((ROOT / "examples").glob("*.toml"))
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if "../shared" in line or "shared/reference" in line or re.search(r"(?<![\w/])MODEL\.md", line)]
    assert not hits, f"references to the development machine's ../shared/: {hits}"


def test_model_page_cites_the_paper_and_has_its_labels():
    text = (ROOT / "docs" / "model.md").read_text(encoding="utf-8")
    for needed in ("Chupin", "Dubois", "Non-isochoric stable granular models taking into account "
                   "fluidisation by pore gas pressure"):
        assert needed in text
    for label in ("syst1b", "syst2b", "syst3b", "syst4b", "def:S", "def:I", "f-general", "f-DP", "C1",
                  "C2", "C3", "th1", "th2", "th3", "th4", "ideal-gas0", "dissipation-general"):
        assert re.search(rf"(?<![\w:-]){re.escape(label)}(?![\w:-])", text), label
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "](docs/model.md)" in readme


def test_section_references_to_the_model_page_exist():
    text = (ROOT / "docs" / "model.md").read_text(encoding="utf-8")
    sections = {int(n) for n in re.findall(r"^## (\d+)\. ", text, flags=re.M)}
    items = set(re.findall(r"\*\*(\d+\.\d+)\*\*", text))
    assert sections == set(range(1, 9))
    refs = []
    for p in DOC_FILES + sorted((ROOT / "validation").rglob("*.py")) + sorted((ROOT / "examples").glob("*.toml")):
        for m in MODEL_SECTION_REF.finditer(p.read_text(encoding="utf-8")):
            refs.append((p.relative_to(ROOT), m.group(1), m.group(2)))
    assert refs, "the docs cite sections of docs/model.md"
    bad = [r for r in refs if int(r[1]) not in sections or (r[2] and f"{r[1]}.{r[2]}" not in items)]
    assert not bad, bad
