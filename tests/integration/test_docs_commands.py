"""Every command of the README and docs runs as written, in order, on a fresh clone (issue 16
item 3).

The tracked files (``git ls-files``, so a fresh clone's content) are copied to a temporary
directory; the lines of every ```bash block of README.md, then docs/cases.md, docs/sweeps.md,
docs/theory.md and the other docs pages, are run there one by one (a ```text block is a
template, not run). ``granflow`` and ``python`` resolve to this tree's code. The
README's ``pip install -e ".[dev]" &&`` prefix is the installation (done) and its ``pytest`` the
suite itself (running); both are skipped. Runs are made small with the environment override
``GRANFLOW_EXTRA_SET`` (granflow.config.EXTRA_SET_ENV), scoped to the collapse cases; the
verification examples run as they are. A command that exits non-zero fails the test with its
output.
"""
from __future__ import annotations

import os
import re
import shlex
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from granflow.config import EXTRA_SET_ENV

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
DOCS_ORDER = ["README.md", "docs/cases.md", "docs/sweeps.md", "docs/theory.md"]
"""Files whose commands build on each other, in reading order; other docs pages follow."""
SMALL = ";".join([
    # collapses on coarse grids and for a quarter of a second (records every 0.05 s: the
    # documented plot at t = 0.2 s exists, the GIFs have 6 frames); they end still moving
    "column_collapse:grid.nx=16", "column_collapse:grid.nz=6", "column_collapse:time.stop_time=0.25",
    "column_collapse:output.interval=0.05",
    "lagree_column:grid.nx=16", "lagree_column:grid.nz=16", "lagree_column:time.stop_time=0.5"])
BASH_BLOCK = re.compile(r"^```bash\n(.*?)^```", re.S | re.M)
INSTALL_PREFIX = 'pip install -e ".[dev]" && '
TIMEOUT_S = 900


def documentation_files() -> list[str]:
    rest = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))
    return DOCS_ORDER + [p for p in rest if p not in DOCS_ORDER]


def commands(path: str) -> list[str]:
    """The command lines of the ```bash blocks of ``path`` (comments and blank lines dropped,
    the installation prefix removed, the test-suite command skipped)."""
    out = []
    for block in BASH_BLOCK.findall((ROOT / path).read_text(encoding="utf-8")):
        for line in block.splitlines():
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            if line.startswith(INSTALL_PREFIX):
                line = line[len(INSTALL_PREFIX):]
            if line == "pytest":
                continue
            out.append(line)
    return out


def test_the_extraction_finds_the_readme_commands():
    readme = commands("README.md")
    assert readme[0] == "granflow run examples/column_collapse_fluidised.toml"
    assert any(c.startswith("granflow sweep") for c in readme)
    assert "pytest" not in readme
    assert sum(len(commands(p)) for p in documentation_files()) >= 30


def fresh_clone(dest: Path) -> Path:
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in filter(None, files.decode().split("\0")):
        src = ROOT / name
        if src.is_file():
            target = dest / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, target)
    return dest


def tool_directory(bin_dir: Path) -> Path:
    bin_dir.mkdir()
    granflow = bin_dir / "granflow"
    granflow.write_text(f'#!/bin/sh\nexec "{sys.executable}" -c "import sys; from granflow.cli import main; '
                        f'sys.exit(main())" "$@"\n')
    granflow.chmod(granflow.stat().st_mode | stat.S_IEXEC)
    (bin_dir / "python").symlink_to(sys.executable)
    return bin_dir


def split_commands(line: str) -> list[list[str]]:
    """The commands of one line (``a; b`` is two), each as its argument list (comments dropped)."""
    lexer = shlex.shlex(line, posix=True, punctuation_chars=";")
    lexer.whitespace_split = True
    lexer.commenters = "#"
    out, current = [], []
    for token in lexer:
        if token == ";":
            out.append(current)
            current = []
        else:
            current.append(token)
    out.append(current)
    return [c for c in out if c]


def test_split_commands():
    assert split_commands('granflow list cases; granflow config show column_collapse   # every') == [
        ["granflow", "list", "cases"], ["granflow", "config", "show", "column_collapse"]]
    assert split_commands('granflow derive "0.38 + I"  # f') == [["granflow", "derive", "0.38 + I"]]


def test_every_documented_command_runs_in_order_on_a_fresh_clone(tmp_path, monkeypatch, capsys):
    """``granflow ...`` commands run in this process (the same CLI, without the start-up of a
    new interpreter for each), anything else (``python ...``) in a subprocess."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the git work tree (git ls-files)")
    from granflow.cli import main

    clone = fresh_clone(tmp_path / "clone")
    bin_dir = tool_directory(tmp_path / "bin")
    monkeypatch.chdir(clone)
    monkeypatch.setenv(EXTRA_SET_ENV, SMALL)  # read by load_case here and in the sweep's workers
    monkeypatch.setenv("MPLBACKEND", "Agg")
    env = dict(os.environ)
    env.update({"PATH": f"{bin_dir}{os.pathsep}{env.get('PATH', '')}",
                "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT / "src"), env.get("PYTHONPATH")]))})
    ran = []
    for path in documentation_files():
        for line in commands(path):
            for argv in split_commands(line):
                if argv[0] == "granflow":
                    code = main(argv[1:])
                    out, err = capsys.readouterr()
                else:
                    res = subprocess.run(argv, cwd=clone, env=env, capture_output=True, text=True,
                                         timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)
                    code, out, err = res.returncode, res.stdout, res.stderr
                assert code == 0, (f"{path}: `{line}` exited {code}\nstdout:\n{out[-3000:]}\n"
                                   f"stderr:\n{err[-3000:]}")
                ran.append(argv)
    # the commands did what they say: the README's outputs exist
    assert (clone / "runs" / "column_collapse_fluidised" / "output.nc").is_file()
    assert (clone / "runs" / "fluidised_140x30" / "summary.json").is_file()
    assert (clone / "pf.gif").is_file() and (clone / "rr.png").is_file()
    assert (clone / "runs" / "column_collapse_fluidised" / "vtk").is_dir()
    assert (clone / "runs" / "sweep_column").is_dir()
    assert len(ran) >= 30
