"""Does the Eulerian bed's time step bound the waves its fluxes use?  (A review's open point.)

    python bench/check_face_wave_speed.py [--gamma 3] [--cycles 8] [--cells-per-d 4] [--dim 1]

:func:`bsrflow.numerics.bed_eulerian.bed_stable_dt` takes, per cell, the rate
Σ_a (c + c_k + |u_a|)/Δx_a with c the contact wave speed bound and c_k the cell's kinetic sound
speed.  The fluxes (HLLE across x and y, HLLC along z, whose contact speed lies between the two)
take their wave bounds S_L, S_R from the face states, whose φ and θ are reconstructed
independently, so a face's c_k may exceed both its cells'.  This runs the Γ bed
(``bsrflow.physics.granular_bed.BedSetup``'s defaults, the LIGGGHTS bed's) on the grid and, 50
times a cycle, evaluates the vertical faces' bounds with the NumPy twin
(:func:`bsrflow.numerics.bed_eulerian_reference.axis_fluxes_numpy`'s formulas): it prints the
largest face c_k over the largest cell c_k, and the largest face max(|S_L|, |S_R|) over the
largest cell rate's vertical term c + c_k + |u_z|, with the cells' own values (up to 1.0002 since
the HLLC flux along z, 2026-12-05) and as the step takes it since then (c_k and |u_z| at the
largest φ, θ and |u_z| of the cell and its neighbours).  Exit status 1 if that last ratio exceeds
1 (the fluxes' waves outrun the step's bound), else 0.  Writes nothing; about a minute in 1-D.
"""

from __future__ import annotations

import inspect
import sys

import numpy as np

from _args import Parser, float_in, int_in
from bsrflow.numerics import bed_eulerian_reference as R
from bsrflow.numerics.bed_eulerian import EulerianBed
from bsrflow.physics.granular_bed import BedSetup


def _wave_bounds_function():
    """The twin's face fluxes, returning its wave bounds and face sound speeds instead (the same
    formulas, so that this check cannot drift from the twin the kernels are tested against)."""
    src = inspect.getsource(R.axis_fluxes_numpy)
    assert "    return f, uf" in src
    src = src.replace("def axis_fluxes_numpy(", "def _face_waves(").replace("    return f, uf", "    return SL, SR, ckL, ckR")
    namespace = dict(vars(R))
    exec(src, namespace)
    return namespace["_face_waves"]


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--gamma", type=float_in(0.0, 8.0, lo_open=True), default=3.0,
                    help="Γ = aω²/g, in (0, 8] (default 3)")
    ap.add_argument("--cycles", type=int_in(1, 50), default=8, help="cycles of vibration, in [1, 50] (default 8)")
    ap.add_argument("--cells-per-d", type=int_in(1, 16), default=4, help="vertical cells per d, in [1, 16] (default 4)")
    ap.add_argument("--dim", type=int, choices=(1, 3), default=1, help="1 (column) or 3 (4 x 4 columns, 5 %% mode)")
    args = ap.parse_args(argv)
    waves = _wave_bounds_function()
    s = BedSetup(gamma=args.gamma, cycles=args.cycles)
    bed = EulerianBed(s, args.dim, args.cells_per_d, 4 if args.dim == 3 else 1, 0.05 if args.dim == 3 else 0.0)
    par = R.make_params(s, bed.dx)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    period = 1.0 / s.frequency
    t = 0.0
    worst_rate, worst_ck, worst_own = 0.0, 0.0, 0.0
    for n in range(1, 50 * args.cycles + 1):
        t1 = n * period / 50
        bed.advance(t, t1)
        t = t1
        prim = R.primitives_numpy(bed.q, par["rho_tiny"])
        r, u, th, _ = prim
        SL, SR, ckL, ckR = waves(prim, 2, "wall", par)
        ck = R.kinetic_sound_speed_numpy(r / par["rho_s"], th, par["e"])
        has = r > 0.0
        face = float(np.maximum(np.abs(SL), np.abs(SR)).max())
        own = (par["c_cap"] + ck + np.abs(u[2]))[has].max()
        # the step's bound: c_k and |u_z| at the largest φ, θ, |u_z| of each cell and its
        # vertical neighbours (bed_stable_dt)
        nb = [R._pad(a, "wall")[..., 1:-1] for a in (r, th, np.abs(u[2]))]
        phm = np.maximum(np.maximum(nb[0][..., :-2], nb[0][..., 1:-1]), nb[0][..., 2:])
        thm = np.maximum(np.maximum(nb[1][..., :-2], nb[1][..., 1:-1]), nb[1][..., 2:])
        uzm = np.maximum(np.maximum(nb[2][..., :-2], nb[2][..., 1:-1]), nb[2][..., 2:])
        bound = (par["c_cap"] + R.kinetic_sound_speed_numpy(phm / par["rho_s"], thm, par["e"]) + uzm)[has].max()
        worst_own = max(worst_own, face / own)
        worst_rate = max(worst_rate, face / bound)
        worst_ck = max(worst_ck, float(np.maximum(ckL, ckR).max() / max(ck[has].max(), 1e-300)))
    print(f"Γ = {args.gamma:g}, {args.dim}-D, {args.cells_per_d} cells per d, {args.cycles} cycles "
          f"(contact wave speed bound c = {par['c_cap']:.1f} m/s):")
    print(f"  largest face c_k / largest cell c_k: {worst_ck:.4f}")
    print(f"  largest face wave speed / largest cell c + c_k + |u_z| (the cells' own values): {worst_own:.6f}")
    print(f"  largest face wave speed / the step's bound (bed_stable_dt: the neighbours' largest φ, θ, "
          f"|u_z|): {worst_rate:.6f}")
    return 1 if worst_rate > 1.0 else 0


if __name__ == "__main__":
    sys.exit(main())
