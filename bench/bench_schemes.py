"""Benchmark (issue #5): cost of the 'seed' and 'accurate' presets at equal error on the tapped
column's settling phase (0 <= t <= 0.3 s, no tap), against a fine reference solution.

    python bench/bench_schemes.py --json bench/results_schemes.json [--quick]

Both presets run at 5, 10, 20 and 40 points per diameter (ppd), with their own CFL numbers.

Reference.  The error of this problem is dominated by the time step (the kernel's friction term
σ(u_y - u_x) switches like Coulomb friction, which every explicit stepper resolves only to first
order in Δt), so a fine reference needs a fine grid *and* a short step.  The seed's scheme
cannot provide one: its moving average adds a diffusion Δx²/(4Δt) that grows as Δt shrinks, so
refining its step at a fixed grid converges to a different, smoother solution.  The reference is
therefore the 'accurate' scheme's semi-discretisation (whose κ2/κ4 dissipations do not depend on
Δt) stepped by Kutta's RK3 (not the preset's own stepper) at 80 ppd and CFL 0.025; it is
checked against an independent second reference (the Bogacki–Shampine pair with error control,
atol 1e-3 m/s, at 40 ppd) and the difference of the two is printed as the reference's
uncertainty.  For transparency the errors are also reported against the seed's own 80-ppd
solution (the reference an earlier version of this benchmark used) and against a reference from
a different semi-discretisation, an older 'accurate' preset (classical RK4 with the post-step
selective average) at 80 ppd and CFL 0.025.

Errors.  The settling column amplifies round-off (a 1e-14 relative perturbation of the initial
density moves ρ at t = 0.3 s by about 1 % on the grid; that "chaos floor" is measured and
printed), so the benchmark uses coarse-grained quantities:

* ``density_1d``: ‖ρ̄ - ρ̄_ref‖₁ / ‖ρ̄_ref‖₁ at t = 0.3 s, ρ̄ the density averaged over bins one
  diameter wide;
* ``mass_centre``: max over the saved times (every 5 ms) of |h - h_ref| / d, h the mass-centre
  height.

Cost: wall time of the run (compiled, one core, compilation excluded; median of 5).  For each
metric the cost of each preset at a common error (the larger of the two presets' smallest
errors) is interpolated log-log over the grids, and the ratio seed/accurate printed: > 1 means
'accurate' is cheaper.  Rows of the adaptive variant of 'accurate' (error control instead of a
small CFL number), of the previous version of the preset (Kutta's RK3 at CFL 0.1) and of the
preset with classical RK4 in place of its stepper rk4_0.4_0.25 are printed for comparison, with
their own ratios against the seed; they do not enter the preset's ratio.
"""

from __future__ import annotations

import json
import os
import statistics
import time

import numba
import numpy as np

from bsrflow.numerics.solver import Scheme
from bsrflow.physics.column import ColumnSetup, column_run_from_result, initial_density
from _args import Parser, output_json, repo_path  # noqa: E402

T = 0.3
PPDS = (5, 10, 20, 40)
REF_PPD = 80
BASE = dict(m0=406.0, kernel_dissipation=0.9, n_taps=0, t_end=T, save_every=0.005)
_d = ColumnSetup(**BASE).diameter
BASE["domain_height"] = (np.ceil(ColumnSetup(**BASE).energy_bound_height() / _d) + 1) * _d   # whole d: grids nest
_LINE = ColumnSetup(**BASE).particle_mass / _d

SCHEMES = {
    "seed": lambda: Scheme.preset("seed"),
    "accurate": lambda: Scheme.preset("accurate"),
    "accurate_adaptive": lambda: Scheme.preset("accurate", stepper="bs32", cfl=0.8, rtol=1e-2,
                                               atol=(1e-2, 1e-2 * _LINE)),
    # the previous version of the preset: Kutta's RK3 at CFL 0.1 (third order on smooth problems)
    "accurate_kutta3": lambda: Scheme.preset("accurate", stepper="kutta3", cfl=0.1),
    # the preset with classical RK4 in place of its four-stage member rk4_0.4_0.25
    "accurate_rk4": lambda: Scheme.preset("accurate", stepper="rk4"),
}
VARIANTS = ("accurate_adaptive", "accurate_kutta3", "accurate_rk4")
REFERENCES = {
    # Kutta's RK3, not the preset's own stepper, so that the preset is not measured against itself
    "converged": (lambda: Scheme.preset("accurate", stepper="kutta3", cfl=0.025), REF_PPD),
    "independent": (lambda: Scheme.preset("accurate", stepper="bs32", cfl=0.8, rtol=1e-2,
                                          atol=(1e-3, 1e-3 * _LINE)), 40),
    "seed_own": (lambda: Scheme.preset("seed"), REF_PPD),
    "older_preset": (lambda: Scheme.preset("accurate", stepper="rk4", sensor_dissipation=0.0, cfl=0.025), REF_PPD),
}
OTHER_REFS = ("converged", "older_preset", "seed_own")


def run(scheme, ppd, perturb=0.0, repeats=1):
    s = ColumnSetup(points_per_diameter=ppd, **BASE)
    g = s.grid()
    sim = s.simulation(scheme)
    rho0 = initial_density(s, g.x)
    if perturb:
        rho0 = rho0 * (1.0 + perturb * np.random.default_rng(1).standard_normal(rho0.size))
    sim.run(np.zeros(g.n_cells), rho0, 1e-3)                     # compile / warm up
    walls = []
    for _ in range(repeats):
        w = time.perf_counter()
        res = sim.run(np.zeros(g.n_cells), rho0, T, save_every=BASE["save_every"], tracers=s.sphere_centres())
        walls.append(time.perf_counter() - w)
    r = column_run_from_result(s, g, res)
    return statistics.median(walls), r, res


def coarse(rho, ppd):
    n = rho.size // ppd * ppd
    return rho[:n].reshape(-1, ppd).mean(axis=1)


def errors(r, ppd, ref, ref_ppd):
    a, b = coarse(r.rho[-1], ppd), coarse(ref.rho[-1], ref_ppd)
    n = min(a.size, b.size)
    a, b = a[:n], b[:n]
    return {"density_1d": float(np.abs(a - b).sum() / np.abs(b).sum()),
            "mass_centre": float(np.max(np.abs(r.mass_centre - ref.mass_centre)) / _d)}


def cost_at(err, errs, costs):
    """log-log interpolation of cost at error ``err`` (errors need not be monotone: the pairs
    are sorted by error)."""
    order = np.argsort(errs)
    return float(np.exp(np.interp(np.log(err), np.log(np.asarray(errs)[order]), np.log(np.asarray(costs)[order]))))


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=output_json, default=repo_path("bench/results_schemes.json"),
                    help="JSON file written (default bench/results_schemes.json)")
    ap.add_argument("--quick", action="store_true", help="one timing per run, no chaos floor, grids 5-20")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    ppds = PPDS[:3] if args.quick else PPDS
    repeats = 1 if args.quick else 5
    refs, ref_ppd = {}, {}
    out = {"t_end_s": T, "reference_ppd": REF_PPD, "references": {}, "presets": {}, "equal_error": {}}
    for name, (make, ppd) in REFERENCES.items():
        wall, refs[name], res = run(make(), ppd)
        ref_ppd[name] = ppd
        out["references"][name] = {"scheme": make().to_dict(), "ppd": ppd, "wall_s": wall, "steps": int(res.steps)}
        print(f"reference {name:12s} ppd {ppd}: {res.steps} steps, {wall:.1f} s", flush=True)
    unc = errors(refs["independent"], ref_ppd["independent"], refs["converged"], REF_PPD)
    seed_off = errors(refs["seed_own"], REF_PPD, refs["converged"], REF_PPD)
    prev_off = errors(refs["older_preset"], REF_PPD, refs["converged"], REF_PPD)
    out["reference_uncertainty"] = unc
    out["seed_own_reference_vs_converged"] = seed_off
    out["older_preset_reference_vs_converged"] = prev_off
    print("reference uncertainty (independent vs converged): " + ", ".join(f"{k} {v:.2e}" for k, v in unc.items()))
    print("seed's own 80-ppd solution vs converged:          " + ", ".join(f"{k} {v:.2e}" for k, v in seed_off.items()))
    print("older preset's 80-ppd solution vs converged:      " + ", ".join(f"{k} {v:.2e}" for k, v in prev_off.items()))
    if not args.quick:
        _, pert, _ = run(REFERENCES["converged"][0](), REF_PPD, perturb=1e-14)
        out["chaos_floor"] = errors(pert, REF_PPD, refs["converged"], REF_PPD)
        print("chaos floor (1e-14 perturbation of the converged reference): "
              + ", ".join(f"{k} {v:.2e}" for k, v in out["chaos_floor"].items()), flush=True)
    for scheme, make in SCHEMES.items():
        rows = []
        for ppd in (ppds if scheme != "accurate_adaptive" else ppds[:3]):
            wall, r, res = run(make(), ppd, repeats=repeats)
            row = {"ppd": ppd, "wall_s": wall, "steps": int(res.steps),
                   "rejected_steps": int(res.info.get("rejected_steps", 0)),
                   "errors": {name: errors(r, ppd, refs[name], ref_ppd[name]) for name in OTHER_REFS}}
            rows.append(row)
            print(f"{scheme:17s} ppd {ppd:2d}: wall {wall:7.3f} s, {res.steps:6d} steps  " + "  ".join(
                f"vs {name}: ρ̄ {e['density_1d']:.2e}, h {e['mass_centre']:.2e} d" for name, e in row["errors"].items()),
                flush=True)
        out["presets"][scheme] = rows
    for ref_name in OTHER_REFS:
        for metric in ("density_1d", "mass_centre"):
            es = {s: [row["errors"][ref_name][metric] for row in out["presets"][s]] for s in ("seed", "accurate")}
            cs = {s: [row["wall_s"] for row in out["presets"][s]] for s in ("seed", "accurate")}
            target = max(min(es["seed"]), min(es["accurate"]))
            c_seed = cost_at(target, es["seed"], cs["seed"])
            c_acc = cost_at(target, es["accurate"], cs["accurate"])
            key = f"{metric}_vs_{ref_name}_reference"
            out["equal_error"][key] = {"error": target, "seed_wall_s": c_seed, "accurate_wall_s": c_acc,
                                       "ratio_seed_over_accurate": c_seed / c_acc}
            print(f"{key:40s} at error {target:.2e}: seed {c_seed:.3f} s, accurate {c_acc:.3f} s, "
                  f"ratio seed/accurate {c_seed / c_acc:.2f}", flush=True)
    # the variants against the seed, converged reference only (not part of the preset's claim)
    out["equal_error_variants"] = {}
    for var in VARIANTS:
        for metric in ("density_1d", "mass_centre"):
            es = {s: [row["errors"]["converged"][metric] for row in out["presets"][s]] for s in ("seed", var)}
            cs = {s: [row["wall_s"] for row in out["presets"][s]] for s in ("seed", var)}
            target = max(min(es["seed"]), min(es[var]))
            c_seed, c_var = cost_at(target, es["seed"], cs["seed"]), cost_at(target, es[var], cs[var])
            inside = min(es[var]) <= target <= max(es[var])
            out["equal_error_variants"][f"{var}_{metric}"] = {
                "error": target, "seed_wall_s": c_seed, "variant_wall_s": c_var,
                "ratio_seed_over_variant": c_seed / c_var, "interpolated": bool(inside)}
            print(f"variant {var:17s} {metric:12s} at error {target:.2e}: seed {c_seed:.3f} s, {var} {c_var:.3f} s, "
                  f"ratio {c_seed / c_var:.2f}{'' if inside else ' (outside its error range: clamped)'}", flush=True)
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
