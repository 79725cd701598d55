"""The demo's three-tap column (a/d = 0.75, taps 0.6 s apart, to 2.5 s) in the Eulerian form of
the nonlocal packing interaction at several grids: the top maximum of each tap [d], beside the
built-in DEM's.  Prints one line per grid (runs one after the other, one core each).

    python bench/check_eulerian_three_taps.py [--ppd 5,10,20] [--formulation eulerian]

(20 cells per diameter takes about 4 minutes on a 2-core VM.)
"""

from __future__ import annotations


import numpy as np

from bsrflow.physics.column import ColumnSetup, run_packing_column
from bsrflow.analysis.compare import run_dem_column
from _args import Parser, list_of, positive_int  # noqa: E402


def tap_maxima(t, top, setup) -> list[float]:
    """The top's maximum [d] in each tap period."""
    out = []
    for k in range(setup.n_taps):
        t0 = setup.tap_start + k * setup.tap_period
        sel = (t >= t0) & (t < t0 + setup.tap_period)
        out.append(float(np.max(top[sel])) / setup.diameter)
    return out


def main(argv=None) -> int:
    ap = Parser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--ppd", type=list_of(positive_int), default=[5, 10, 20], help="cells per diameter")
    ap.add_argument("--formulation", choices=("eulerian", "lagrangian"), default="eulerian",
                    help="the packing continuum's formulation (default eulerian)")
    args = ap.parse_args(argv)
    base = ColumnSetup(kernel_name="packing", formulation=args.formulation, a_over_d=0.75, n_taps=3, t_end=2.5)
    try:                                   # every grid checked before the work starts
        setups = [base.with_(points_per_diameter=ppd) for ppd in args.ppd]
    except ValueError as exc:
        ap.error(f"--ppd: {exc}")
    t, positions, _ = run_dem_column(base)
    print(f"DEM: taps reach {' / '.join(f'{v:.2f}' for v in tap_maxima(t, positions[:, -1], base))} d")
    for s in setups:
        r = run_packing_column(s)
        print(f"{args.formulation} R=1d, {s.points_per_diameter} per diameter (tap period {s.tap_period:g} s): taps reach "
              f"{' / '.join(f'{v:.2f}' for v in tap_maxima(r.t, r.top, s))} d ({r.wall_time:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
