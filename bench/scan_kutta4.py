"""How the 'accurate' preset's stepper was chosen: a scan of Kutta's family of four-stage
fourth-order Runge–Kutta methods on the tapped column's settling phase (issue #5).

    python bench/scan_kutta4.py [--nodes 0.2,0.3,0.333,0.4,0.6,0.7,0.8] [--ppd 10,20] [--cfl 0.1]
                                [--perturb 1e-14] [--json bench/results_kutta4.json]

Every member of the family (nodes 0, c2, c3, 1; ``bsrflow.numerics.steppers.kutta4_family``)
has the stability polynomial of classical RK4 and order 4 on smooth problems; they differ in
their error constants.  On the settling column the time error comes from the kernel's
Coulomb-like friction switch (first order in Δt for every explicit stepper), and its constant
depends strongly on the nodes.  For each (c2, c3) on the grid (general case only: c2 ≠ c3,
c2 ≠ 1/2; nodes rounded to fractions with denominators up to 100) the script runs the 'accurate' preset's semi-discretisation with that stepper at the
given ppd and CFL number, and prints the errors of ``bench/bench_schemes.py`` (mass-centre h
[d], binned density ρ̄) against its converged reference (Kutta's RK3, 80 ppd, CFL 0.025), with
Kutta's RK3 and classical RK4 as the first two rows.  About 1 min for the reference plus
0.5 s per member and ppd pair on one core.
"""

from __future__ import annotations

import itertools
import json
import os
import sys
from fractions import Fraction

import numba
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_schemes as bs  # noqa: E402
from _args import Parser, float_in, int_in, list_of, output_json  # noqa: E402

from bsrflow.numerics import steppers  # noqa: E402
from bsrflow.numerics.solver import Scheme  # noqa: E402


def main(argv=None) -> int:
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nodes", type=list_of(float_in(0.0, 1.0, lo_open=True, hi_open=True)),
                    default="0.2,0.3,0.333,0.4,0.6,0.7,0.8",
                    help="values tried for both c2 and c3, each in (0, 1) (default 0.2,0.3,0.333,0.4,0.6,0.7,0.8)")
    ap.add_argument("--ppd", type=list_of(int_in(2)), default="10,20",
                    help="grids, points per diameter >= 2 (default 10,20)")
    ap.add_argument("--cfl", type=float_in(0.0, 1.7321, lo_open=True), default=0.1,
                    help="Courant number in (0, 1.7321], the limit of the Kutta RK3 row (default 0.1)")
    ap.add_argument("--perturb", type=float_in(0.0, 1e-3), default=0.0,
                    help="relative perturbation of the initial density, in [0, 1e-3] (default 0)")
    ap.add_argument("--json", type=output_json, default=None, help="also write the table as JSON")
    args = ap.parse_args(argv)
    nodes, ppds = args.nodes, args.ppd
    numba.set_num_threads(1)
    make_ref, ref_ppd = bs.REFERENCES["converged"]
    _, ref, res = bs.run(make_ref(), ref_ppd)
    print(f"reference: {res.steps} steps at {ref_ppd} ppd", flush=True)
    names = ["kutta3", "rk4"]
    for c2, c3 in itertools.product(nodes, nodes):
        name = f"kutta4_{c2:g}_{c3:g}"
        try:
            steppers.STEPPERS[name] = steppers.kutta4_tableau(Fraction(c2).limit_denominator(100),
                                                              Fraction(c3).limit_denominator(100), name)
        except ValueError:
            continue
        names.append(name)
    rows = []
    for name in names:
        tb = steppers.get_stepper(name)
        row = {"stepper": name, "c": tb.c.tolist(), "max_abs_coefficient": float(max(np.abs(tb.a).max(), np.abs(tb.b).max())),
               "errors": {}}
        for ppd in ppds:
            _, r, _ = bs.run(Scheme.preset("accurate", stepper=name, cfl=args.cfl), ppd, perturb=args.perturb)
            row["errors"][str(ppd)] = bs.errors(r, ppd, ref, ref_ppd)
        rows.append(row)
        print(f"{name:22s} " + "  ".join(f"ppd {p}: h {e['mass_centre']:.4f} d, ρ̄ {e['density_1d']:.4f}"
                                         for p, e in row["errors"].items())
              + f"  max|coef| {row['max_abs_coefficient']:.2f}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"cfl": args.cfl, "ppd": ppds, "perturb": args.perturb, "t_end_s": bs.T, "rows": rows}, fh, indent=2)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
