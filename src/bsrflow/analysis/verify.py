"""Verification: errors against exact solutions and observed orders from grid refinement.

``bsrflow verify --json PATH`` runs every case, prints a table and writes
``{"cases": [{"name", "kind", "stepper", "filter", "resolutions", "errors", "observed_order", ...}]}``.

Error measure (dimensionless): e = max(‖u - u*‖∞ / ‖u*‖∞, ‖ρ - ρ*‖∞ / ‖ρ*‖∞) at the final time,
with (u*, ρ*) the exact solution ("exact" cases) or a reference solution ("space": the
unfiltered RK3 solution on a 4x finer grid than the finest, Fourier-interpolated to the coarse
cell centres; "time": the unfiltered RK3 solution of the same semi-discrete system with a
step 8x smaller than the smallest, by classical RK4).  The observed order is the least-squares slope of
log e against log h (h = Δx for "space"/"exact", Δt for "time"); ``pairwise_orders`` gives
log2(e_k / e_{k+1}) for each refinement.

The cases
---------
example_a[_unfiltered]   Example A (3.3.1) on [0, 1] m to t = 0.9 s, exact inflow data at both
                         ends, fixed CFL number.  u is linear in x and ρ uniform, so central
                         differences and the moving average are exact: the error is the time
                         error of RK3 (Δt ∝ Δx).  Also checks that a run to t = 1.2 s stops
                         with a clear message near t = 1 s (``blowup_detected_at``).
example_b[_unfiltered]   Example B on the periodic [0, 1] m to t = 2 s, fixed CFL number.
smooth_space[_filter]    ρ_t + (ρu)_x = 0, u_t + u u_x = ∫ρΘ with the elastic Walton-Braun
                         kernel (ε = 0), smooth periodic data, refined in space at fixed CFL.
smooth_time[_filter]     the same problem on a fixed grid, refined in the time step.
*_accurate               the same with the 'accurate' preset (no moving average; fourth-difference
                         and sensor-switched second-difference dissipation inside the
                         right-hand side).  Its time reference is the same semi-discrete
                         system (dissipations included) stepped by RK4 with a small step.
smooth_time_accurate_kutta3  smooth_time_accurate with Kutta's RK3 (the previous preset's
                         stepper) in place of the preset's four-stage RK4 member rk4_0.4_0.25.
smooth_time_friction[_kutta3]  smooth_time_accurate (rk4_0.4_0.25; Kutta's RK3) with the kernel's
                         friction switch on (ε = 0.3): both are first order in Δt.
"""

from __future__ import annotations

import json
import time

import numpy as np

from ..numerics.grid import Grid1D
from ..numerics.solver import Scheme, Simulation, SimulationError
from ..physics.kernels import walton_braun
from ..physics.model import BSRModel
from .exact import example_a_model, example_a_solution, example_b_model, example_b_solution, psi_b

__all__ = ["run_cases", "observed_order", "relative_error", "add_parser", "SMOOTH"]


def relative_error(u, rho, u_ref, rho_ref) -> float:
    """max(‖u-u*‖∞/‖u*‖∞, ‖ρ-ρ*‖∞/‖ρ*‖∞)."""
    eu = np.max(np.abs(u - u_ref)) / max(np.max(np.abs(u_ref)), 1e-300)
    er = np.max(np.abs(rho - rho_ref)) / max(np.max(np.abs(rho_ref)), 1e-300)
    return float(max(eu, er))


def observed_order(h, errors) -> float:
    """Least-squares slope of log(error) against log(h)."""
    h = np.asarray(h, float)
    e = np.asarray(errors, float)
    ok = e > 0
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(e[ok]), 1)[0])


def pairwise_orders(h, errors):
    h = np.asarray(h, float)
    e = np.asarray(errors, float)
    return [float(np.log(e[k] / e[k + 1]) / np.log(h[k] / h[k + 1])) for k in range(len(e) - 1)]


def _case(name, kind, scheme, resolutions, h, errors, **extra):
    d = {"name": name, "kind": kind, "stepper": scheme.stepper, "filter": bool(scheme.filter),
         "scheme": scheme.name, "resolutions": [int(r) for r in resolutions], "h": [float(x) for x in h],
         "errors": [float(e) for e in errors], "observed_order": observed_order(h, errors),
         "pairwise_orders": pairwise_orders(h, errors)}
    d.update(extra)
    return d


# ---- Example A ------------------------------------------------------------------------------
def case_example_a(scheme: Scheme, resolutions=(16, 32, 64, 128), t_end=0.9, name="example_a"):
    model = example_a_model()
    errors, h = [], []
    for n in resolutions:
        grid = Grid1D(0.0, 1.0, n, "dirichlet", "dirichlet")
        u0, r0 = example_a_solution(grid.x, 0.0)
        res = Simulation(model, grid, scheme).run(u0, r0, t_end)
        ue, re = example_a_solution(grid.x, t_end)
        errors.append(relative_error(res.u[-1], res.rho[-1], ue, re))
        h.append(grid.dx)
    # past the blow-up: the solver must stop cleanly near t = 1
    grid = Grid1D(0.0, 1.0, resolutions[0], "dirichlet", "dirichlet")
    u0, r0 = example_a_solution(grid.x, 0.0)
    blow = None
    msg = ""
    try:
        Simulation(model, grid, scheme, rho_max=1e6).run(u0, r0, 1.2, save_every=0.1)
    except SimulationError as exc:
        blow = exc.time
        msg = str(exc)
    return _case(name, "exact", scheme, resolutions, h, errors, t_end=t_end,
                 blowup_detected_at=blow, blowup_message=msg)


# ---- Example B ------------------------------------------------------------------------------
def case_example_b(scheme: Scheme, resolutions=(32, 64, 128, 256), t_end=2.0, name="example_b"):
    model = example_b_model()
    errors, h = [], []
    for n in resolutions:
        grid = Grid1D(0.0, 1.0, n, "periodic", "periodic")
        u0, r0 = example_b_solution(grid.x, 0.0)
        res = Simulation(model, grid, scheme).run(u0, r0, t_end)
        ue, re = example_b_solution(grid.x, t_end)
        errors.append(relative_error(res.u[-1], res.rho[-1], ue, re))
        h.append(grid.dx)
    return _case(name, "exact", scheme, resolutions, h, errors, t_end=t_end)


# ---- smooth periodic problem with the interaction kernel ------------------------------------
SMOOTH = dict(length=1.0, radius=1.0 / 16.0, strength=3.0 * 16.0 ** 3, rho0=1.0, rho_amp=0.2,
              u_amp=0.2, t_end=0.15)
"""Smooth periodic problem: L = 1 m, R = 1/16 m, λ = 3/R³ kg⁻¹s⁻² (sound speed
sqrt(λR³ρ/3) = 1 m/s at ρ = 1 kg/m), ρ0 = 1 + 0.2 sin 2πx kg/m, u0 = 0.2 cos 2πx m/s,
to t = 0.15 s (well before the first shock)."""


def smooth_model(dissipation: float = 0.0) -> BSRModel:
    """The smooth problem's model; ``dissipation`` ε > 0 switches on the kernel's friction
    σ(z Δu) (the ``smooth_time_friction*`` cases)."""
    return BSRModel(kernel=walton_braun(SMOOTH["strength"], dissipation, SMOOTH["radius"]))


def smooth_initial(x):
    k = 2.0 * np.pi / SMOOTH["length"]
    return SMOOTH["u_amp"] * np.cos(k * x), SMOOTH["rho0"] * (1.0 + SMOOTH["rho_amp"] * np.sin(k * x))


def fourier_resample(values, n_out):
    """Values of a smooth periodic cell-centred field of n_in cells at the centres of n_out cells
    on the same interval (trigonometric interpolation)."""
    n_in = values.size
    c = np.fft.rfft(values)
    k = np.arange(c.size)
    # shift from the fine centres (j+1/2)/n_in to the coarse centres (m+1/2)/n_out: evaluate the
    # trigonometric polynomial directly at the coarse points
    x_in0 = 0.5 / n_in
    x_out = (np.arange(n_out) + 0.5) / n_out
    phase = np.exp(2j * np.pi * np.outer(x_out - x_in0, k))
    w = np.full(c.size, 2.0)
    w[0] = 1.0
    if n_in % 2 == 0:
        w[-1] = 1.0
    return (phase @ (w * c)).real / n_in


def case_smooth_space(scheme: Scheme, resolutions=(64, 128, 256, 512), name="smooth_space"):
    model = smooth_model()
    L = SMOOTH["length"]
    ref_n = 4 * resolutions[-1]
    ref_scheme = Scheme(stepper="kutta3", filter=False, cfl=scheme.cfl, quadrature=scheme.quadrature,
                        name="reference")
    grid = Grid1D(0.0, L, ref_n, "periodic", "periodic")
    u0, r0 = smooth_initial(grid.x)
    ref = Simulation(model, grid, ref_scheme).run(u0, r0, SMOOTH["t_end"])
    errors, h = [], []
    for n in resolutions:
        grid = Grid1D(0.0, L, n, "periodic", "periodic")
        u0, r0 = smooth_initial(grid.x)
        res = Simulation(model, grid, scheme).run(u0, r0, SMOOTH["t_end"])
        errors.append(relative_error(res.u[-1], res.rho[-1], fourier_resample(ref.u[-1], n),
                                     fourier_resample(ref.rho[-1], n)))
        h.append(grid.dx)
    return _case(name, "space", scheme, resolutions, h, errors, reference_cells=ref_n, cfl=scheme.cfl,
                 t_end=SMOOTH["t_end"])


def case_smooth_time(scheme_kw: dict, steps=(64, 128, 256, 512), n_cells=256, name="smooth_time",
                     dissipation=0.0):
    model = smooth_model(dissipation)
    T = SMOOTH["t_end"]
    grid = Grid1D(0.0, SMOOTH["length"], n_cells, "periodic", "periodic")
    u0, r0 = smooth_initial(grid.x)
    ref_steps = 8 * steps[-1]
    same_system = {k: scheme_kw[k] for k in ("hyperdiffusion", "selective_filter", "sensor_dissipation",
                                             "positivity")
                   if k in scheme_kw}
    ref = Simulation(model, grid, Scheme(stepper="rk4", filter=False, dt=T / ref_steps,
                                         **same_system)).run(u0, r0, T)
    errors, h = [], []
    scheme = None
    for n in steps:
        scheme = Scheme(dt=T / n, **scheme_kw)
        res = Simulation(model, grid, scheme).run(u0, r0, T)
        errors.append(relative_error(res.u[-1], res.rho[-1], ref.u[-1], ref.rho[-1]))
        h.append(T / n)
    c_max = 1.0 * np.sqrt(1.0 + SMOOTH["rho_amp"]) + SMOOTH["u_amp"]
    return _case(name, "time", scheme, steps, h, errors, n_cells=n_cells, reference_steps=ref_steps,
                 kernel_dissipation=dissipation,
                 largest_cfl=float(c_max * T / steps[0] / grid.dx), t_end=T)


def run_cases(which=None, log=print):
    """Run the verification cases (all by default; ``which``: names of cases to run, ValueError
    naming the valid ones for an unknown name, before anything runs). Returns the list of case
    dicts."""
    seed = Scheme.preset("seed")
    unf = Scheme.preset("seed", filter=False, name="seed_unfiltered")
    jobs = [
        ("example_a", lambda: case_example_a(seed)),
        ("example_a_unfiltered", lambda: case_example_a(unf, name="example_a_unfiltered")),
        ("example_b", lambda: case_example_b(seed)),
        ("example_b_unfiltered", lambda: case_example_b(unf, name="example_b_unfiltered")),
        ("smooth_space", lambda: case_smooth_space(unf, name="smooth_space")),
        ("smooth_space_filter", lambda: case_smooth_space(seed, name="smooth_space_filter")),
        ("smooth_time", lambda: case_smooth_time(dict(stepper="kutta3", filter=False, name="seed_unfiltered"),
                                                 name="smooth_time")),
        ("smooth_time_filter", lambda: case_smooth_time(dict(stepper="kutta3", filter=True, name="seed"),
                                                        name="smooth_time_filter")),
    ]
    acc = Scheme.preset("accurate")
    acc_kw = dict(stepper=acc.stepper, filter=False, hyperdiffusion=acc.hyperdiffusion,
                  selective_filter=acc.selective_filter, sensor_dissipation=acc.sensor_dissipation,
                  positivity=acc.positivity, name="accurate")
    jobs += [
        ("example_a_accurate", lambda: case_example_a(acc, name="example_a_accurate")),
        ("example_b_accurate", lambda: case_example_b(acc, name="example_b_accurate")),
        ("smooth_space_accurate", lambda: case_smooth_space(acc, name="smooth_space_accurate")),
        ("smooth_time_accurate", lambda: case_smooth_time(acc_kw, name="smooth_time_accurate")),
        # the same with Kutta's RK3 (the previous preset's stepper) in place of the preset's
        ("smooth_time_accurate_kutta3", lambda: case_smooth_time(dict(acc_kw, stepper="kutta3"),
                                                                 name="smooth_time_accurate_kutta3")),
        # the kernel's friction switch on (ε = 0.3): both steppers drop to first order in Δt
        ("smooth_time_friction", lambda: case_smooth_time(acc_kw, dissipation=0.3, name="smooth_time_friction")),
        ("smooth_time_friction_kutta3", lambda: case_smooth_time(dict(acc_kw, stepper="kutta3"), dissipation=0.3,
                                                                 name="smooth_time_friction_kutta3")),
    ]
    jobs += _extra_jobs()
    valid = [name for name, _ in jobs]
    unknown = [w for w in (which or []) if w not in valid]
    if unknown:                                  # before any case runs
        raise ValueError(f"--case {unknown[0]!r} is not a verification case; valid names: {', '.join(valid)}")
    out = []
    for name, job in jobs:
        if which and name not in which:
            continue
        t0 = time.perf_counter()
        got = job()
        wall = time.perf_counter() - t0
        for case in (got if isinstance(got, list) else [got]):
            case.setdefault("wall_time_s", wall)
            out.append(case)
        if log:
            log(f"  {name}: done in {wall:.1f} s")
    return out


def _extra_jobs():
    """Cases contributed by other modules (n-D embedding of the seed kernel and of the packing
    continuum: embedding_packing_2d / _3d)."""
    jobs = []
    try:
        from ..numerics import solver_nd  # noqa: F401
        from ..numerics.solver_nd import verify_cases as nd_cases
        jobs.append(("embedding", nd_cases))
    except ImportError:
        pass
    from ..numerics.packing_nd import verify_cases as packing_nd_cases
    jobs.append(("embedding_packing", packing_nd_cases))
    return jobs


def format_table(cases) -> str:
    wn = max([24] + [len(c["name"]) for c in cases])
    ws = max([8] + [len(c["stepper"]) for c in cases])
    head = f"{'case':{wn}s} {'kind':5s} {'stepper':{ws}s} {'filter':6s} {'resolutions':>22s}  {'errors':>40s}  order"
    lines = [head, "-" * len(head)]
    for c in cases:
        res = ",".join(str(r) for r in c["resolutions"])
        errs = " ".join(f"{e:.2e}" for e in c["errors"])
        order = c["observed_order"]
        o = "  n/a" if order is None or not np.isfinite(order) else f"{order:5.2f}"
        lines.append(f"{c['name']:{wn}s} {c['kind']:5s} {c['stepper']:{ws}s} {str(c['filter']):6s} {res:>22s}  "
                     f"{errs:>40s}  {o}")
    return "\n".join(lines)


def add_parser(sub):
    p = sub.add_parser("verify", help="run the verification cases (exact solutions, refinement orders)",
                       description="Run the verification cases and print observed orders of convergence.")
    p.add_argument("--json", metavar="PATH", help="write the results as JSON to PATH (its folder must exist)")
    p.add_argument("--case", action="append", metavar="NAME", help="run only this case (repeatable; an unknown name lists the valid ones)")
    p.set_defaults(func=_main)


def _main(args) -> int:
    from ..io.paths import check_output_file
    if args.json is not None:
        check_output_file(args.json, "--json")
    flat = run_cases(args.case)
    print(format_table(flat))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"cases": flat}, fh, indent=2, default=_json_default)
        print(f"wrote {args.json}")
    return 0


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))
