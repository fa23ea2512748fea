"""Output writers, diagnostics recorders and checkpointers on a Simulation (issue 18 item 2):
bad input names the key and the value, entries sharing a schedule run together, a run that fails
mid-way leaves a readable file and a checkpoint, and a script-level restart from that checkpoint
writes the same file, bit for bit, as the uninterrupted run."""
from __future__ import annotations

import netCDF4
import numpy as np
import pytest

from granflow import make_closure
from granflow.errors import GranflowInputError
from granflow.grid import Grid
from granflow.model import Model
from granflow.output import (
    BasalProbes,
    Checkpointer,
    FrontRecorder,
    NetCDFOutputWriter,
    Output,
    RestDetector,
    VariableSpec,
    field_outputs,
    front_output,
    kinetic_energy_output,
    load_checkpoint,
)
from granflow.simulation import IterationInterval, Simulation, TimeInterval

STOP = 0.02
"""Simulated time of the test runs [s] (about 20 steps of dt_max = 1e-3 s)."""
INTERVAL = 0.004
"""Record interval [s]."""
THRESHOLD = 0.004
"""Front threshold [m]."""
FAIL_AT_STEP = 9


def collapse(stop_time: float = STOP) -> Simulation:
    """A dry 4 cm column in a 12 x 5 cell box."""
    grid = Grid(nx=12, nz=5, Lx=0.12, Lz=0.05)
    model = Model(grid, make_closure("drucker_prager"))
    column = (grid.xc[:, None] < 0.04) & (grid.zc[None, :] < 0.04)
    return Simulation(model, model.initial_state(np.where(column, model.material.phi_max, 0.0)),
                      stop_time=stop_time)


def wire(sim: Simulation, directory, interval: float = INTERVAL) -> tuple[NetCDFOutputWriter, FrontRecorder]:
    """The writer, front recorder and checkpointer of these tests."""
    outputs = {**field_outputs(sim.model, ["phi", "u", "p"]), "kinetic_energy": kinetic_energy_output(),
               "x_front": front_output(THRESHOLD)}
    writer = NetCDFOutputWriter(sim.model, directory / "out.nc", outputs, TimeInterval(interval))
    front = FrontRecorder(THRESHOLD, writer=writer)
    sim.output_writers["fields"] = writer
    sim.diagnostics["front"] = front
    sim.checkpointers["checkpoint"] = Checkpointer(directory / "checkpoints", IterationInterval(5))
    return writer, front


def read(path) -> dict[str, np.ndarray]:
    with netCDF4.Dataset(path) as ds:
        return {name: np.array(var[:]) for name, var in ds.variables.items()}


# --- bad input ---------------------------------------------------------------------------------
def test_an_entry_without_a_schedule_is_refused_naming_key_and_value(tmp_path):
    sim = collapse()
    with pytest.raises(GranflowInputError, match=r"output_writers\['fields'\].*schedule.*None"):
        sim.output_writers["fields"] = object()
    with pytest.raises(GranflowInputError, match=r"NetCDFOutputWriter: schedule .* got 0\.1"):
        NetCDFOutputWriter(sim.model, tmp_path / "x.nc", field_outputs(sim.model), schedule=0.1)
    not_callable = type("NotCallable", (), {"schedule": IterationInterval(1)})()
    with pytest.raises(GranflowInputError, match=r"diagnostics\['rest'\].*not callable"):
        sim.diagnostics["rest"] = not_callable
    with pytest.raises(GranflowInputError, match=r"checkpointers\[''\]"):
        sim.checkpointers[""] = Checkpointer(tmp_path, IterationInterval(1))
    with pytest.raises(GranflowInputError, match="callback 'p'.*got 5"):
        sim.add_callback(print, 5, name="p")
    assert len(sim.output_writers) == len(sim.diagnostics) == len(sim.checkpointers) == len(sim.callbacks) == 0


@pytest.mark.parametrize("make, match", [
    (lambda m, p: field_outputs(m, ["phi", "vorticity"]), "'vorticity'"),
    (lambda m, p: Output(3.0, VariableSpec(("time",), "m", "x")), "values must be callable.*3.0"),
    (lambda m, p: NetCDFOutputWriter(m, p, {"h": np.ones(3)}, TimeInterval(1.0)), r"outputs\['h'\]"),
    (lambda m, p: Checkpointer(p, IterationInterval(1), keep=0), "keep .* got 0"),
    (lambda m, p: TimeInterval(-1.0), "interval .* got -1.0"),
    (lambda m, p: IterationInterval(True), "got True"),
    (lambda m, p: FrontRecorder(0.0, IterationInterval(1)), "threshold .* got 0.0"),
    (lambda m, p: RestDetector(1e-3, "every step"), "RestDetector: schedule .* 'every step'"),
], ids=["field", "output", "writer-outputs", "keep", "interval", "iterations", "threshold", "rest"])
def test_bad_writer_and_recorder_arguments(tmp_path, make, match):
    with pytest.raises(GranflowInputError, match=match):
        make(collapse().model, tmp_path / "x.nc")


def test_two_recorders_writing_the_same_checkpoint_keys_are_refused(tmp_path):
    sim = collapse()
    sim.diagnostics["front"] = FrontRecorder(THRESHOLD, IterationInterval(1))
    sim.diagnostics["front2"] = FrontRecorder(2 * THRESHOLD, IterationInterval(1))
    with pytest.raises(GranflowInputError, match="'front2' writes checkpoint entries.*run.front_t"):
        sim.checkpoint_payload()


def test_two_time_schedules_with_one_name_are_refused():
    sim = collapse()
    sim.add_callback(lambda s: None, TimeInterval(0.01), name="fields")
    sim.diagnostics["fields"] = FrontRecorder(THRESHOLD, TimeInterval(0.002))
    with pytest.raises(GranflowInputError, match="two time schedules are named 'fields'"):
        sim.checkpoint_payload()


# --- schedules ---------------------------------------------------------------------------------
def test_entries_sharing_a_schedule_run_at_the_same_times(tmp_path):
    sim = collapse()
    shared = TimeInterval(INTERVAL)
    seen_a, seen_b = [], []
    sim.add_callback(lambda s: seen_a.append(s.state.t), shared, name="a")
    sim.add_callback(lambda s: seen_b.append(s.state.t), shared, name="b")
    writer, front = wire(sim, tmp_path)
    sim.run()
    sim.close()
    times = read(tmp_path / "out.nc")["time"]
    assert seen_a == seen_b and len(seen_a) == round(STOP / INTERVAL) + 1  # a second entry is not starved
    np.testing.assert_array_equal(front.t, times)
    np.testing.assert_array_equal(front.x, read(tmp_path / "out.nc")["x_front"])


def test_a_completed_run_ends_with_its_final_state_an_interrupted_one_does_not(tmp_path):
    done = collapse(stop_time=0.011)
    wire(done, tmp_path / "a")
    done.run()
    done.close()
    np.testing.assert_allclose(read(tmp_path / "a" / "out.nc")["time"], [0, .004, .008, .011], atol=1e-12)
    stopped = collapse(stop_time=0.011)
    wire(stopped, tmp_path / "b")
    stopped.add_callback(lambda s: s.request_stop("test") if s.state.t > 0.009 else None,
                         IterationInterval(1), name="stop")
    stopped.run()
    stopped.close()
    np.testing.assert_allclose(read(tmp_path / "b" / "out.nc")["time"], [0, .004, .008], atol=1e-12)
    ckpt = Checkpointer(tmp_path / "b" / "checkpoints", IterationInterval(1)).manager.latest()
    assert load_checkpoint(ckpt)[1]["state.step"] == stopped.state.step  # the last accepted state


# --- failure and restart -----------------------------------------------------------------------
def test_a_failing_run_leaves_its_file_and_a_checkpoint_and_restarts_bit_for_bit(tmp_path):
    reference = collapse()
    wire(reference, tmp_path / "ref")
    reference.run()
    reference.close()
    expected = read(tmp_path / "ref" / "out.nc")

    failing = collapse()
    writer, _ = wire(failing, tmp_path / "run")
    advance = failing.model.advance

    def advance_then_fail(state, dt):
        if state.step + 1 == FAIL_AT_STEP:
            raise RuntimeError("disk on fire")
        return advance(state, dt)

    failing.model.advance = advance_then_fail
    with pytest.raises(RuntimeError, match="disk on fire"):
        failing.run()
    t_failed = failing.state.t
    partial = read(tmp_path / "run" / "out.nc")  # readable while the writer is still open
    assert 0 < partial["time"].size < expected["time"].size and partial["time"][-1] <= t_failed
    ckpt = Checkpointer(tmp_path / "run" / "checkpoints", IterationInterval(1)).manager.latest()
    arrays, scalars, _ = load_checkpoint(ckpt)
    assert scalars["state.step"] == FAIL_AT_STEP - 1 and scalars["state.t"] == t_failed
    writer.close()

    restarted = collapse()
    wire(restarted, tmp_path / "run")
    restarted.restore_checkpoint(arrays, scalars)
    restarted.run()
    restarted.close()
    got = read(tmp_path / "run" / "out.nc")
    assert sorted(got) == sorted(expected)
    for name in expected:
        np.testing.assert_array_equal(got[name], expected[name], err_msg=name)
    assert restarted.diagnostics["front"].t == reference.diagnostics["front"].t


def test_basal_probes_record_their_history_and_restore_it(tmp_path):
    sim = collapse()
    every_3 = IterationInterval(3)
    probes = BasalProbes(sim.model.grid, [0.015, 0.11], schedule=every_3)
    sim.diagnostics["probes"] = probes
    bottom = []
    sim.add_callback(lambda s: bottom.append(s.state.p[:, 0].copy()), every_3, name="bottom")
    sim.run()
    steps = len(sim.reports)
    assert len(probes.t) == len(bottom) == steps // 3 + 1 and probes.t[0] == 0.0
    np.testing.assert_array_equal(np.array(probes.p), np.array(bottom)[:, [1, 11]])
    assert probes.cells.tolist() == [1, 11] and probes.p[0][0] > 0 and probes.p[0][1] == 0  # column, ambient
    arrays, scalars = sim.checkpoint_payload()
    again = BasalProbes(sim.model.grid, [0.015, 0.11], schedule=IterationInterval(3))
    fresh = collapse()
    fresh.diagnostics["probes"] = again
    fresh.restore_checkpoint(arrays, scalars)
    assert again.t == probes.t
    np.testing.assert_array_equal(np.array(again.p_f), np.array(probes.p_f))
    np.testing.assert_array_equal(np.array(again.p), np.array(probes.p))
    with pytest.raises(GranflowInputError, match=r"diagnostics\['probes'\].*schedule.*None"):
        collapse().diagnostics["probes"] = BasalProbes(sim.model.grid, [0.01])


def test_a_checkpoint_from_before_the_linear_solve_terms_restores_them_as_zero():
    """Checkpoints written before session 26 hold no ``budget.numerical.linear_solve`` nor
    ``gas_linear_solve`` (simulation.LATER_BUDGET_FIELDS): they restart from 0; any other missing
    budget term is still an error naming it."""
    sim = collapse(stop_time=0.004)
    sim.run()
    arrays, scalars = sim.checkpoint_payload()
    old = {k: v for k, v in scalars.items() if not k.endswith("linear_solve")}
    assert len(old) == len(scalars) - 2
    restarted = collapse()
    restarted.restore_checkpoint(arrays, old)
    assert restarted.budget.numerical["linear_solve"] == restarted.budget.numerical["gas_linear_solve"] == 0.0
    assert restarted.budget.numerical["advection"] == sim.budget.numerical["advection"] != 0.0
    broken = {k: v for k, v in scalars.items() if k != "budget.numerical.advection"}
    with pytest.raises(GranflowInputError, match="budget.numerical.advection"):
        collapse().restore_checkpoint(arrays, broken)
