"""Sections of the case file that stand alone (the base :class:`Section`, ``[inflow]``,
``[topography]``); the rest of the schema and :class:`granflow.config.schema.CaseConfig` are in
:mod:`granflow.config.schema`, which re-exports these."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator


class Section(BaseModel):
    """Base of every section: frozen, unknown keys forbidden, no type coercion, finite numbers."""

    model_config = ConfigDict(frozen=True, extra="forbid", strict=True, allow_inf_nan=False,
                              validate_default=True)


class InflowSection(Section):
    """``[inflow]``: a supply of grains through part of the west wall or of the base
    (:mod:`granflow.physics.inflow`); off unless ``side`` is set."""

    side: Literal["none", "west", "bottom"] = Field(
        "none", description='where the grains enter: "none" (no source), "west" (the west wall, over '
        'lower <= z <= upper) or "bottom" (the base, over lower <= x <= upper) [-]')
    lower: float = Field(0.0, ge=0, description="start of the source's span along its side [m]")
    upper: float | None = Field(None, gt=0, description="end of the source's span along its side (needed "
                                "with a source) [m]")
    phi: float | None = Field(None, gt=0, description="solid fraction of the incoming grains, at most "
                              "material.phi_max (default: material.phi_max) [-]")
    speed: float | None = Field(None, gt=0, description="velocity of the incoming grains into the box "
                                "(needed with a source) [m s^-1]")
    start: float = Field(0.0, ge=0, description="the source is on from this time [s]")
    stop: float | None = Field(None, gt=0, description="... until this time (default: the whole run) [s]")

    @model_validator(mode="after")
    def _complete(self) -> InflowSection:
        if self.side == "none":
            given = sorted(k for k in self.model_fields_set  # (an effective file repeats the defaults)
                           if k != "side" and getattr(self, k) != type(self).model_fields[k].default)
            if given:
                raise ValueError(f"inflow.{given[0]} is set but inflow.side is \"none\" (no source): set "
                                 f"inflow.side (\"west\" or \"bottom\") or remove {', '.join('inflow.' + k for k in given)}")
            return self
        for key in ("upper", "speed"):
            if getattr(self, key) is None:
                raise ValueError(f'inflow.side = "{self.side}" needs inflow.{key}')
        if not self.lower < self.upper:
            raise ValueError(f"inflow.lower = {self.lower:g} must be below inflow.upper = {self.upper:g}")
        if self.stop is not None and not self.start < self.stop:
            raise ValueError(f"inflow.start = {self.start:g} must be before inflow.stop = {self.stop:g}")
        return self


class TopographySection(Section):
    """``[topography]``: a base profile z_b(x) through the points (x, z), linear between them and
    level beyond; the cells below it are solid (granflow.topography). Empty: the flat base."""

    x: list[float] = Field(default_factory=list, description="abscissae of the profile's points, "
                           "strictly increasing [m]")
    z: list[float] = Field(default_factory=list, description="base height at each x [m]")
    file: str | None = Field(None, description="CSV file of two columns x, z [m] (a header line is "
                             "allowed), relative to the case file; read when the file is loaded, the "
                             "effective configuration then lists the points [-]")

    @model_validator(mode="after")
    def _points(self) -> TopographySection:
        if self.file is not None and (self.x or self.z):
            raise ValueError("give the profile either as topography.x and topography.z or as "
                             "topography.file, not both")
        if len(self.x) != len(self.z):
            raise ValueError(f"topography.x and topography.z must have the same length "
                             f"(got {len(self.x)} and {len(self.z)})")
        if any(b <= a for a, b in zip(self.x, self.x[1:])):
            raise ValueError(f"topography.x must be strictly increasing (got {self.x})")
        return self
