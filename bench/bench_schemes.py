"""Benchmark: cost of the 'seed' and 'accurate' presets at equal error on the tapped column's
settling phase (0 <= t <= 0.3 s, no tap), against a fine reference solution.

    python bench/bench_schemes.py --json bench/results_schemes.json

Both presets run at 5, 10 and 20 points per diameter; the reference is 'accurate' at 40 points
per diameter.  Error: ‖ρ - ρ_ref‖₁ / ‖ρ_ref‖₁ at t = 0.3 s, the reference averaged onto the
coarse cells (cells nest: ppd doubles).  Cost: wall time of the run (compiled, one core,
compilation excluded).  The cost of each preset at a common error level (the larger of the two
smallest errors) is interpolated log-log, and the ratio seed/accurate printed.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numba
import numpy as np

from bsrflow.physics.column import ColumnSetup, run_bsr_column

T = 0.3
BASE = dict(m0=410.0, kernel_dissipation=0.83, n_taps=0, t_end=T, save_every=T)
_d = ColumnSetup(**BASE).diameter
BASE["domain_height"] = (np.ceil(ColumnSetup(**BASE).energy_bound_height() / _d) + 1) * _d   # whole d: grids nest


def run(scheme, ppd):
    s = ColumnSetup(points_per_diameter=ppd, **BASE)
    run_bsr_column(s.with_(t_end=1e-3, save_every=1e-3), scheme=scheme)       # compile / warm up
    w = time.perf_counter()
    r = run_bsr_column(s, scheme=scheme)
    return time.perf_counter() - w, r.rho[-1]


def coarsen(rho, factor):
    return rho.reshape(-1, factor).mean(axis=1)


def cost_at(err, errors, costs):
    le, lc = np.log(errors)[::-1], np.log(costs)[::-1]          # increasing error order
    return float(np.exp(np.interp(np.log(err), le, lc)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default="bench/results_schemes.json")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    _, ref = run("accurate", 40)
    out = {"reference": "accurate, 40 points per diameter", "t_end_s": T, "presets": {}}
    for scheme in ("seed", "accurate"):
        errs, costs = [], []
        for ppd in (5, 10, 20):
            wall, rho = run(scheme, ppd)
            r = coarsen(ref, 40 // ppd)
            errs.append(float(np.abs(rho - r).sum() / np.abs(r).sum()))
            costs.append(wall)
            print(f"{scheme:8s} ppd {ppd:2d}: error {errs[-1]:.3e}  wall {wall:.3f} s")
        out["presets"][scheme] = {"ppd": [5, 10, 20], "errors": errs, "wall_s": costs}
    target = max(min(out["presets"]["seed"]["errors"]), min(out["presets"]["accurate"]["errors"]))
    cs = cost_at(target, out["presets"]["seed"]["errors"], out["presets"]["seed"]["wall_s"])
    ca = cost_at(target, out["presets"]["accurate"]["errors"], out["presets"]["accurate"]["wall_s"])
    out["equal_error"] = {"error": target, "seed_wall_s": cs, "accurate_wall_s": ca, "ratio_seed_over_accurate": cs / ca}
    print(f"at error {target:.3e}: seed {cs:.3f} s, accurate {ca:.3f} s, ratio seed/accurate {cs / ca:.2f}")
    os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
