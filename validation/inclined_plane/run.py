"""Steady flow down an infinite incline: the solver against the exact Bagnold solution.

Verification items 9c and 9d of issue 3 (docs/model.md §7, NUMERICS.md §11 item 3). A granular layer
of thickness h0 = 1 cm on a grid periodic in x (4 columns of 25 cm: the flow is uniform, the x
extent only sets the advective CFL), no-slip base, pressureless ambient above (2-3 cells), gravity
g (sin theta, -cos theta), mu(I) closure with its dilatancy law (mu1 = tan 21 deg, mu2 = tan 33 deg,
I0 = 0.3; phi_eq = phi_max - delta_phi I, phi_max = 0.6, delta_phi = 0.2; d = 0.5 mm,
rho_s = 2500 kg/m^3). Exact steady state (derived in tests/integration/test_inclined_plane.py):

    mu(I_theta) = tan(theta) / (1 - beta),   phi = phi_eq(I_theta),
    p = (1 - beta) phi rho_s g cos(theta) (h - z),
    u(z) = 4 I_theta / (3 c_I d) sqrt((1 - beta) phi g cos(theta)) [h^(3/2) - (h - z)^(3/2)],

with beta = 0 for the dry layer (theta = 25 deg) and beta = 0.15 for the fluidised chute
(theta = 22 deg; base gas injection U = beta U_mf, U_mf = kappa phi rho_s g cos(theta), p_f = 0 at
the bed surface, so p_f = beta x lithostatic). The runs start from the exact state (cell-aligned
surface) and are integrated with granflow.simulation.Simulation (dt <= 0.05 s, the default CFL number) to
t = 20 s (relaxation time ~2 s). The surface velocity is the u of the top row of x-faces (the
stress-free ambient moves with the surface). Model options: see tests/integration/test_inclined_plane.py and
the README (their effect is measured by ``--options``).

Run:   python validation/inclined_plane/run.py [--quick] [--options]
Time:  ~2.5 min on one core (``--quick``: nz = 10 to t = 3 s, < 2 s, smoke test;
       ``--options``: + ~1 min).
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from granflow.grid import Grid
from granflow.model import Model
from granflow.rheology import make_closure
from granflow.simulation import Simulation, StepFailure, TimeInterval
from granflow.verification.bagnold import BagnoldLayer, steady_inertial_number

HERE = Path(__file__).resolve().parent
FIGURE = HERE / "profiles.png"
G = 9.81
RHO_S = 2500.0
PHI_MAX = 0.6
DELTA_PHI = 0.2
D = 5e-4
MU1, MU2, I0 = math.tan(math.radians(21.0)), math.tan(math.radians(33.0)), 0.3
H0 = 0.01
NX, LX = 4, 1.0
N_AMBIENT = 2
T_END = 20.0
QUICK_T_END = 3.0
DT_MAX = 0.05
RECORD = 1.0
LEVELS = (10, 20, 40, 80, 160)
FLUID_LEVELS = (10, 20, 40, 80)
DRY = {"theta_deg": 25.0, "beta": 0.0}
FLUIDISED = {"theta_deg": 22.0, "beta": 0.15}
OPTIONS: dict = {}
"""Model options of the main tables: none (the defaults, scheme v2: indicator surface, consistent
momentum transport)."""
V1 = {"surface": "threshold", "advection": "upwind"}
V1_LOOP = {"picard": {"max_sweeps": 10, "predictor": "previous"}}
"""The converged Picard loop the v1 options were measured with (the defaults until session 25; with
one solve per step, ``interface_packing = True`` and ``gravity_blend_velocity = None`` leave the
layer unsteady, +60 % and +57 % on u_s: README "Session 25")."""
V1_OPTIONS = {**V1, **V1_LOOP, "delta_p": 1e-3, "ambient": {"eta_a": 1e-4, "velocity_band_margin": 0},
              "interface_packing": False,
              "gravity_blend_velocity": 0.01, "isochoric_interface": 0}  # the top cells must dilate
"""The v1 (threshold surface) scheme with the four surface options its Bagnold match needed."""
DEFAULT_OPTIONS = {"delta_p": 1.0, "ambient": {"eta_a": 1e-3, "velocity_band_margin": 0}, "interface_packing": True,
                   "gravity_blend_velocity": None, "isochoric_interface": 0}  # the v1 defaults
OPTIONS_LEVEL = 40
REST_CASES = ((22.0, 0.0), (25.0, 0.0), (28.0, 0.0), (22.0, 0.15), (25.0, 0.15), (28.0, 0.05))
"""(theta [deg], beta) of the from-rest table (issue 12 acceptance 2); beta = 0.15 at 28 deg has
no steady packing (I_theta = 3.0, phi_eq < 0: refused by the case), hence 0.05 there."""
REST_LEVELS = (20, 40)
REST_T_END = {(28.0, 0.05): 25.0}
"""Longer runs for the rows that relax more slowly [s]: with one solve per step (the defaults since
session 25) the 28 deg, beta = 0.05 layer is still accelerating at 20 s (session 22's preview,
docs/solver.md)."""
REST_HEADROOM = 1.3
"""Box height over h0 of the from-rest runs (the layer dilates from phi_max by up to 25 %)."""
STEADY_WINDOW = 2.0
"""Drift = peak-to-peak of u_s over the last STEADY_WINDOW seconds / u_s [s]."""


def inertial_number(theta_deg: float, beta: float) -> float:
    """I with mu(I) = tan(theta)/(1 - beta) (:func:`granflow.verification.bagnold.steady_inertial_number`)."""
    mu = math.tan(math.radians(theta_deg)) / (1.0 - beta)
    return steady_inertial_number(mu, MU1, MU2, I0)


def packing(theta_deg: float, beta: float) -> float:
    return PHI_MAX - DELTA_PHI * inertial_number(theta_deg, beta)


def bagnold(z, c_I: float, theta_deg: float, beta: float, h: float = H0):
    """Exact velocity [m/s] at height z (:class:`granflow.verification.bagnold.BagnoldLayer`,
    the case's definition)."""
    I = inertial_number(theta_deg, beta)
    layer = BagnoldLayer(theta=math.radians(theta_deg), beta=beta, I=I, phi=PHI_MAX - DELTA_PHI * I,
                         h=h, c_I=c_I, d=D, g=G)
    return layer.velocity(z)


def build(nz: int, c_I: float, theta_deg: float, beta: float, options: dict):
    """Model and exact initial state of one level."""
    th = math.radians(theta_deg)
    phi0 = packing(theta_deg, beta)
    g = Grid(nx=NX, nz=nz + N_AMBIENT, Lx=LX, Lz=H0 / nz * (nz + N_AMBIENT), periodic_x=True)
    clo = make_closure("mu_i", material={"d": D, "rho_s": RHO_S, "phi_max": PHI_MAX,
                                         "delta_phi": DELTA_PHI, "c_I": c_I},
                       mu1=MU1, mu2=MU2, I0=I0)
    gas = {}
    if beta:
        u_mf = float(clo.material.permeability(phi0)) * phi0 * RHO_S * G * math.cos(th)
        gas = {"gas": "linear", "U_inj": beta * u_mf}
    model = Model(g, clo, gravity=(G * math.sin(th), -G * math.cos(th)),
                  **{k: v for k, v in {**options, **gas}.items() if v is not None})
    phi = np.where(g.cell_coords()[1] < H0, phi0, 0.0)
    state = model.initial_state(phi, p_f=beta * model.lithostatic_pressure(phi))
    state.vel = g.pack_velocity(bagnold(g.xface_coords()[1], c_I, theta_deg, beta),
                                np.zeros(g.zface_shape))
    return model, state


def run(resolution: int, quick: bool = False, c_I: float = 2.0, theta_deg: float = DRY["theta_deg"],
        beta: float = DRY["beta"], options: dict | None = None) -> dict:
    """One level: ``resolution`` cells over h0. Returns errors relative to the exact solution.

    Keys: ``err_us`` (surface velocity, relative), ``err_profile`` (max |u - u_exact| / u_s over
    the layer's x-faces), ``dphi`` (median phi - phi_eq), ``err_p`` (max |p - p_exact| / p_base),
    ``drift`` (relative change of u_s over the last 2 s), ``dust`` (grains above the surface, in
    cells), ``steps``, ``wall`` [s], ``z``, ``u``, ``phi``, ``p`` (column 0 profiles) and
    ``failure`` (message of a StepFailure, else "").
    """
    t_end = QUICK_T_END if quick else T_END
    model, state = build(resolution, c_I, theta_deg, beta, OPTIONS if options is None else options)
    g = model.grid
    history = []
    sim = Simulation(model, state, stop_time=t_end, dt_max=DT_MAX)
    sim.add_callback(lambda s: history.append(float(g.unpack_velocity(s.state.vel)[0][0, -1])),
                     TimeInterval(RECORD))
    t0 = time.perf_counter()
    failure = ""
    try:
        sim.run()
    except StepFailure as err:
        failure = f"t = {sim.state.t:.2f} s: {str(err)[:120]}"
    wall = time.perf_counter() - t0
    nz = resolution
    u = g.unpack_velocity(sim.state.vel)[0][0]
    u_s = float(bagnold(H0, c_I, theta_deg, beta))
    zc = g.zc[:nz]
    phi_eq = packing(theta_deg, beta)
    p_exact = (1.0 - beta) * phi_eq * RHO_S * G * math.cos(math.radians(theta_deg)) * (H0 - zc)
    return {
        "nz": nz, "c_I": c_I, "beta": beta, "theta_deg": theta_deg,
        "err_us": u[-1] / u_s - 1.0,
        "err_profile": float(np.abs(u[:nz] - bagnold(zc, c_I, theta_deg, beta)).max() / u_s),
        "dphi": float(np.median(sim.state.phi[0, :nz]) - phi_eq),
        "err_p": float(np.abs(sim.state.p[0, :nz] - p_exact).max() / p_exact[0]),
        "drift": abs(history[-1] - history[-3]) / abs(history[-1]) if len(history) >= 3 else math.nan,
        "dust": float(sim.state.phi[0, nz:].sum() / phi_eq),
        "steps": sim.state.step, "wall": wall, "z": g.zc.copy(), "u": u.copy(),
        "phi": sim.state.phi[0].copy(), "p": sim.state.p[0].copy(), "failure": failure,
    }


def from_rest(resolution: int, theta_deg: float, beta: float, t_end: float = T_END, cfl: float | None = None) -> dict:
    """The ``inclined_layer`` case released from rest at phi_max with the default numerics (no
    numerics section; ``resolution`` cells over h0, a box REST_HEADROOM h0 high; ``cfl``: a
    ``time.cfl`` other than the default), like
    examples/inclined_layer_from_rest.toml. Keys: ``err_us`` (u_s at t_end against Bagnold's at
    the steady thickness), ``drift`` (over the last STEADY_WINDOW s), ``dphi`` (median phi/c of
    the layer - phi_eq), ``steps``, ``wall`` [s]."""
    from granflow.cases import CASES
    from granflow.cases.inclined_layer import bagnold as case_bagnold, surface_velocity
    from granflow.config import CaseConfig

    nz = int(round(REST_HEADROOM * resolution))
    data = {"case": {"name": "inclined_layer"},
            "setup": {"h0": H0, "start": "rest", **({"beta": beta} if beta else {})},
            "material": {"d": D, "rho_s": RHO_S, "phi_max": PHI_MAX, "delta_phi": DELTA_PHI},
            "closure": {"name": "mu_i", "mu1": MU1, "mu2": MU2, "I0": I0},
            "gravity": {"slope_deg": theta_deg, "g": G},
            "grid": {"periodic_x": True, "nx": NX, "nz": nz, "Lx": LX, "Lz": H0 * nz / resolution},
            "time": {"stop_time": t_end, "dt_max": DT_MAX, **({"cfl": cfl} if cfl else {})},
            "output": {"figures": False}}
    if beta:
        data["gas"] = {"law": "linear"}
    cfg = CaseConfig.from_dict(data)
    sim = CASES.get("inclined_layer").setup(cfg)
    record = []
    t0 = time.perf_counter()
    while sim.state.t < t_end - 1e-9:
        sim.step()
        record.append((sim.state.t, surface_velocity(sim)))
    t, u = np.array(record).T
    ref = case_bagnold(cfg)
    late = u[t >= t[-1] - STEADY_WINDOW]
    psi = sim.state.phi / np.maximum(sim.state.c, 1e-300)
    layer = psi[0][sim.state.c[0] > 0.999]
    return {"nz": resolution, "theta_deg": theta_deg, "beta": beta,
            "err_us": float(u[-1] / ref.surface_velocity - 1.0),
            "drift": float(np.ptp(late) / abs(u[-1])), "dphi": float(np.median(layer) - ref.phi),
            "steps": sim.state.step, "wall": time.perf_counter() - t0, "t_end": t_end}


def rest_rows() -> list:
    """The from-rest table's runs: every REST_CASES row at every REST_LEVELS level, each to its
    REST_T_END (default T_END)."""
    return [from_rest(n, th, b, t_end=REST_T_END.get((th, b), T_END)) for th, b in REST_CASES for n in REST_LEVELS]


def rest_table(rows) -> str:
    out = ["| theta [deg] | beta | cells over h | t_end [s] | err u_s | drift (last 2 s) | median phi - phi_eq | steps | wall [s] |",
           "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['theta_deg']:g} | {r['beta']:g} | {r['nz']} | {r['t_end']:g} | {r['err_us']:+.3e} | "
                   f"{r['drift']:.1e} | {r['dphi']:+.2e} | {r['steps']} | {r['wall']:.1f} |")
    return "\n".join(out)


def surcharge_error(dust_cells: float, nz: int, c_I: float = 2.0,
                    theta_deg: float = DRY["theta_deg"]) -> float:
    """Relative u_s error predicted by the surface surcharge alone (dry layer).

    The grains above the top face (``dust_cells`` cells at phi_eq, solid volume ``m`` per unit
    area) sit in cells below phi_c, i.e. in the pressureless ambient: the layer drags them along x
    (shear stress + rho_s g sin(theta) m) but its pressure carries only half their weight (the
    centred face fraction of the interface face), so mu(I(z)) = tan(theta) (phi (h - z) + m) /
    (phi (h - z) + m/2) and u_s = int 2 I sqrt(p/rho_s)/(c_I d) dz. Within a depth ~m of the
    surface this mu exceeds mu2 (no I); that sliver, of relative weight (m/h)^(3/2) < 1e-4, is
    left out. Integrated in s = sqrt(h - z) (smooth integrand).
    """
    from scipy.integrate import quad

    th = math.radians(theta_deg)
    phi = packing(theta_deg, 0.0)
    m = dust_cells * phi * H0 / nz

    def rate(s: float, load: float) -> float:
        depth = phi * s * s
        mu = math.tan(th) * (depth + load) / (depth + load / 2)
        I = I0 * (mu - MU1) / (MU2 - mu)
        return 2 * s * 2 * I * math.sqrt(G * math.cos(th) * (depth + load / 2)) / (c_I * D)

    exact = quad(rate, 0.0, math.sqrt(H0), args=(0.0,))[0]
    return quad(rate, math.sqrt(m / phi), math.sqrt(H0), args=(m,))[0] / exact - 1.0


def orders(errors) -> list:
    e = np.abs(np.asarray(errors, dtype=float))
    return [math.nan] + list(np.log2(e[:-1] / e[1:]))


def table(rows, surcharge: bool = False) -> str:
    extra = " surcharge model |" if surcharge else ""
    head = ("| nz | dz/h | err u_s | order |" + extra + " max err u(z)/u_s | order | median phi - phi_eq | "
            "max err p / p_base | dust [cells] | drift (last 2 s) | steps | wall [s] |\n"
            "|---:|---:|---:|---:|" + "---:|" * surcharge + "---:|---:|---:|---:|---:|---:|---:|---:|")
    o_s, o_p = orders([r["err_us"] for r in rows]), orders([r["err_profile"] for r in rows])
    lines = [f"| {r['nz']} | {1 / r['nz']:.4f} | {r['err_us']:+.3e} | {a:.2f} |"
             + (f" {surcharge_error(r['dust'], r['nz']):+.3e} |" if surcharge else "")
             + f" {r['err_profile']:.3e} | {b:.2f} | {r['dphi']:+.2e} | {r['err_p']:.2e} | {r['dust']:.3f} | "
             f"{r['drift']:.1e} | {r['steps']} | {r['wall']:.1f} |" for r, a, b in zip(rows, o_s, o_p)]
    return "\n".join([head, *lines]).replace("| nan |", "| - |")


def figure(rows, fluid_rows, path: Path = FIGURE) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(13, 4.2))
    th = DRY["theta_deg"]
    zf = np.linspace(0.0, H0, 200)
    u_s = float(bagnold(H0, 2.0, th, 0.0))
    ax[0].plot(bagnold(zf, 2.0, th, 0.0) / u_s, zf / H0, "k-", lw=2, label="Bagnold (c_I = 2)")
    for r in rows:
        nz = r["nz"]
        ax[0].plot(r["u"][:nz] / u_s, r["z"][:nz] / H0, "o-", ms=3, lw=0.8, label=f"nz = {nz}")
    ax[0].set(xlabel="u / u_s (exact)", ylabel="z / h", title="dry, theta = 25 deg")
    ax[0].legend(fontsize=8)
    phi_eq = packing(th, 0.0)
    for r in rows:
        nz = r["nz"]
        ax[1].plot(r["phi"][:nz], r["z"][:nz] / H0, "-", lw=1, label=f"nz = {nz}")
    ax[1].axvline(phi_eq, color="k", lw=2, label="phi_eq(I_theta)")
    ax[1].set(xlabel="phi", ylabel="z / h", title="packing", xlim=(phi_eq - 0.006, phi_eq + 0.002))
    ax[1].legend(fontsize=8)
    for rs, label, mk in ((rows, "dry, surface velocity", "o-"), (rows, "dry, max profile error", "s--"),
                          (fluid_rows, "fluidised, surface velocity", "^-")):
        key = "err_profile" if "profile" in label else "err_us"
        ax[2].loglog([1 / r["nz"] for r in rs], [abs(r[key]) for r in rs], mk, label=label)
    dz = np.array([1 / rows[0]["nz"], 1 / rows[-1]["nz"]])
    ax[2].loglog(dz, abs(rows[0]["err_us"]) * dz / dz[0], "k:", label="first order")
    ax[2].set(xlabel="dz / h", ylabel="relative error", title="convergence")
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="coarsest level only, short run")
    parser.add_argument("--options", action="store_true",
                        help="also measure the v1 (threshold surface) options one at a time")
    parser.add_argument("--rest", action="store_true",
                        help="only the from-rest table (issue 12 acceptance 2, ~1 min)")
    args = parser.parse_args(argv)
    if args.rest:
        print("from rest at phi_max, default numerics (case inclined_layer, no numerics section):")
        print(rest_table(rest_rows()))
        return
    levels = LEVELS[:1] if args.quick else LEVELS
    rows = [run(n, args.quick) for n in levels]
    print(f"dry, theta = {DRY['theta_deg']} deg, c_I = 2: I_theta = {inertial_number(25.0, 0.0):.4f}, "
          f"phi_eq = {packing(25.0, 0.0):.5f}, u_s = {float(bagnold(H0, 2.0, 25.0, 0.0)):.4f} m/s")
    print(table(rows, surcharge=True))
    if args.quick:
        return
    ci1 = [run(n, c_I=1.0) for n in (20, 40)]
    print("\nc_I = 1 (same parameters): u_s(c_I = 1) / u_s(c_I = 2), and its error against each formula")
    print("| nz | ratio | err vs c_I = 1 formula | err vs c_I = 2 formula |\n|---:|---:|---:|---:|")
    for r1 in ci1:
        r2 = next(r for r in rows if r["nz"] == r1["nz"])
        ratio = (1 + r1["err_us"]) * float(bagnold(H0, 1.0, 25.0, 0.0)) / (
            (1 + r2["err_us"]) * float(bagnold(H0, 2.0, 25.0, 0.0)))
        wrong = (1 + r1["err_us"]) * 2.0 - 1.0
        print(f"| {r1['nz']} | {ratio:.4f} | {r1['err_us']:+.3e} | {wrong:+.3e} |")
    fluid = [run(n, **FLUIDISED) for n in FLUID_LEVELS]
    print(f"\nfluidised chute, theta = 22 deg, beta = 0.15: I = {inertial_number(22.0, 0.15):.4f} "
          f"(dry: {inertial_number(22.0, 0.0):.4f}), u_s = {float(bagnold(H0, 2.0, 22.0, 0.15)):.4f} m/s "
          f"(dry: {float(bagnold(H0, 2.0, 22.0, 0.0)):.4f})")
    print(table(fluid))
    print(f"\nfigure: {figure(rows, fluid)}")
    print("\nfrom rest at phi_max, default numerics (case inclined_layer, no numerics section):")
    print(rest_table(rest_rows()))
    if args.options:
        print(f"\nv1 (threshold surface) options, one at a time back to the v1 default, nz = {OPTIONS_LEVEL}:")
        print("| option | value | err u_s | drift (last 2 s) | dust [cells] | failure |\n"
              "|---|---|---:|---:|---:|---|")
        for key, value in DEFAULT_OPTIONS.items():
            r = run(OPTIONS_LEVEL, options={**V1_OPTIONS, key: value})
            print(f"| {key} | {value} | {r['err_us']:+.3e} | {r['drift']:.1e} | {r['dust']:.3f} | "
                  f"{r['failure']} |")


if __name__ == "__main__":
    main()
