"""Sweeps: member generation (grid, zip, Latin hypercube), overrides, and runs on Dask.

The Dask tests use a ``distributed.LocalCluster`` started here (2 single-threaded worker
*processes*, so the member function really is pickled and imported by the workers) and, once,
the default cluster that :func:`run_sweep` starts itself. Calls are counted through files that the
member function appends to. Expected summaries are computed here from the parameter values.
"""
from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.sweep import SweepSpec, apply_overrides, run_sweep

FAIL_A = 2  # members with model.a == FAIL_A raise
CALLS = "calls.txt"
BASE = {"model": {"a": 0, "b": 0.0, "name": "toy"}, "material": {"d": 7e-5}}


def toy_member(config: dict, outdir) -> dict:
    """Member function run on the workers (module level, so that Dask can import it)."""
    with (outdir / CALLS).open("a") as fh:
        fh.write("call\n")
    a, b = config["model"]["a"], config["model"]["b"]
    if a == FAIL_A:
        raise ValueError(f"a = {a} is bad")
    return {"product": a * b, "energy": {"error": float("nan")}, "d": config["material"]["d"],
            "profile": [1.0, 2.0]}


def calls(member_dir) -> int:
    path = member_dir / CALLS
    return len(path.read_text().splitlines()) if path.exists() else 0


def read_table(path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


GRID = {"base": BASE, "parameters": {"model.a": {"values": [1, 2, 3]},
                                     "model.b": {"range": [0.0, 1.0], "n": 2}}}


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as c:
        yield c


# ------------------------------------------------------------------------------ members
def test_grid_members_are_the_cartesian_product_with_stable_ids():
    members = SweepSpec.from_dict(GRID).members()
    assert [m for m, _ in members] == [f"m{i:04d}" for i in range(6)]
    assert [tuple(o.values()) for _, o in members] == [
        (1, 0.0), (1, 1.0), (2, 0.0), (2, 1.0), (3, 0.0), (3, 1.0)]
    assert SweepSpec.from_dict(GRID).members() == members


def test_zip_members_pair_elementwise():
    spec = SweepSpec.from_dict({"parameters": {"a": {"values": ["x", "y", "z"]},
                                               "b": {"range": [1.0, 2.0], "n": 3}}, "mode": "zip"})
    assert [tuple(o.values()) for _, o in spec.members()] == [("x", 1.0), ("y", 1.5), ("z", 2.0)]


LHS = {"parameters": {"material.d": {"lhs": [6e-5, 8e-5]}, "slope_deg": {"lhs": [0.0, 20.0]},
                      "model.b": {"lhs": [-1.0, 1.0]}},
       "mode": "lhs", "samples": 10, "seed": 2024, "base": BASE}


def test_lhs_is_reproducible_and_stratified():
    members = SweepSpec.from_dict(LHS).members()
    assert members == SweepSpec.from_dict(LHS).members()
    assert members != SweepSpec.from_dict({**LHS, "seed": 2025}).members()
    n = LHS["samples"]
    assert len(members) == n
    for key, p in LHS["parameters"].items():
        lo, hi = p["lhs"]
        v = np.array([o[key] for _, o in members])
        assert ((v >= lo) & (v <= hi)).all(), key
        bins = np.floor((v - lo) / (hi - lo) * n).astype(int)
        assert sorted(bins) == list(range(n)), key  # each of the n strata hit exactly once


@pytest.mark.parametrize("bad, culprit", [
    ({"parameters": {"model.a": {"valuse": [1]}}}, "valuse"),
    ({"parameters": {"model.a": {"values": [1], "lhs": [0, 1]}}}, "exactly one"),
    ({"parameters": {"model.a": {"range": [0, 1]}}}, "'n'"),
    ({"parameters": {"model.a": {"range": [1, 0], "n": 2}}}, "lo < hi"),
    ({"parameters": {"model.a": {"lhs": [0, 1]}}}, "mode = 'lhs'"),
    ({"parameters": {"model.a": {"lhs": [0, 1]}}, "mode": "lhs", "samples": 3}, "seed"),
    ({"parameters": {"model.a": {"values": [1]}}, "seed": 1}, "lhs"),
    ({"parameters": {"a": {"values": [1]}, "b": {"values": [1, 2]}}, "mode": "zip"}, "equally"),
    ({"parameters": {"modle.a": {"values": [1]}}, "base": BASE}, "modle"),
    ({"parameters": {"model.a": {"values": [1]}}, "mode": "random"}, "mode"),
    ({"parameters": {}}, "parameters"),
])
def test_spec_errors_name_the_problem(bad, culprit):
    with pytest.raises(GranflowInputError, match=culprit):
        SweepSpec.from_dict(bad)


def test_apply_overrides():
    out = apply_overrides(BASE, {"model.a": 5, "model.extra.deep": [1], "material.d": 1e-4,
                                 "new_key": True})
    assert out == {"model": {"a": 5, "b": 0.0, "name": "toy", "extra": {"deep": [1]}},
                   "material": {"d": 1e-4}, "new_key": True}
    assert BASE["model"]["a"] == 0 and "extra" not in BASE["model"]  # base untouched
    with pytest.raises(GranflowInputError, match="'materail'"):
        apply_overrides(BASE, {"materail.d": 1.0})
    with pytest.raises(GranflowInputError, match="'model.name' is not a table"):
        apply_overrides(BASE, {"model.name.x": 1.0})
    assert apply_overrides({"a": 1}, {"b.c": 2}) == {"a": 1, "b": {"c": 2}}  # no sections: free


# ------------------------------------------------------------------------------ Dask runs
def test_grid_sweep_on_existing_cluster_records_failures_and_skips_finished(tmp_path, cluster):
    out = tmp_path / "sweep"
    table = run_sweep(GRID, toy_member, out, scheduler=cluster.scheduler_address)
    assert table == out / "sweep_summary.csv"
    rows = read_table(table)
    members = SweepSpec.from_dict(GRID).members()
    assert [r["member_id"] for r in rows] == [m for m, _ in members]
    for row, (mid, ov) in zip(rows, members, strict=True):
        mdir = out / mid
        assert calls(mdir) == 1
        member = json.loads((mdir / "member.json").read_text())
        assert member["config"]["model"]["a"] == ov["model.a"]
        assert member["config"]["model"]["name"] == "toy"
        assert float(row["model.a"]) == ov["model.a"] and float(row["model.b"]) == ov["model.b"]
        assert row["cached"] == "False"
        if ov["model.a"] == FAIL_A:
            assert row["status"] == "failed" and "ValueError: a = 2 is bad" in row["error"]
            err = json.loads((mdir / "error.json").read_text())
            assert "a = 2 is bad" in err["error"] and "toy_member" in err["traceback"]
            assert not (mdir / "summary.json").exists()
        else:
            assert row["status"] == "ok" and row["error"] == ""
            summary = json.loads((mdir / "summary.json").read_text())
            assert summary["product"] == ov["model.a"] * ov["model.b"]
            assert summary["energy"] == {"error": None}  # NaN -> null
            assert math.isclose(float(row["product"]), ov["model.a"] * ov["model.b"])
            assert row["energy.error"] == "" and row["d"] == "7e-05"
            assert "profile" not in row  # only scalars go to the table

    # re-run: finished members are skipped, failed ones are tried again
    rows2 = read_table(run_sweep(GRID, toy_member, out, scheduler=cluster.scheduler_address))
    for row, (mid, ov) in zip(rows2, members, strict=True):
        failed = ov["model.a"] == FAIL_A
        assert calls(out / mid) == (2 if failed else 1), mid
        assert row["status"] == ("failed" if failed else "ok")
        assert row["cached"] == ("False" if failed else "True")
    assert [r["product"] for r in rows2] == [r["product"] for r in rows]

    # a different sweep in the same directory is refused rather than silently mixed
    other = {**GRID, "parameters": {**GRID["parameters"], "model.a": {"values": [7, 8, 9]}}}
    with pytest.raises(GranflowInputError, match="different sweep"):
        run_sweep(other, toy_member, out, scheduler=cluster.scheduler_address)


def test_default_local_cluster(tmp_path):
    pytest.importorskip("distributed")
    spec = {"base": BASE, "mode": "zip",
            "parameters": {"model.a": {"values": [1, 3]}, "model.b": {"values": [0.5, 2.0]}}}
    rows = read_table(run_sweep(spec, toy_member, tmp_path, workers=1))
    assert [(r["status"], float(r["product"])) for r in rows] == [("ok", 0.5), ("ok", 6.0)]
    with pytest.raises(GranflowInputError, match="workers"):
        run_sweep(spec, toy_member, tmp_path, scheduler="tcp://127.0.0.1:1", workers=2)


def test_docstring_examples():
    import doctest

    import granflow.sweep_spec

    result = doctest.testmod(granflow.sweep_spec)  # SweepSpec's examples (re-exported by granflow.sweep)
    assert result.attempted > 0 and result.failed == 0
