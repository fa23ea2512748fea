"""Smoke runs of the validation/figure scripts at their coarsest size, so they cannot rot."""
from __future__ import annotations

from pathlib import Path

from _scripts import load_script

ROOT = Path(__file__).resolve().parents[1]


def _load(rel: str):
    return load_script(rel)


def test_theory_figures_quick(tmp_path):
    paths = _load("validation/theory/make_figures.py").run(tmp_path, quick=True)
    assert len(paths) == 4
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
