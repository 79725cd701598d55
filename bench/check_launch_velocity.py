"""Velocities of the column just after a tap: the DEM's spheres against the packing continuum's
tracers (issue #18, why the continuum's top sphere rises less than the DEM's).

    python bench/check_launch_velocity.py [--a-over-d 1.5] [--ppd 20] [--at 0.46] [--range 0]

For the seed's column (d = 2.2 cm, 20 spheres, one tap at 0.4 s lasting 0.05 s), prints the
velocity of every sphere centre at time ``--at`` in the laboratory frame, corrected back to the
tap's end by adding g (t − t_end) (free flight), in units of aω: the DEM (the package's) and the
Lagrangian packing continuum (tracers at the sphere centres, finite differences of the saved
heights) with the interaction range ``--range`` R/d (default 0: the local limit, the model the
script was written for; 1: the package's nonlocal interaction).
"""

from __future__ import annotations


import numpy as np

from _args import Parser, positive_float, positive_int
from bsrflow.physics.column import ColumnSetup, run_bsr_column
from bsrflow.physics.dem import DEMColumn, run_dem


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--a-over-d", type=positive_float, default=1.5, help="tap amplitude over d (default 1.5)")
    ap.add_argument("--ppd", type=positive_int, default=20, help="the continuum's points per diameter (default 20)")
    ap.add_argument("--at", type=positive_float, default=0.46, help="time [s] after the tap's end (0.45 s)")
    ap.add_argument("--range", type=float, default=0.0, help="R/d of the packing interaction (default 0, local)")
    args = ap.parse_args(argv)
    s = ColumnSetup(a_over_d=args.a_over_d, t_end=args.at + 0.01, save_every=0.0005)
    t_tap_end = s.tap_start + 0.5 / s.frequency
    if args.at <= t_tap_end:
        ap.error(f"--at must be after the tap's end, {t_tap_end:g} s")
    try:
        packing = s.with_(kernel_name="packing", formulation="lagrangian", points_per_diameter=args.ppd,
                          range_over_d=args.range)
    except ValueError as exc:
        ap.error(str(exc))
    aw = s.amplitude * s.omega
    col = DEMColumn(n_spheres=s.n_spheres, diameter=s.diameter, density=s.density, stiffness=s.stiffness,
                    restitution=s.restitution, gravity=s.gravity)
    r = run_dem(col, s.motion(), s.t_end, sample_interval=s.save_every)
    k = int(np.argmin(np.abs(np.asarray(r.t) - args.at)))
    v_dem = (np.asarray(r.velocities)[k] + s.gravity * (r.t[k] - t_tap_end)) / aw
    run = run_bsr_column(packing)
    j = int(np.argmin(np.abs(run.t - args.at)))
    v_c = (np.gradient(run.tracers, run.t, axis=0)[j] + s.gravity * (run.t[j] - t_tap_end)) / aw
    np.set_printoptions(precision=3, linewidth=120)
    print(f"a/d = {args.a_over_d}, velocities at t = {args.at} s corrected to the tap's end, in units of "
          f"a w = {aw:.4g} m/s, bottom sphere first:")
    print("DEM      ", v_dem)
    print(f"continuum (lagrangian, R = {args.range:g} d)", v_c)
    print(f"DEM: {v_dem.min():.3f} to {v_dem.max():.3f}, mean {v_dem.mean():.3f}; continuum: {v_c.min():.3f} to "
          f"{v_c.max():.3f}, mean {v_c.mean():.3f}")


if __name__ == "__main__":
    main()
