"""``Simulation`` accepts any object with the model interface (issue 18 item 4):
:class:`granflow.simulation.SteppingModel` is a :class:`typing.Protocol`, checked instead of
``isinstance(model, Model)``. A model that is not a Model subclass -- here a wrapper delegating to
one -- runs bit-identically to the Model it wraps; an object without the interface is refused,
naming what it lacks."""
from __future__ import annotations

import typing

import numpy as np
import pytest

from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import MODEL_INTERFACE, Simulation, SteppingModel
from granflow.state import State


class Delegating:
    """Not a Model: forwards every attribute to the Model it holds."""

    def __init__(self, model: Model) -> None:
        self._model = model

    def __getattr__(self, name: str):
        return getattr(self._model, name)


def _collapse() -> tuple[Model, State]:
    g = Grid(nx=8, nz=6, Lx=0.08, Lz=0.06)
    model = Model(g, make_closure("mu_i"))
    X, Z = g.cell_coords()
    return model, model.initial_state(np.where((X < 0.03) & (Z < 0.04), 0.6, 0.0))


def test_the_interface_names_the_protocol_members():
    assert set(MODEL_INTERFACE) == set(typing._get_protocol_attrs(SteppingModel))
    model, _ = _collapse()
    assert isinstance(model, SteppingModel)


def test_a_model_that_is_not_a_model_subclass_runs_bit_identically():
    model, state = _collapse()
    wrapped, wrapped_state = _collapse()
    duck = Delegating(wrapped)
    assert not isinstance(duck, Model) and isinstance(duck, SteppingModel)
    runs = [Simulation(m, s, stop_time=1.0, max_steps=3) for m, s in ((model, state), (duck, wrapped_state))]
    for sim in runs:
        sim.run()
    assert state.step == wrapped_state.step == 3
    for name in ("phi", "vel", "p", "c"):
        assert np.array_equal(getattr(state, name), getattr(wrapped_state, name)), name


def test_an_object_without_the_interface_is_refused_naming_what_it_lacks():
    model, state = _collapse()

    class NoAdvance:
        grid, gravity, material, gas = model.grid, model.gravity, model.material, None

        def inertia_density(self, phi):
            return model.inertia_density(phi)

    with pytest.raises(GranflowInputError, match="model interface.*NoAdvance without advance$"):
        Simulation(NoAdvance(), state, stop_time=1.0)
    with pytest.raises(GranflowInputError, match="without " + ", ".join(MODEL_INTERFACE) + "$"):
        Simulation(object(), state, stop_time=1.0)
