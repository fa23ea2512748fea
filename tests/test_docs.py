"""Documentation stays in step with the code."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from _scripts import load_script

ROOT = Path(__file__).resolve().parents[1]


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
    mods = ["granflow.rheology.base", "granflow.rheology.derive", "granflow.rheology"]
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "--doctest-modules", "-p", "no:cacheprovider",
                          *[str(ROOT / "src" / (m.replace(".", "/") + ("/__init__.py" if m == "granflow.rheology" else ".py")))
                            for m in mods]], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stdout + res.stderr
