"""Checkpoint / restart: bit-identical round trips, clear errors, atomic saves, exact restarts.

"Identical" means the same dtype, shape and bytes for arrays and the same IEEE-754 bit pattern for
float scalars (so NaN, -0.0 and subnormals count); tolerance zero throughout. The restart test uses
a chaotic toy stepper defined here (logistic map + neighbour averaging, state-dependent dt), for
which a one-ulp difference at the restart visibly changes the final state: the comparison can fail.
"""
from __future__ import annotations

import struct
import zipfile

import numpy as np
import pytest

import granflow
import granflow.output.checkpoint as ckpt
from granflow.errors import GranflowInputError
from granflow.output import (
    CheckpointError,
    CheckpointManager,
    load_checkpoint,
    save_checkpoint,
)


def same_bits(a, b) -> bool:
    """Exact identity of two scalars, bitwise for floats (NaN == NaN, -0.0 != 0.0)."""
    if isinstance(a, float) and isinstance(b, float):
        return struct.pack("<d", a) == struct.pack("<d", b)
    return type(a) is type(b) and a == b


def assert_identical_arrays(got: dict, want: dict) -> None:
    assert sorted(got) == sorted(want)
    for k, w in want.items():
        w = np.asarray(w)
        assert got[k].dtype == w.dtype, k
        assert got[k].shape == w.shape, k
        assert got[k].tobytes(order="A") == w.tobytes(order="A"), k


def odd_arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(12345)
    f8 = rng.standard_normal((7, 5))
    f8[0, :4] = [np.nan, -0.0, 5e-324, -np.inf]
    return {
        "f8": f8,
        "f4": rng.standard_normal(9).astype(np.float32),
        "f2": np.array([1.5, np.nan], dtype=np.float16),
        "big_endian": f8.astype(">f8"),
        "fortran": np.asfortranarray(rng.standard_normal((3, 4))),
        "i8": np.array([2**62, -(2**63)], dtype=np.int64),
        "u1": np.arange(5, dtype=np.uint8),
        "bool": np.array([True, False]),
        "c16": np.array([1 + 2j, np.nan - 0j]),
        "scalar0d": np.array(np.pi),
        "empty": np.empty((0, 3)),
        "nan_payload": np.array([0x7FF8_0000_DEAD_BEEF], dtype=np.uint64).view(np.float64),
    }


ODD_SCALARS = {"t": 0.1 + 0.2, "nan": float("nan"), "inf": float("-inf"), "neg0": -0.0,
               "tiny": 5e-324, "step": 2**62, "ok": True, "name": "φ run", "none": None}


def test_roundtrip_is_bit_identical(tmp_path):
    arrays = odd_arrays()
    path = save_checkpoint(tmp_path / "c.npz", arrays, ODD_SCALARS, {"case": "a = 1", "x": np.nan})
    got_arrays, got_scalars, meta = load_checkpoint(path)
    assert_identical_arrays(got_arrays, arrays)
    assert got_arrays["fortran"].flags.f_contiguous
    assert sorted(got_scalars) == sorted(ODD_SCALARS)
    for k, v in ODD_SCALARS.items():
        assert same_bits(got_scalars[k], v), k
    assert meta["case"] == "a = 1" and meta["x"] is None
    assert meta["granflow_version"] == granflow.__version__
    assert meta["checkpoint_schema"] == ckpt.SCHEMA_VERSION


def test_numpy_scalars_keep_their_value(tmp_path):
    s = {"f32": np.float32(0.1), "i": np.int16(-3), "b": np.bool_(True)}
    _, got, _ = load_checkpoint(save_checkpoint(tmp_path / "c.npz", {}, s))
    assert same_bits(got["f32"], float(np.float32(0.1))) and np.float32(got["f32"]) == s["f32"]
    assert got["i"] == -3 and got["b"] is True


def test_bad_inputs_are_refused(tmp_path):
    p = tmp_path / "c.npz"
    with pytest.raises(GranflowInputError, match="'o'.*object"):
        save_checkpoint(p, {"o": np.array([object()])})
    with pytest.raises(GranflowInputError, match="'s'"):
        save_checkpoint(p, {}, {"s": [1, 2]})
    with pytest.raises(GranflowInputError, match="granflow_version"):
        save_checkpoint(p, {}, meta={"granflow_version": "0"})
    with pytest.raises(GranflowInputError, match="__granflow_header__"):
        save_checkpoint(p, {ckpt.HEADER_KEY: np.zeros(1)})
    assert not p.exists()


def test_missing_and_corrupt_files(tmp_path):
    with pytest.raises(CheckpointError, match="does not exist"):
        load_checkpoint(tmp_path / "nope.npz")
    assert issubclass(CheckpointError, GranflowInputError)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"this is not a zip archive" * 10)
    with pytest.raises(CheckpointError, match="corrupt"):
        load_checkpoint(garbage)
    good = save_checkpoint(tmp_path / "good.npz", {"u": np.arange(1000.0)}, {"t": 1.0})
    data = good.read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="truncated.npz"):
        load_checkpoint(truncated)
    flipped = bytearray(data)
    flipped[200] ^= 0xFF  # inside the array data: the zip CRC check must catch it
    bad = tmp_path / "flipped.npz"
    bad.write_bytes(bytes(flipped))
    with pytest.raises(CheckpointError):
        load_checkpoint(bad)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, u=np.zeros(2))
    with pytest.raises(CheckpointError, match="not a granflow checkpoint"):
        load_checkpoint(foreign)


def test_newer_schema_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(ckpt, "SCHEMA_VERSION", ckpt.SCHEMA_VERSION + 1)
    p = save_checkpoint(tmp_path / "future.npz", {"u": np.zeros(2)})
    monkeypatch.undo()
    with pytest.raises(CheckpointError, match="schema"):
        load_checkpoint(p)


def test_failed_save_keeps_the_previous_checkpoint(tmp_path, monkeypatch):
    p = tmp_path / "c.npz"
    save_checkpoint(p, {"u": np.arange(3.0)}, {"t": 1.0})
    before = p.read_bytes()

    def savez_dies_midway(fh, **arrays):
        with zipfile.ZipFile(fh, "w") as z:
            z.writestr("u.npy", b"partial")
        raise MemoryError("killed while writing")

    monkeypatch.setattr(ckpt.np, "savez", savez_dies_midway)
    with pytest.raises(MemoryError):
        save_checkpoint(p, {"u": np.arange(4.0)}, {"t": 2.0})
    monkeypatch.undo()
    assert p.read_bytes() == before
    assert [q.name for q in tmp_path.iterdir()] == ["c.npz"]  # no temporary left


# ------------------------------------------------------------------------------ exact restart
R_LOGISTIC = 3.9  # chaotic regime of the logistic map
EPS = 0.2  # weight of the neighbour average
DT0 = 0.1  # nominal time step [s] (not a binary fraction: t accumulates rounding)


def toy_step(u: np.ndarray, v: np.ndarray, t: float, n: int):
    """One step of a deterministic, chaotic toy model (float64 u, float32 v, state-dependent dt)."""
    f = R_LOGISTIC * u * (1.0 - u)
    nb = 0.25 * (np.roll(f, 1, 0) + np.roll(f, -1, 0) + np.roll(f, 1, 1) + np.roll(f, -1, 1))
    u_new = (1.0 - EPS) * f + EPS * nb
    dt = DT0 / (1.0 + float(u_new.max()))
    v_new = v + np.float32(dt) * np.sin(u_new).astype(np.float32)
    return u_new, v_new, t + dt, n + 1


def initial_state():
    rng = np.random.default_rng(7)
    return rng.uniform(0.05, 0.95, (16, 12)), np.zeros((16, 12), np.float32), 0.0, 0


def run(state, n_steps):
    for _ in range(n_steps):
        state = toy_step(*state)
    return state


N_HALF = 40
EVERY = 10  # checkpoint period [steps]


def test_restart_reaches_the_same_state_bit_for_bit(tmp_path):
    u_ref, v_ref, t_ref, n_ref = run(initial_state(), 2 * N_HALF)

    manager = CheckpointManager(tmp_path / "ckpt", keep=2)
    state = initial_state()
    for _ in range(N_HALF // EVERY):  # the first run checkpoints periodically, then "dies"
        state = run(state, EVERY)
        u, v, t, n = state
        manager.save(n, {"u": u, "v": v}, {"t": t, "step": n}, {"case": "toy"})
    assert manager.steps() == [N_HALF - EVERY, N_HALF]  # keep=2 pruned the older ones
    del state, u, v, t, n

    arrays, scalars, meta = load_checkpoint(manager.latest())
    assert meta["case"] == "toy" and scalars["step"] == N_HALF
    u, v, t, n = run((arrays["u"], arrays["v"], scalars["t"], scalars["step"]), N_HALF)
    assert_identical_arrays({"u": u, "v": v}, {"u": u_ref, "v": v_ref})
    assert same_bits(t, t_ref) and n == n_ref == 2 * N_HALF

    # the comparison is sensitive: a restart from a state one ulp away ends elsewhere
    u1 = np.nextafter(arrays["u"], 1.0)
    u_bad, _, _, _ = run((u1, arrays["v"], scalars["t"], scalars["step"]), N_HALF)
    assert u_bad.tobytes() != u_ref.tobytes()


def test_manager_paths_and_validation(tmp_path):
    m = CheckpointManager(tmp_path, keep=None)
    assert m.latest() is None and m.steps() == []
    for step in (0, 5, 12):
        m.save(step, {"u": np.full(2, float(step))})
    (tmp_path / "checkpoint_notanumber.npz").write_bytes(b"")
    assert m.steps() == [0, 5, 12]
    assert m.latest() == tmp_path / "checkpoint_00000012.npz"
    assert load_checkpoint(m.latest())[0]["u"][0] == 12.0
    with pytest.raises(GranflowInputError, match="keep"):
        CheckpointManager(tmp_path, keep=0)
