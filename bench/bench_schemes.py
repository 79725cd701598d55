"""Benchmark (issue #5): cost of the 'seed' and 'accurate' presets at equal error on the tapped
column's settling phase (0 <= t <= 0.3 s, no tap), against fine reference solutions.

    python bench/bench_schemes.py --json bench/results_schemes.json

Both presets run at 5, 10, 20 and 40 points per diameter.  References: each preset at 80
points per diameter (the ratio is reported against both, so that neither scheme is favoured
by being its own reference).

Errors.  The settling column is sensitive to round-off: the friction term of the kernel switches
with the sign of velocity differences, and a relative perturbation of 1e-14 of the initial
density changes ρ at t = 0.3 s by about 1 % in L1 on the grid (the "chaos floor", measured here
at the references' resolution and printed).  Grid-level L1 errors therefore stop converging at
that floor; the benchmark uses coarse-grained quantities that do converge:

* ``density_1d``: ‖ρ̄ - ρ̄_ref‖₁ / ‖ρ̄_ref‖₁ at t = 0.3 s, ρ̄ the density averaged over bins one
  diameter wide;
* ``mass_centre``: max over the saved times (every 5 ms) of |h - h_ref| / d, h the mass-centre
  height.

Cost: wall time of the run (compiled, one core, compilation excluded; median of 3).  For each
metric and reference the cost of each preset at a common error (the larger of the two smallest
errors) is interpolated log-log, and the ratio seed/accurate printed: > 1 means 'accurate' is
cheaper.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numba
import numpy as np

from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.column import ColumnSetup, column_run_from_result, initial_density

T = 0.3
PPDS = (5, 10, 20, 40)
REF_PPD = 80
BASE = dict(m0=406.0, kernel_dissipation=0.9, n_taps=0, t_end=T, save_every=0.005)
_d = ColumnSetup(**BASE).diameter
BASE["domain_height"] = (np.ceil(ColumnSetup(**BASE).energy_bound_height() / _d) + 1) * _d   # whole d: grids nest


def run(scheme, ppd, perturb=0.0, repeats=1):
    s = ColumnSetup(points_per_diameter=ppd, **BASE)
    g = s.grid()
    line = s.particle_mass / s.diameter
    sim = Simulation(s.model(), g, Scheme.preset(scheme), vacuum_density=1e-4 * line, top_tolerance=1e-3 * line)
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
    return statistics.median(walls), r


def coarse(rho, ppd):
    n = rho.size // ppd * ppd
    return rho[:n].reshape(-1, ppd).mean(axis=1)


def errors(r, ref, ppd):
    a, b = coarse(r.rho[-1], ppd), coarse(ref.rho[-1], REF_PPD)
    return {"density_1d": float(np.abs(a - b).sum() / np.abs(b).sum()),
            "mass_centre": float(np.max(np.abs(r.mass_centre - ref.mass_centre)) / _d)}


def cost_at(err, errs, costs):
    """log-log interpolation of cost at error ``err`` (errors need not be monotone: the pairs
    are sorted by error)."""
    order = np.argsort(errs)
    return float(np.exp(np.interp(np.log(err), np.log(np.asarray(errs)[order]), np.log(np.asarray(costs)[order]))))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default="bench/results_schemes.json")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    refs, floor = {}, {}
    for scheme in ("seed", "accurate"):
        _, refs[scheme] = run(scheme, REF_PPD)
        _, pert = run(scheme, REF_PPD, perturb=1e-14)
        floor[scheme] = errors(pert, refs[scheme], REF_PPD)
        print(f"reference {scheme} ppd {REF_PPD}; chaos floor (1e-14 perturbation): "
              + ", ".join(f"{k} {v:.2e}" for k, v in floor[scheme].items()), flush=True)
    out = {"t_end_s": T, "reference_ppd": REF_PPD, "chaos_floor": floor, "presets": {}, "equal_error": {}}
    for scheme in ("seed", "accurate"):
        rows = []
        for ppd in PPDS:
            wall, r = run(scheme, ppd, repeats=3)
            row = {"ppd": ppd, "wall_s": wall, "steps": int(r.steps),
                   "errors": {name: errors(r, refs[name], ppd) for name in refs}}
            rows.append(row)
            print(f"{scheme:8s} ppd {ppd:2d}: wall {wall:7.3f} s  " + "  ".join(
                f"vs {name}: ρ̄ {e['density_1d']:.2e}, h {e['mass_centre']:.2e} d" for name, e in row["errors"].items()),
                flush=True)
        out["presets"][scheme] = rows
    for ref_name in refs:
        for metric in ("density_1d", "mass_centre"):
            es = {s: [row["errors"][ref_name][metric] for row in out["presets"][s]] for s in out["presets"]}
            cs = {s: [row["wall_s"] for row in out["presets"][s]] for s in out["presets"]}
            target = max(min(es["seed"]), min(es["accurate"]))
            c_seed = cost_at(target, es["seed"], cs["seed"])
            c_acc = cost_at(target, es["accurate"], cs["accurate"])
            key = f"{metric}_vs_{ref_name}_reference"
            out["equal_error"][key] = {"error": target, "seed_wall_s": c_seed, "accurate_wall_s": c_acc,
                                       "ratio_seed_over_accurate": c_seed / c_acc}
            print(f"{key:40s} at error {target:.2e}: seed {c_seed:.3f} s, accurate {c_acc:.3f} s, "
                  f"ratio seed/accurate {c_seed / c_acc:.2f}", flush=True)
    os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
