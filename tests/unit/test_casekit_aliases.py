"""``granflow.cases`` holds case files only (issue 18 item 4): its registry, runner and helpers moved
to ``granflow.casekit``, and the old import paths ``granflow.cases.<module>`` still give those
modules -- the same module objects, so a monkeypatch through either path is seen by both
(:func:`granflow.registry.alias_modules`).
"""
from __future__ import annotations

import importlib
import pkgutil
import sys

import pytest

import granflow.cases as cases_pkg
from granflow.registry import alias_modules


@pytest.mark.parametrize("name", cases_pkg.MOVED)
def test_the_old_path_is_the_moved_module(name):
    old = importlib.import_module(f"granflow.cases.{name}")
    new = importlib.import_module(f"granflow.casekit.{name}")
    assert old is new
    assert old.__spec__.name == old.__name__ == f"granflow.casekit.{name}"
    assert getattr(cases_pkg, name) is new  # ``from granflow.cases import name`` too


def test_old_style_imports_of_user_scripts_work(monkeypatch):
    from granflow.cases.common import make_model
    from granflow.cases.registry import CASES as OLD_CASES
    from granflow.cases.runner import CaseRun

    import granflow.casekit.common
    import granflow.casekit.runner

    assert make_model is granflow.casekit.common.make_model
    assert CaseRun is granflow.casekit.runner.CaseRun and OLD_CASES is cases_pkg.CASES
    monkeypatch.setattr("granflow.cases.runner.REST_SPEED_FACTOR", -1.0)
    assert granflow.casekit.runner.REST_SPEED_FACTOR == -1.0


def test_the_cases_package_holds_case_modules_only():
    modules = {m.name for m in pkgutil.iter_modules(cases_pkg.__path__)}
    assert modules and not modules & set(cases_pkg.MOVED)
    assert not hasattr(cases_pkg, "INFRASTRUCTURE")
    found = cases_pkg.discover()
    registered = {cases_pkg.CASES.get(n).setup.__module__ for n in cases_pkg.CASES.names()}
    assert set(found) == {f"granflow.cases.{m}" for m in modules if not m.startswith("_")} == registered


def test_an_alias_of_an_unknown_name_is_not_found_and_is_installed_once():
    before = len(sys.meta_path)
    alias_modules("granflow.cases", {"nothing": "granflow.registry"})  # granflow.cases has one: ignored
    assert len(sys.meta_path) == before
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("granflow.cases.no_such_module")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("granflow.cases.nothing")
