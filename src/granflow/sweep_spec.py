"""Sweep definitions: a base configuration, the swept parameters and how to combine them
(:class:`SweepSpec`), split from :mod:`granflow.sweep` (which re-exports every name here).

A :class:`SweepSpec` holds a base configuration (the nested dict of a case file) and, for dotted
keys such as ``"material.d"``, either a list of ``values``, a ``range`` ``[lo, hi]`` with ``n``
points (linspace) or, in ``"lhs"`` mode, an interval ``lhs = [lo, hi]`` sampled by a Latin
hypercube of ``samples`` points with a fixed ``seed`` (McKay, Beckman & Conover 1979,
Technometrics 21, 239). ``mode = "grid"`` takes the cartesian product, ``"zip"`` pairs
equal-length lists. :meth:`SweepSpec.members` gives deterministic ids ``m0000, m0001, ...``, so a
sweep can be re-run to finish it.
"""
from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from pydantic import Field, ValidationError, model_validator

from granflow.errors import GranflowInputError
from granflow.params import Params, format_validation_error
from granflow.safe_toml import MAX_NESTING

MAX_MEMBERS = 10_000
"""Most members of one sweep (a guard against ``n = 1000000000``, which never finished making the
member list); split a larger study into several sweeps."""
#: Minimum number of digits of member ids (m0000).
ID_DIGITS = 4
ID_PREFIX = "m"
#: Separator of nested keys (overrides and flattened summaries).
KEY_SEP = "."


class ParameterRange(Params):
    """One swept parameter: exactly one of ``values``, ``range`` (+ ``n``) or ``lhs``."""

    values: list[Any] | None = Field(default=None, min_length=1)
    range: tuple[float, float] | None = None
    n: int | None = Field(default=None, ge=1, le=MAX_MEMBERS)
    lhs: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _one_kind(self) -> ParameterRange:
        kinds = [k for k in ("values", "range", "lhs") if getattr(self, k) is not None]
        if len(kinds) != 1:
            raise ValueError("give exactly one of 'values', 'range' (with 'n') or 'lhs'")
        if (self.range is None) != (self.n is None):
            raise ValueError("'range' and 'n' go together")
        interval = self.range or self.lhs
        if interval is not None and not interval[0] < interval[1]:
            raise ValueError(f"interval must have lo < hi, got {list(interval)}")
        return self

    def points(self) -> list[Any]:
        """The values of a ``values`` or ``range`` parameter (``range``: n points, ends included)."""
        if self.values is not None:
            return list(self.values)
        if self.range is not None:
            return [float(v) for v in np.linspace(self.range[0], self.range[1], self.n)]
        raise GranflowInputError("an 'lhs' parameter has no fixed points; use mode = 'lhs'")


class SweepSpec(Params):
    """A sweep: base configuration, swept parameters (dotted keys) and how to combine them.

    Parameters
    ----------
    base : dict
        The base configuration (e.g. a parsed case file).
    parameters : dict
        ``"a.b" -> {"values": [...]}``, ``{"range": [lo, hi], "n": k}`` or ``{"lhs": [lo, hi]}``.
    mode : {"grid", "zip", "lhs"}
        Cartesian product, element-wise pairing (equal lengths), or Latin hypercube.
    samples, seed : int
        Number of Latin-hypercube members and the seed; both required in ``"lhs"`` mode (a fixed
        seed makes member ids stable, which re-running a sweep relies on).

    Examples
    --------
    >>> spec = SweepSpec.from_dict({"base": {"material": {"d": 7e-5}},
    ...     "parameters": {"material.d": {"values": [6e-5, 8e-5]}, "slope": {"range": [0, 10], "n": 2}}})
    >>> [(m, o["slope"]) for m, o in spec.members()]
    [('m0000', 0.0), ('m0001', 10.0), ('m0002', 0.0), ('m0003', 10.0)]
    """

    base: dict[str, Any] = Field(default_factory=dict)
    parameters: dict[str, ParameterRange] = Field(min_length=1)
    mode: Literal["grid", "zip", "lhs"] = "grid"
    samples: int | None = Field(default=None, ge=1, le=MAX_MEMBERS)
    seed: int | None = Field(default=None, ge=0)

    @model_validator(mode="after")
    def _consistent(self) -> SweepSpec:
        is_lhs = {k: p.lhs is not None for k, p in self.parameters.items()}
        if self.mode == "lhs":
            if not all(is_lhs.values()):
                raise ValueError(f"mode 'lhs': every parameter needs 'lhs = [lo, hi]', not "
                                 f"{[k for k, v in is_lhs.items() if not v]}")
            if self.samples is None or self.seed is None:
                raise ValueError("mode 'lhs' needs 'samples' and 'seed'")
        else:
            if any(is_lhs.values()):
                raise ValueError(f"'lhs' parameters {[k for k, v in is_lhs.items() if v]} need "
                                 "mode = 'lhs'")
            if self.samples is not None or self.seed is not None:
                raise ValueError("'samples' and 'seed' apply to mode 'lhs' only")
        if self.mode == "grid":
            count = math.prod(len(p.values) if p.values is not None else p.n
                              for p in self.parameters.values())
            if count > MAX_MEMBERS:
                raise ValueError(f"mode 'grid' makes {count} members, more than {MAX_MEMBERS} "
                                 "(granflow.sweep.MAX_MEMBERS); split the sweep")
        if self.mode == "zip":
            lengths = {k: len(p.points()) for k, p in self.parameters.items()}
            if len(set(lengths.values())) != 1:
                raise ValueError(f"mode 'zip' needs equally long parameter lists, got {lengths}")
        for key in self.parameters:
            if not all(key.split(KEY_SEP)):
                raise ValueError(f"bad parameter key {key!r}")
            if len(key.split(KEY_SEP)) > MAX_NESTING:
                raise ValueError(f"parameter key {key[:40]!r}... of {len(key.split(KEY_SEP))} parts; "
                                 f"tables are nested at most {MAX_NESTING} levels deep")
            apply_overrides(self.base, {key: None})  # unknown section -> error now, not per member
        return self

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepSpec:
        """Validate ``data`` (e.g. a parsed ``[sweep]`` TOML table); errors name the key."""
        try:
            return cls.model_validate(dict(data))
        except ValidationError as err:
            raise GranflowInputError(format_validation_error(err, "sweep")) from None

    def _lhs_points(self) -> list[dict[str, float]]:
        from scipy.stats import qmc  # scipy.stats is slow to import; only needed here

        d = len(self.parameters)
        try:
            sampler = qmc.LatinHypercube(d=d, rng=self.seed)
        except TypeError:  # scipy < 1.15 calls it seed
            sampler = qmc.LatinHypercube(d=d, seed=self.seed)
        unit = sampler.random(self.samples)
        lo = np.array([p.lhs[0] for p in self.parameters.values()])
        hi = np.array([p.lhs[1] for p in self.parameters.values()])
        pts = qmc.scale(unit, lo, hi)
        return [{k: float(row[j]) for j, k in enumerate(self.parameters)} for row in pts]

    def members(self) -> list[tuple[str, dict[str, Any]]]:
        """``(member_id, overrides)`` for every member, in a deterministic order."""
        keys = list(self.parameters)
        if self.mode == "lhs":
            combos = self._lhs_points()
        else:
            lists = [self.parameters[k].points() for k in keys]
            rows = itertools.product(*lists) if self.mode == "grid" else zip(*lists, strict=True)
            combos = [dict(zip(keys, row, strict=True)) for row in rows]
        width = max(ID_DIGITS, len(str(len(combos) - 1)))
        return [(f"{ID_PREFIX}{i:0{width}d}", c) for i, c in enumerate(combos)]

    def config(self, overrides: Mapping[str, Any]) -> dict[str, Any]:
        """The base configuration with ``overrides`` applied (see :func:`apply_overrides`)."""
        return apply_overrides(self.base, overrides)


def apply_overrides(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """A deep copy of ``base`` with dotted keys set: ``{"material.d": 1e-4}``.

    Missing intermediate tables are created. If ``base`` has sections (dict values), the section
    of a dotted key (its first component) must be one of them, so that a misspelt section is an
    error naming it. Other keys (undotted new keys, deeper keys) are checked by the case's own
    strict configuration when the member runs, not here.

    Raises
    ------
    GranflowInputError
        For an unknown top-level section, or a key that descends into a non-table value.
    """
    out = copy.deepcopy(dict(base))
    has_sections = any(isinstance(v, Mapping) for v in out.values())
    for key, value in overrides.items():
        parts = key.split(KEY_SEP)
        if has_sections and len(parts) > 1 and parts[0] not in out:
            raise GranflowInputError(f"override {key!r}: unknown section {parts[0]!r}; base has "
                                     f"{sorted(out)}")
        node = out
        for i, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise GranflowInputError(f"override {key!r}: {KEY_SEP.join(parts[:i + 1])!r} "
                                         "is not a table")
        node[parts[-1]] = copy.deepcopy(value)
    return out
