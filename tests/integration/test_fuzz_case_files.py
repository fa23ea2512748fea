"""Fuzzed bad input (issue 5, item 8): at least 200 malformed case files, generated from the dry
example by seeded mutations. Each must end with exit code 2, one line on stderr naming the
problem, no traceback, and nothing run.

The expected fragment of each message is fixed by the mutation (the key path, the bad name, or the
file-level problem), not read back from the code under test.
"""
from __future__ import annotations

import random
import tomllib

import pytest

from granflow.cli import main

from _scripts import ROOT  # noqa: E402  (the repository; tests/ holds tiers)
BASE_TEXT = (ROOT / "examples" / "column_collapse_dry.toml").read_text()
BASE = tomllib.loads(BASE_TEXT)
N_CASES = 220
SEED = 20261122

NUMERIC_KEYS = [("grid", "Lx"), ("grid", "Lz"), ("material", "d"), ("material", "rho_s"), ("setup", "H0"),
                ("setup", "L0"), ("time", "stop_time"), ("time", "dt_max"), ("output", "interval")]
INT_KEYS = [("grid", "nx"), ("grid", "nz")]


def _toml_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if v != v:
            return "nan"
        if v in (float("inf"), float("-inf")):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return str(v)


def dump(d: dict) -> str:
    lines = []
    for section, table in d.items():
        lines.append(f"[{section}]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in table.items()]
        lines.append("")
    return "\n".join(lines)


def _copy() -> dict:
    return {s: dict(t) for s, t in BASE.items()}


def mutations(rng: random.Random):
    """Yield (kind, file text or bytes, expected message fragment)."""
    word = lambda: "".join(rng.choice("abcdefghijklmnopqrstuvwxyz_") for _ in range(rng.randint(3, 10)))  # noqa: E731
    while True:
        kind = rng.choice(["unknown_section", "unknown_key", "wrong_type", "nan", "negative", "huge_grid",
                           "unknown_closure", "closure_param", "phi0", "missing_case", "syntax", "binary",
                           "unicode_key", "zero_cells", "unknown_case"])
        d = _copy()
        if kind == "unknown_section":
            name = "x" + word()
            d[name] = {"a": 1}
            yield kind, dump(d), name
        elif kind == "unknown_key":
            sec = rng.choice(["grid", "material", "time", "output", "setup"])
            key = "q" + word()
            d[sec][key] = rng.choice([1, 0.5, "s"])
            yield kind, dump(d), f"{sec}.{key}"
        elif kind == "wrong_type":
            sec, key = rng.choice(NUMERIC_KEYS + INT_KEYS)
            d[sec][key] = rng.choice(["ten", [1, 2], "", "1e-3x"])
            yield kind, dump(d), f"{sec}.{key}"
        elif kind == "nan":
            sec, key = rng.choice(NUMERIC_KEYS)
            d[sec][key] = rng.choice([float("nan"), float("inf"), float("-inf")])
            yield kind, dump(d), f"{sec}.{key}"
        elif kind == "negative":
            sec, key = rng.choice(NUMERIC_KEYS)
            d[sec][key] = -abs(rng.uniform(1e-6, 10.0))
            yield kind, dump(d), f"{sec}.{key}"
        elif kind == "huge_grid":
            d["grid"]["nx"] = rng.randint(10**5, 10**7)
            d["grid"]["nz"] = rng.randint(10**3, 10**5)
            yield kind, dump(d), "grid"
        elif kind == "zero_cells":
            key = rng.choice(["nx", "nz"])
            d["grid"][key] = rng.choice([0, 1, -3])
            yield kind, dump(d), f"grid.{key}"
        elif kind == "unknown_closure":
            name = "no_such_" + word()
            d["closure"] = {"name": name}
            yield kind, dump(d), name
        elif kind == "closure_param":
            key = "z" + word()
            d["closure"][key] = 1.0
            yield kind, dump(d), key
        elif kind == "phi0":
            d["setup"]["phi0"] = rng.uniform(0.6001, 0.99)
            yield kind, dump(d), "phi0"
        elif kind == "missing_case":
            del d["case"]
            yield kind, dump(d), "case"
        elif kind == "unknown_case":
            name = "nocase_" + word()
            d["case"]["name"] = name
            yield kind, dump(d), name
        elif kind == "syntax":
            lines = dump(d).splitlines()
            at = rng.randrange(len(lines))
            lines.insert(at, rng.choice(["= = =", "[grid", "nx == 3", 'name = "unterminated', "[[", "a.b.c"]))
            yield kind, "\n".join(lines) + "\n", "line"
        elif kind == "binary":
            blob = bytes(rng.randrange(128, 256) for _ in range(rng.randint(1, 64)))
            yield kind, blob + BASE_TEXT.encode(), "UTF-8"
        elif kind == "unicode_key":
            key = "".join(rng.choice("αβγδεζηθλμπσφψω☃") for _ in range(rng.randint(1, 6)))
            text = dump(d) + f'\n[grid2]\n"{key}" = 1\n'
            yield kind, text, "grid2"


CASES = []
_gen = mutations(random.Random(SEED))
for _i in range(N_CASES):
    CASES.append(next(_gen))


def test_corpus_is_large_and_varied():
    assert len(CASES) >= 200
    assert len({k for k, _, _ in CASES}) >= 12


@pytest.mark.parametrize("i", range(N_CASES))
def test_malformed_case_file_exit_2_one_line(i, tmp_path, capsys):
    kind, content, needle = CASES[i]
    path = tmp_path / "case.toml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    out_dir = tmp_path / "out"
    code = main(["run", str(path), "--out", str(out_dir), "--quiet"])
    _, err = capsys.readouterr()
    assert code == 2, (kind, err)
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, (kind, err)
    assert needle in lines[0], (kind, needle, lines[0])
    assert not out_dir.exists(), "nothing may be written for bad input"
