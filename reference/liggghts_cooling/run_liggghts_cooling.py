#!/usr/bin/env python3
"""Homogeneous cooling of the bed's spheres in a periodic box (LIGGGHTS): the contact law's own
collisional loss against the solid fraction, measured apart from any bed (issue #19).

The vibrated bed's continuum loses fluctuation energy at Enskog's rate
12 (1 - e^2) g0(phi) rho_s phi^2 theta^(3/2) / (d sqrt(pi)) with Carnahan-Starling's g0; in a
homogeneous cooling state that is Haff's law d(theta^(-1/2))/dt = 4 (1 - e^2) g0 phi / (d sqrt(pi)).
This script measures that slope for the spheres and contact law of reference/liggghts_bed
(d = 5 mm, 1200 kg/m^3, Walton-Braun K = 5e4 N/m, e = 0.9, frictionless) at solid fractions from
dilute to close packing, so that the loss of the packed state can be set from the contact law
alone (not from the bed).

  python reference/liggghts_cooling/run_liggghts_cooling.py                 # every phi of PHIS
  python reference/liggghts_cooling/run_liggghts_cooling.py --phi 0.6 0.62

Per phi: N = 2000 spheres inserted at random (seed 12345) in a periodic cube at the phi that
random insertion reaches, compressed to phi by `fix deform` with elastic contacts (e = 1, so that
the compression keeps them agitated), relaxed at fixed phi under a strong drag (the compression's
heat and its overlaps' elastic energy taken out), then given Gaussian velocities of variance
theta_0 per component (zero total momentum) and let cool with the contact law (e = 0.9); the
kinetic energy every 20 steps, with the contacts' (pair virial) pressure.  Results: cooling.csv (t, theta per
phi, every 1e-4 s) and summary.json (the fitted slope of theta^(-1/2) while theta falls from
0.9 theta_0 to theta_0/4 and the contact value g0 it implies, beside Carnahan-Starling's; and the
pressure route's g0, from p_c = 2 (1 + e) rho_s phi^2 g0 theta over the same window).  Big files
go to work/.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("run_liggghts", HERE.parent / "liggghts_bed" / "run_liggghts.py")
bed = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bed)

N = 2000
THETA0 = 0.01            # initial granular temperature [m^2/s^2] (the bed's, ~0.1 m/s)
PHIS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.55, 0.58, 0.6, 0.61, 0.62, 0.63)
PHI_INSERT = 0.25
COMPRESS_S = 0.05        # compression time [s]
COOL_S = 0.05            # cooling time [s]
RELAX_S = 0.03           # relaxation at fixed phi after the compression [s]
RELAX_TAU_S = 1e-3       # its drag's relaxation time m/gamma [s]
PRINT_EVERY = 20
SEED = 12345


def g0_cs(phi):
    return (1.0 - 0.5 * phi) / (1.0 - phi) ** 3


def write_data(path: Path, pos, vel, lx: float) -> None:
    lines = ["LIGGGHTS data file written by run_liggghts_cooling.py", "", f"{len(pos)} atoms", "2 atom types", "",
             f"0 {lx:.10g} xlo xhi", f"0 {lx:.10g} ylo yhi", f"0 {lx:.10g} zlo zhi", "", "Atoms", ""]
    for i, p in enumerate(pos):
        lines.append(f"{i + 1} 1 {bed.D:.10g} {bed.RHO:.10g} {p[0]:.10g} {p[1]:.10g} {p[2]:.10g}")
    lines += ["", "Velocities", ""]
    for i, v in enumerate(vel):
        lines.append(f"{i + 1} {v[0]:.8g} {v[1]:.8g} {v[2]:.8g} 0 0 0")
    path.write_text("\n".join(lines) + "\n")


def header() -> str:
    return """# written by reference/liggghts_cooling/run_liggghts_cooling.py
units           si
atom_style      granular
atom_modify     map array
boundary        p p p
newton          off
communicate     single vel yes
processors      1 1 1
"""


def max_overlap(pos, lx: float) -> float:
    """The largest overlap d − r [m] of any pair in the periodic cube of side lx (0 when none)."""
    from scipy.spatial import cKDTree
    pairs = cKDTree(pos, boxsize=lx).query_pairs(bed.D, output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    dx = pos[pairs[:, 0]] - pos[pairs[:, 1]]
    dx -= lx * np.round(dx / lx)
    return float(bed.D - np.sqrt((dx * dx).sum(axis=1)).min())


def deck_start(data: str, contact: str, dt: float) -> str:
    """The deck up to the integrator: the box and spheres of ``data``, the contact law, the step."""
    return header() + f"""read_data       {data}
neighbor        {0.1 * bed.D:.6g} bin
neigh_modify    delay 0
{contact}
timestep        {dt:.12g}
fix integr all nve/sphere
"""


def gaussian(n, theta, rng):
    v = rng.normal(0.0, math.sqrt(theta), (n, 3))
    return v - v.mean(axis=0)


def run_phi(phi: float, work: Path) -> dict:
    rng = np.random.default_rng(SEED)
    wd = work / f"phi_{phi:.3f}"
    wd.mkdir(parents=True, exist_ok=True)
    dt, _ = bed.timestep()
    l_ins = (N * bed.VOL / PHI_INSERT) ** (1.0 / 3.0)
    l_end = (N * bed.VOL / phi) ** (1.0 / 3.0)
    # random insertion in the cube, a gap of 1.2 d kept at the top so that no pair overlaps across z
    pos = bed.random_insert(N, l_ins, N * bed.VOL / (l_ins * l_ins * (l_ins - 1.2 * bed.D)), rng)
    write_data(wd / "start.data", pos, gaussian(N, THETA0, rng), l_ins)
    e_save = bed.E_REST
    bed.E_REST = 1.0
    contact_elastic = bed.deck_contact("walton_braun", 0.0)
    bed.E_REST = e_save
    contact = bed.deck_contact("walton_braun", 0.0)
    n_comp = int(round(COMPRESS_S / dt))
    deck = deck_start("start.data", contact_elastic, dt) + f"""fix squeeze all deform 1 x final 0 {l_end:.12g} y final 0 {l_end:.12g} z final 0 {l_end:.12g} remap x
thermo_style    custom step atoms ke
thermo          {max(1, n_comp // 10)}
thermo_modify   norm no
run {n_comp}
unfix squeeze
# relax at fixed phi: a strong drag (relaxation time {RELAX_TAU_S:g} s) takes out the compression's
# heat and the elastic energy of its overlaps, so that the cooling starts from theta_0 alone
fix damp all viscous {bed.MASS / RELAX_TAU_S:.10g}
run {int(round(RELAX_S / dt))}
unfix damp
write_dump all custom compressed.dump id x y z vx vy vz modify sort id
"""
    (wd / "in.compress").write_text(deck)
    wall_c = bed.run_liggghts(wd / "in.compress", wd, Path("log.compress"))
    _, ids, x = bed.last_frame(wd / "compressed.dump")
    relaxed_ke = 0.5 * bed.MASS * float((x[:, 3:6] ** 2).sum())
    overlap = max_overlap(x[:, :3] % l_end, l_end)
    v0 = gaussian(N, THETA0, rng)
    theta_start = float((v0 ** 2).sum() / (3.0 * N))
    write_data(wd / "cool.data", x[:, :3] % l_end, v0, l_end)
    n_cool = int(round(COOL_S / dt))
    deck = deck_start("cool.data", contact, dt) + f"""compute k all ke
compute sa all stress/atom pair
compute ps all reduce sum c_sa[1] c_sa[2] c_sa[3]
variable st equal step
variable en equal c_k
variable na equal atoms
variable pc equal -(c_ps[1]+c_ps[2]+c_ps[3])/(3*vol)
fix pr all print {PRINT_EVERY} "${{st}} ${{en}} ${{na}} ${{pc}}" file ke.txt screen no title "# step kinetic_energy_J atoms collisional_pressure_Pa"
thermo_style    custom step atoms ke
thermo          {max(1, n_cool // 10)}
thermo_modify   norm no
run {n_cool}
"""
    (wd / "in.cool").write_text(deck)
    wall = bed.run_liggghts(wd / "in.cool", wd, Path("log.cool"))
    a = bed.read_columns(wd / "ke.txt")
    a = np.vstack([[0.0, 1.5 * N * bed.MASS * theta_start, N, np.nan], a])     # t = 0: the velocities given
    t = a[:, 0] * dt
    theta = 2.0 * a[:, 1] / (3.0 * N * bed.MASS)
    # Haff: theta^(-1/2) linear in t; its slope while theta falls from 0.9 theta_0 to theta_0/4 (the
    # first tenth left to the structure's adjustment to the new velocities)
    start = int(np.argmax(theta < 0.9 * THETA0)) if (theta < 0.9 * THETA0).any() else 1
    fall = theta >= THETA0 / 4.0
    stop = int(np.argmin(fall)) if not fall.all() else len(theta)
    sl = np.polyfit(t[start:stop], theta[start:stop] ** -0.5, 1)[0] if stop - start > 5 else float("nan")
    enskog = 4.0 * (1.0 - bed.E_REST ** 2) * phi / (bed.D * math.sqrt(math.pi))     # per unit g0
    # the pressure route: the contacts' (virial) pressure p_c = 2 (1 + e) rho_s phi^2 g0 theta, its
    # least-squares proportion to theta over the same window
    pc, th = a[start:stop, 3], theta[start:stop]
    g0_p = float(np.sum(pc * th) / np.sum(th * th) / (2.0 * (1.0 + bed.E_REST) * bed.RHO * phi * phi))
    return {"phi": phi, "box_m": l_end, "dt_s": dt, "slope_theta_inv_sqrt_s_per_m": float(sl),
            "g0_measured": float(sl / enskog), "g0_carnahan_starling": g0_cs(phi),
            "ratio_to_carnahan_starling": float(sl / enskog / g0_cs(phi)),
            "g0_pressure_route": g0_p, "ratio_pressure_route_to_carnahan_starling": g0_p / g0_cs(phi),
            "fit_window_s": [float(t[start]), float(t[stop - 1])] if stop > start else None,
            "theta_start_m2_s2": theta_start, "theta_max_m2_s2": float(theta.max()),
            "relaxed_kinetic_energy_J": relaxed_ke, "relaxed_max_overlap_over_d": overlap / bed.D,
            "theta_end_m2_s2": float(theta[-1]), "atoms_final": int(a[-1, 2]),
            "wall_time_s": wall + wall_c, "t": t, "theta": theta}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--phi", type=float, nargs="+", default=list(PHIS))
    ap.add_argument("--root", metavar="DIR", help="write work/ and the results under DIR instead of this folder")
    a = ap.parse_args(argv)
    for p in a.phi:
        if not 0.0 < p < 0.64:
            ap.error(f"argument --phi: {p!r} is outside the valid range (0, 0.64)")
    root = Path(a.root).resolve() if a.root else HERE
    work = root / "work"
    work.mkdir(parents=True, exist_ok=True)
    runs = []
    for p in a.phi:
        r = run_phi(p, work)
        print(f"phi {p:.3f}: slope {r['slope_theta_inv_sqrt_s_per_m']:.1f} /(m/s) s, g0 {r['g0_measured']:.2f} "
              f"(Carnahan-Starling {r['g0_carnahan_starling']:.2f}, ratio {r['ratio_to_carnahan_starling']:.3f}; "
              f"pressure route {r['g0_pressure_route']:.2f}, ratio {r['ratio_pressure_route_to_carnahan_starling']:.3f}), "
              f"{r['wall_time_s']:.1f} s", flush=True)
        runs.append(r)
    grid = np.arange(0.0, COOL_S + 1e-12, 1e-4)
    with open(root / "cooling.csv", "w") as f:
        f.write(f"# homogeneous cooling, N = {N}, theta_0 = {THETA0} m^2/s^2, Walton-Braun K = {bed.K_N:g} N/m, "
                f"e = {bed.E_REST:g}, d = {bed.D:g} m, rho_s = {bed.RHO:g} kg/m^3; theta = 2 KE/(3 N m) [m^2/s^2] "
                "against t [s]\n")
        f.write("t_s," + ",".join(f"theta_phi{r['phi']:.3f}_m2_s2" for r in runs) + "\n")
        cols = [np.interp(grid, r["t"], r["theta"]) for r in runs]
        for i, tt in enumerate(grid):
            f.write(f"{tt:.4f}," + ",".join(f"{c[i]:.5e}" for c in cols) + "\n")
    summ = {"n": N, "theta0_m2_s2": THETA0, "K_N_m": bed.K_N, "e": bed.E_REST, "d_m": bed.D, "rho_s_kg_m3": bed.RHO,
            "compress_s": COMPRESS_S, "cool_s": COOL_S, "seed": SEED,
            "runs": [{k: v for k, v in r.items() if k not in ("t", "theta")} for r in runs]}
    (root / "summary.json").write_text(json.dumps(summ, indent=2))


if __name__ == "__main__":
    main()
