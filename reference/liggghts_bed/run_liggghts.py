#!/usr/bin/env python3
"""LIGGGHTS reference for a vertically vibrated bed of spheres (issue #19).

The script writes the LIGGGHTS input decks, runs LIGGGHTS (serial, one core) and
reduces its output into small CSV/JSON files next to this script:

  python reference/liggghts_bed/run_liggghts.py --check            # contact-law checks
  python reference/liggghts_bed/run_liggghts.py --settle           # pour + settle, N=2000
  python reference/liggghts_bed/run_liggghts.py --gamma 3          # vibrate the settled bed
  python reference/liggghts_bed/run_liggghts.py --gamma 3 --model hooke --friction 0.5
  python reference/liggghts_bed/run_liggghts.py --gamma 3 --model hooke            # its control
  python reference/liggghts_bed/run_liggghts.py --gamma 1.5 2 2.5 3.5 4 4.5 5 5.5 6 6.5 7 7.5 8 --model hooke
  python reference/liggghts_bed/run_liggghts.py --gamma 4 --restitution 0.5       # exploratory
  python reference/liggghts_bed/run_liggghts.py --gamma 1.5 2 2.5 3 3.5 4 4.5 5 5.5 6 6.5 7 7.5 8 --floor-restitution 1
  python reference/liggghts_bed/run_liggghts.py --settle --n 10000 --lateral 29
  python reference/liggghts_bed/run_liggghts.py --gamma 3 --n 10000 --lateral 29
  python reference/liggghts_bed/run_liggghts.py --gamma 2 3 4.5 --floor-power   # + the floor contacts' loss
  python reference/liggghts_bed/run_liggghts.py --summary          # flight_vs_gamma.csv

Big files (dumps, restarts, logs) go to reference/liggghts_bed/work/ (not committed).
Only numpy is needed besides the `liggghts` executable (Debian package, 3.8.0).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
WORK = HERE / "work"
RESULTS = HERE / "results"
OUT = HERE          # where params.json and the settled-bed JSON go (--root moves all three)

# ---------------------------------------------------------------- parameters
D = 5.0e-3            # sphere diameter [m]
RHO = 1200.0          # material density [kg/m^3]
E_REST = 0.9          # normal coefficient of restitution (Walton-Braun: K_unload = K/e^2)
K_N = 5.0e4           # loading normal stiffness [N/m] (reduced stiffness, see README; --stiffness)
DEFAULT_K_N = K_N
FREQ = 20.0           # floor frequency [Hz]
G = 9.81              # gravity [m/s^2]
SAMPLES_PER_CYCLE = 40          # dump frequency: 1/(40 f)
STEPS_PER_CONTACT = 50          # dt ~ t_contact / 50 (pair contact, the shortest one)
CYCLES_STARTUP = 3
CYCLES_MEASURED = 8
FORCE_EVERY = 10                # floor force / overlap sampling [steps]
SEED = 12345                    # the random insertion of the settled bed (--seed: another packing)
DEFAULT_SEED = SEED
E_FLOOR = None        # restitution of the sphere-floor contacts when it differs from E_REST (--floor-restitution)
FLOOR_POWER = False   # also measure the floor contacts' energy budget (--floor-power)

MASS = RHO * math.pi * D ** 3 / 6.0
VOL = math.pi * D ** 3 / 6.0
OMEGA = 2.0 * math.pi * FREQ
PERIOD = 1.0 / FREQ


def contact_time(meff: float, k: float = K_N, e: float = E_REST) -> float:
    """Duration of a Walton-Braun (linear hysteretic, no dashpot) contact.

    Loading half-oscillation with K, unloading with K/e^2:
    t_c = (pi/2) sqrt(meff/K) (1 + e)."""
    return 0.5 * math.pi * math.sqrt(meff / k) * (1.0 + e)


def hooke_contact_time(meff: float, k: float = K_N, e: float = E_REST) -> float:
    """Duration of a linear spring-dashpot contact with restitution e."""
    ln = math.log(e)
    w0 = math.sqrt(k / meff)
    return math.pi / (w0 * math.sqrt(1.0 - ln * ln / (ln * ln + math.pi ** 2)))


def timestep() -> tuple[float, int]:
    """dt ~ t_c(pair)/50, adjusted so that the dump interval 1/(40 f) is an integer
    number of steps. Returns (dt, steps per dump)."""
    tc = contact_time(MASS / 2.0, K_N)
    dump_dt = PERIOD / SAMPLES_PER_CYCLE
    n = math.ceil(dump_dt / (tc / STEPS_PER_CONTACT))
    return dump_dt / n, n


# ---------------------------------------------------------------- deck pieces

def deck_header(lx: float, zlo: float, zhi: float, ntypes: int = 2) -> str:
    return f"""# written by reference/liggghts_bed/run_liggghts.py
units           si
atom_style      granular
atom_modify     map array
boundary        p p f
newton          off
communicate     single vel yes
processors      1 1 1
"""


def deck_contact(model: str, mu: float) -> str:
    """Material properties and pair style.

    model = 'walton_braun': edinburgh/stiffness, linear (overlapExponent 1),
            no adhesion, no dashpot (coefficientRestitution 1 -> log 0 -> gamma_n 0),
            unloading stiffness K/e^2 (UnloadingStiffness is the ratio K_unload/K).
            In LIGGGHTS 3.8.0 edinburgh/stiffness is compiled only with the
            tangential model no_history; with no dashpot its tangential force is zero,
            i.e. frictionless.
    model = 'hooke': hooke/stiffness + tangential history, viscoelastic dashpot
            chosen for restitution e separately for sphere-sphere (type 1-1)
            and sphere-floor (type 1-2) contacts, tangential_damping off,
            absolute damping (gamman_abs, gammat_abs).
    Type 1 = spheres, type 2 = floor mesh."""
    k = K_N
    if model == "walton_braun":
        if mu != 0.0:
            raise SystemExit("edinburgh/stiffness in LIGGGHTS 3.8.0 has no friction without "
                             "a dashpot; use --model hooke for friction")
        r = 1.0 / E_REST ** 2
        rw = r if E_FLOOR is None else 1.0 / E_FLOOR ** 2      # the sphere-floor pairs (1-2, 2-1)
        return f"""
# Walton-Braun: linear loading K, unloading K/e^2, no dashpot, no adhesion
fix m1 all property/global LoadingStiffness peratomtypepair 2 {k:.10g} {k:.10g} {k:.10g} {k:.10g}
fix m2 all property/global UnloadingStiffness peratomtypepair 2 {r:.10g} {rw:.10g} {rw:.10g} {r:.10g}
fix m3 all property/global coefficientRestitution peratomtypepair 2 1.0 1.0 1.0 1.0
fix m4 all property/global overlapExponent scalar 1.0
fix m5 all property/global adhesionExponent scalar 1.0
fix m6 all property/global pullOffForce peratomtypepair 2 0.0 0.0 0.0 0.0
fix m7 all property/global surfaceEnergy peratomtypepair 2 0.0 0.0 0.0 0.0
fix m8 all property/global coefficientAdhesionStiffness peratomtypepair 2 0.0 0.0 0.0 0.0
fix m9 all property/global coefficientFriction peratomtypepair 2 0.0 0.0 0.0 0.0
pair_style      gran model edinburgh/stiffness tangential no_history
pair_coeff      * *
"""
    if model == "hooke":
        def gam(meff, e):  # absolute dashpot coefficient for restitution e (0, not -0, at e = 1)
            ln = math.log(e)
            return abs(2.0 * math.sqrt(meff * k) * ln / math.sqrt(math.pi ** 2 + ln * ln))
        g11 = gam(MASS / 2.0, E_REST)
        g12 = gam(MASS, E_REST if E_FLOOR is None else E_FLOOR)   # the sphere-floor pairs
        kt = 2.0 / 7.0 * k
        tang = "history" if mu > 0 else "no_history"
        return f"""
# linear spring-dashpot (hooke/stiffness), restitution e for sphere-sphere and sphere-floor
fix m1 all property/global kn peratomtypepair 2 {k:.10g} {k:.10g} {k:.10g} {k:.10g}
fix m2 all property/global kt peratomtypepair 2 {kt:.10g} {kt:.10g} {kt:.10g} {kt:.10g}
fix m3 all property/global gamman_abs peratomtypepair 2 {g11:.10g} {g12:.10g} {g12:.10g} {g12:.10g}
fix m4 all property/global gammat_abs peratomtypepair 2 0.0 0.0 0.0 0.0
fix m5 all property/global coefficientFriction peratomtypepair 2 {mu:.10g} {mu:.10g} {mu:.10g} {mu:.10g}
pair_style      gran model hooke/stiffness tangential {tang} absolute_damping on tangential_damping off limitForce on
pair_coeff      * *
"""
    raise SystemExit(f"unknown model {model}")


def wall_fix(model: str, mu: float, store_force: bool = False) -> str:
    """fix wall/gran arguments: models, the floor mesh (then ``store_force yes``, a general keyword,
    which LIGGGHTS takes only before the model keywords), then model keywords."""
    mesh = "mesh n_meshes 1 meshes floor" + (" store_force yes" if store_force else "")
    if model == "walton_braun":
        return f"model edinburgh/stiffness tangential no_history {mesh}"
    tang = "history" if mu > 0 else "no_history"
    return (f"model hooke/stiffness tangential {tang} {mesh} absolute_damping on "
            "tangential_damping off limitForce on")


def write_floor_stl(path: Path, lx: float) -> None:
    """Two triangles covering the periodic cross-section [0,lx]^2 at z = 0."""
    v = [(0, 0, 0), (lx, 0, 0), (lx, lx, 0), (0, lx, 0)]
    tri = [(v[0], v[1], v[2]), (v[0], v[2], v[3])]
    lines = ["solid floor"]
    for t in tri:
        lines += ["facet normal 0 0 1", "outer loop"]
        lines += [f"vertex {p[0]:.10g} {p[1]:.10g} {p[2]:.10g}" for p in t]
        lines += ["endloop", "endfacet"]
    lines.append("endsolid floor")
    path.write_text("\n".join(lines) + "\n")


LAST_CPU = [0.0]   # CPU time (user+sys) of the last LIGGGHTS run [s]


def run_liggghts(deck: Path, cwd: Path, log: Path) -> float:
    """Run LIGGGHTS serially; return wall time [s] (CPU time in LAST_CPU[0])."""
    t0 = time.perf_counter()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(cwd / (deck.name + ".screen"), "w") as scr:
        p = subprocess.run(["liggghts", "-in", deck.name, "-log", log.name, "-nocite"],
                           cwd=cwd, stdout=scr, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    LAST_CPU[0] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if p.returncode != 0:
        tail = (cwd / (deck.name + ".screen")).read_text(errors="replace").splitlines()[-20:]
        raise SystemExit(f"LIGGGHTS failed ({deck}):\n" + "\n".join(tail))
    txt = (cwd / log.name).read_text()
    if "ERROR" in txt:
        raise SystemExit(f"LIGGGHTS reported an error in {log}")
    return wall


def read_columns(path: Path) -> np.ndarray:
    """Numeric rows of a fix print file (lines starting with # skipped)."""
    return np.loadtxt(path, comments="#", ndmin=2)


# ---------------------------------------------------------------- contact checks

def check_contacts(model: str) -> dict:
    """Single sphere on the floor and two-sphere head-on collision, no gravity."""
    wd = WORK / (f"check_{model}" + ("" if E_REST == 0.9 else f"_e{E_REST:g}"))
    wd.mkdir(parents=True, exist_ok=True)
    lx = 13 * D
    write_floor_stl(wd / "floor.stl", lx)
    dt, _ = timestep()
    out = {"model": model, "dt_s": dt}
    v0 = 0.5
    for case in ("wall", "pair", "wall_near_periodic_edge"):
        if case == "pair":
            atoms = (f"create_atoms 1 single {lx/2:.6g} {lx/2:.6g} 0.03 units box\n"
                     f"create_atoms 1 single {lx/2 + D + 0.0005:.6g} {lx/2:.6g} 0.03 units box\n"
                     f"set atom 1 diameter {D} density {RHO} vx {v0/2}\n"
                     f"set atom 2 diameter {D} density {RHO} vx {-v0/2}\n")
            obs = "variable v1 equal vx[1]\nvariable v2 equal vx[2]\nvariable x1 equal x[1]\nvariable x2 equal x[2]\n"
            pr = "${st} ${v1} ${v2} ${x1} ${x2} ${fz}"
        else:
            x0 = lx / 2 if case == "wall" else 0.2 * D
            atoms = (f"create_atoms 1 single {x0:.6g} {lx/2:.6g} {D/2 + 0.0005:.6g} units box\n"
                     f"set atom 1 diameter {D} density {RHO} vz {-v0}\n")
            obs = "variable v1 equal vz[1]\nvariable x1 equal z[1]\n"
            pr = "${st} ${v1} ${x1} ${fz}"
        deck = deck_header(lx, -0.01, 0.1) + f"""
region          box block 0 {lx:.10g} 0 {lx:.10g} -0.01 0.1 units box
create_box      2 box
neighbor        {0.1*D:.6g} bin
neigh_modify    delay 0
{deck_contact(model, 0.0)}
timestep        {dt:.10g}
fix floor all mesh/surface/stress file floor.stl type 2
fix wall all wall/gran {wall_fix(model, 0.0)}
{atoms}
fix integr all nve/sphere
variable st equal step
variable fz equal f_floor[3]
{obs}
fix pr all print 1 "{pr}" file {case}.txt screen no title "# step v x F"
run {int(round(0.002 / dt))}
"""
        (wd / f"in.{case}").write_text(deck)
        run_liggghts(wd / f"in.{case}", wd, Path(f"log.{case}"))
        a = read_columns(wd / f"{case}.txt")
        if case == "pair":
            gap = (a[:, 4] - a[:, 3]) - D
            c = gap < 0
            vin, vout = a[0, 2] - a[0, 1], a[-1, 2] - a[-1, 1]
            meff = MASS / 2
            delta_max = -gap.min()
        else:
            c = a[:, 3] != 0.0
            vin, vout = a[0, 1], a[-1, 1]
            meff = MASS
            delta_max = D / 2 - a[:, 2].min()
        n_c = int(c.sum())
        res = {"v_in_m_s": float(vin), "v_out_m_s": float(vout),
               "restitution_measured": float(abs(vout / vin)),
               "contact_time_measured_s": n_c * dt,
               "contact_time_theory_s": contact_time(meff, K_N, E_REST) if model == "walton_braun"
               else hooke_contact_time(meff, K_N, E_REST),
               "max_overlap_measured_m": float(delta_max),
               "max_overlap_theory_m": abs(vin) * math.sqrt(meff / K_N) if model == "walton_braun"
               else None}
        out[case] = res
    return out


# ---------------------------------------------------------------- settling

def random_insert(n: int, lx: float, phi0: float, rng) -> np.ndarray:
    """Random sequential insertion of n non-overlapping spheres (centres) in a
    laterally periodic column of cross-section lx^2, loose solid fraction phi0."""
    h = n * VOL / (phi0 * lx * lx)
    z0 = 0.6 * D
    nc = max(1, int(lx // (1.01 * D)))
    cell = lx / nc
    nz = int(h // cell) + 2
    grid: dict[tuple[int, int, int], list[int]] = {}
    pos = np.empty((n, 3))
    k = 0
    tries = 0
    while k < n:
        tries += 1
        if tries > 200 * n:
            raise SystemExit("random insertion failed; lower phi0")
        p = np.array([rng.uniform(0, lx), rng.uniform(0, lx), rng.uniform(z0, z0 + h)])
        ci, cj, ck = int(p[0] // cell) % nc, int(p[1] // cell) % nc, int((p[2] - z0) // cell)
        ok = True
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                for dk in (-1, 0, 1):
                    for q in grid.get(((ci + di) % nc, (cj + dj) % nc, ck + dk), ()):
                        dx = pos[q] - p
                        dx[:2] -= lx * np.round(dx[:2] / lx)
                        if dx @ dx < (1.02 * D) ** 2:
                            ok = False
                            break
                    if not ok:
                        break
                if not ok:
                    break
            if not ok:
                break
        if ok:
            pos[k] = p
            grid.setdefault((ci, cj, ck), []).append(k)
            k += 1
    return pos


def write_data(path: Path, pos: np.ndarray, lx: float, zlo: float, zhi: float) -> None:
    lines = ["LIGGGHTS data file written by run_liggghts.py", "",
             f"{len(pos)} atoms", "2 atom types", "",
             f"0 {lx:.10g} xlo xhi", f"0 {lx:.10g} ylo yhi", f"{zlo:.10g} {zhi:.10g} zlo zhi",
             "", "Atoms", ""]
    for i, p in enumerate(pos):
        lines.append(f"{i+1} 1 {D:.10g} {RHO:.10g} {p[0]:.10g} {p[1]:.10g} {p[2]:.10g}")
    path.write_text("\n".join(lines) + "\n")


def tag(n: int, lateral: float) -> str:
    """N<n>_L<L/d>d, then _seed<s> for a packing poured with another seed than the default's and
    _K<K> for another contact stiffness (settled with it too)."""
    return (f"N{n}_L{lateral:g}d" + ("" if SEED == DEFAULT_SEED else f"_seed{SEED}")
            + ("" if K_N == DEFAULT_K_N else f"_K{K_N:.12g}"))


def box_top(n: int, lx: float) -> float:
    """Open top: the box is much taller than the bed (atoms above it would be lost)."""
    return max(0.5, 4.0 * n * VOL / (0.3 * lx * lx))


def settle(n: int, lateral: float, model: str) -> dict:
    lx = lateral * D
    wd = WORK / f"settle_{tag(n, lateral)}_{model}"
    wd.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    pos = random_insert(n, lx, 0.3, rng)
    zlo, zhi = -0.02, box_top(n, lx)
    write_data(wd / "init.data", pos, lx, zlo, zhi)
    write_floor_stl(wd / "floor.stl", lx)
    dt, _ = timestep()
    dts = 2.0 * dt   # settling only: t_c/25 is ample for a bed coming to rest
    t_drag, t_drag2 = 0.30, 0.20
    gamma_drag = MASS / 0.05   # drag relaxation time 0.05 s while pouring/settling
    gamma_drag2 = MASS / 0.005  # then 0.005 s to remove the residual jiggling
    deck = deck_header(lx, zlo, zhi) + f"""
read_data       init.data
neighbor        {0.1*D:.6g} bin
neigh_modify    delay 0
{deck_contact(model, 0.0)}
timestep        {dts:.10g}
fix floor all mesh/surface/stress file floor.stl type 2
fix wall all wall/gran {wall_fix(model, 0.0)}
fix grav all gravity {G} vector 0 0 -1
fix integr all nve/sphere
fix drag all viscous {gamma_drag:.10g}
compute ke all ke
compute pc all pair/gran/local id delta
compute wc all wall/gran/local id delta
thermo_style    custom step time atoms c_ke f_floor[3]
thermo          {int(0.01/dts)}
thermo_modify   lost ignore norm no
run {int(round(t_drag/dts))}
unfix drag
fix drag2 all viscous {gamma_drag2:.10g}
run {int(round(t_drag2/dts))}
dump dp all local 1 contacts_pair.txt c_pc[1] c_pc[2] c_pc[3] c_pc[4]
dump dw all local 1 contacts_wall.txt c_wc[3] c_wc[4]
dump da all custom 1 settled.dump id x y z vx vy vz
dump_modify da sort id format "%d %.9g %.9g %.9g %.6g %.6g %.6g"
run 0
unfix drag2
write_restart   settled.restart
"""
    (wd / "in.settle").write_text(deck)
    wall = run_liggghts(wd / "in.settle", wd, Path("log.settle"))
    res = {"n": n, "lateral_d": lateral, "lx_m": lx, "model": model,
           "dt_settle_s": dts, "t_drag_s": [t_drag, t_drag2],
           "drag_coefficient_kg_s": [gamma_drag, gamma_drag2], "wall_time_s": wall,
           "cpu_time_s": LAST_CPU[0]}
    (wd / "settle_meta.json").write_text(json.dumps(res, indent=2))
    return settle_post(n, lateral, model)


def settle_post(n: int, lateral: float, model: str = "walton_braun") -> dict:
    lx = lateral * D
    wd = WORK / f"settle_{tag(n, lateral)}_{model}"
    res = json.loads((wd / "settle_meta.json").read_text())
    t_, ids, x = last_frame(wd / "settled.dump")
    ke = 0.5 * MASS * float(np.sum(x[:, 3:6] ** 2))
    res.update({"n": int(len(ids)), "kinetic_energy_final_J": ke,
           "kinetic_energy_per_weight_d": ke / (len(ids) * MASS * G * D),
           "v_rms_m_s": float(np.sqrt(np.mean(np.sum(x[:, 3:6] ** 2, axis=1))))})
    res.update(packing_stats(x[:, :3], lx, wd))
    (wd / "settled.json").write_text(json.dumps(res, indent=2))
    return res


def packing_stats(x: np.ndarray, lx: float, wd: Path) -> dict:
    """Solid fraction of the interior and coordination number of a settled bed."""
    z = x[:, 2]
    top = float(np.percentile(z, 99))
    zg = np.arange(-D, top + 2 * D, D / 20)
    phi = cg_profile(z, zg, lx)
    inner = (zg >= 2.0 * D) & (zg <= top - 2.0 * D)
    # direct count in the same slab (sphere centres), as a check of the CG value
    zl, zh = 2.0 * D, top - 2.0 * D
    n_in = int(np.sum((z >= zl) & (z < zh)))
    phi_count = n_in * VOL / (lx * lx * (zh - zl))
    # contacts from LIGGGHTS (local dumps at the final step): overlap > 0
    pairs = read_local(wd / "contacts_pair.txt", 4)
    walls = read_local(wd / "contacts_wall.txt", 2)
    pp = pairs[pairs[:, 3] > 0] if len(pairs) else pairs
    pw = walls[walls[:, 1] > 0] if len(walls) else walls
    n = len(z)
    zc = np.zeros(n + 1, dtype=int)
    for a, b in pp[:, :2].astype(int):
        zc[a] += 1
        zc[b] += 1
    zw = np.zeros(n + 1, dtype=int)
    for a in pw[:, 0].astype(int):
        zw[a] += 1
    zc, zw = zc[1:], zw[1:]
    ztot = zc + zw
    rattler = ztot < 4   # frictionless spheres need >= 4 contacts to be stable (d+1)
    # own check from positions: pairs closer than D (minimum image in x,y)
    n_geo = count_pairs_closer_than(x, lx, D)
    n_tol = {eps: count_pairs_closer_than(x, lx, D * (1 + eps)) for eps in (1e-3, 1e-2)}
    return {"phi_interior_cg": float(phi[inner].mean()),
            "phi_interior_count": float(phi_count),
            "interior_window_m": [zl, zh],
            "top99_m": top, "bed_height_layers": top / D,
            "Z_mean_pairs": float(2 * len(pp) / n),
            "Z_mean_incl_floor": float(ztot.mean()),
            "Z_mean_non_rattlers": float(ztot[~rattler].mean()),
            "rattler_fraction": float(rattler.mean()),
            "n_pair_contacts": int(len(pp)), "n_floor_contacts": int(len(pw)),
            "n_pair_contacts_from_positions": int(n_geo),
            "Z_pairs_gap_below_1e-3_d": 2 * n_tol[1e-3] / n,
            "Z_pairs_gap_below_1e-2_d": 2 * n_tol[1e-2] / n,
            "max_overlap_pair_m": float(pp[:, 3].max()) if len(pp) else 0.0,
            "max_overlap_floor_m": float(pw[:, 1].max()) if len(pw) else 0.0}


def count_pairs_closer_than(x: np.ndarray, lx: float, cut: float) -> int:
    n = len(x)
    cnt = 0
    for i0 in range(0, n, 500):
        a = x[i0:i0 + 500, None, :] - x[None, :, :]
        a[..., :2] -= lx * np.round(a[..., :2] / lx)
        r2 = np.einsum("ijk,ijk->ij", a, a)
        ii = np.arange(i0, min(n, i0 + 500))[:, None]
        jj = np.arange(n)[None, :]
        cnt += int(np.sum((r2 < cut * cut) & (jj > ii)))
    return cnt


def read_local(path: Path, ncol: int) -> np.ndarray:
    rows = []
    lines = path.read_text().splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("ITEM: NUMBER OF ENTRIES"):
            m = int(lines[i + 1])
            i += 2
            continue
        if lines[i].startswith("ITEM: ENTRIES"):
            for l in lines[i + 1:i + 1 + m]:
                rows.append([float(v) for v in l.split()[:ncol]])
            i += 1 + m
            continue
        i += 1
    return np.array(rows).reshape(-1, ncol)


def read_dump(path: Path):
    """Frames of a dump custom file sorted by id: list of (step, ids, array).

    A last frame cut short (LIGGGHTS killed while writing it, also inside its last row's last
    number) is dropped with a one-line warning on stderr; the callers check that the frames they
    need are there (:func:`last_frame`)."""
    frames = []
    with open(path) as f:
        while True:
            l = f.readline()
            if not l:
                break
            if not l.startswith("ITEM: TIMESTEP"):
                continue
            try:
                step = int(f.readline())
                f.readline()
                n = int(f.readline())
                for _ in range(5):  # the box (4 lines) and ITEM: ATOMS ...
                    if not f.readline():
                        raise ValueError
                lines = [f.readline() for _ in range(n)]
                if n and not lines[-1].endswith("\n"):     # the last row cut, perhaps inside a number
                    raise ValueError
                block = np.array([r.split() for r in lines], dtype=float)
                if block.shape[0] != n or block.ndim != 2 or block.shape[1] < 2:
                    raise ValueError
            except ValueError:
                print(f"run_liggghts.py: warning: {path}: the frame after {len(frames)} complete "
                      "ones is cut short; it is dropped", file=sys.stderr)
                break
            frames.append((step, block[:, 0].astype(int), block[:, 1:]))
    return frames


def last_frame(path: Path):
    """The last complete frame of :func:`read_dump`; a dump without one stops the script with one
    line naming it."""
    frames = read_dump(path)
    if not frames:
        raise SystemExit(f"run_liggghts.py: {path} holds no complete frame (the run that wrote it was cut "
                         "short); run it again")
    return frames[-1]


# ---------------------------------------------------------------- coarse graining

def cg_profile(z: np.ndarray, zg: np.ndarray, lx: float, w: float = D / 2) -> np.ndarray:
    """Solid fraction phi(z) = sum_i V_i G_w(z - z_i) / (lx*ly), Gaussian of
    standard deviation w (point-volume coarse graining over the periodic
    cross-section, MercuryCG style)."""
    s = (zg[:, None] - z[None, :]) / w
    return VOL * np.exp(-0.5 * s * s).sum(axis=1) / (w * math.sqrt(2 * math.pi) * lx * lx)


def cg_weights(z: np.ndarray, zg: np.ndarray, w: float = D / 2) -> np.ndarray:
    """G[k, i] = the Gaussian of standard deviation w at zg[k] - z[i] [1/m]."""
    s = (zg[:, None] - z[None, :]) / w
    return np.exp(-0.5 * s * s) / (w * math.sqrt(2 * math.pi))


def cg_temperature(z: np.ndarray, v: np.ndarray, zg: np.ndarray, w: float = D / 2, g: np.ndarray | None = None):
    """Coarse-grained kinetic moments on the grid zg for one frame (same Gaussian as
    :func:`cg_profile`): returns (n, n*theta_z, n*theta_h, theta_z_i, theta_h_i) with
    n(z) = sum_i G(z - z_i) [1/m], n theta_a = sum_i G v_ia^2 - (sum_i G v_ia)^2 / n (the
    fluctuation about the local coarse-grained mean velocity U(z)), theta_z for the vertical
    component, theta_h = (theta_xx + theta_yy) / 2 (a mean-velocity gradient adds its variance
    across the kernel, w^2 (dU/dz)^2, to n theta_z / n); and per sphere the squared fluctuations
    (v_iz - U_z(z_i))^2 and ((v_ix - U_x)^2 + (v_iy - U_y)^2) / 2 with U interpolated at z_i."""
    g = cg_weights(z, zg, w) if g is None else g          # g: the weights, when the caller has them
    n = g.sum(axis=1)
    safe = np.where(n > 0, n, 1.0)
    out, per = [], []
    for cols in ((2,), (0, 1)):
        nth = np.zeros_like(zg)
        pi = np.zeros(len(z))
        for c in cols:
            p = g @ v[:, c]
            nth += (g @ (v[:, c] ** 2) - p * p / safe) / len(cols)
            pi += (v[:, c] - np.interp(z, zg, p / safe)) ** 2 / len(cols)
        out.append(np.maximum(nth, 0.0))
        per.append(pi)
    return n, out[0], out[1], per[0], per[1]


def write_temperature(out: Path, frames, meta: dict, zg: np.ndarray) -> None:
    """temperature.csv (the bed's mean granular temperature and its internal energy budget
    against the phase of the cycle, mean over the measured cycles), temperature_profiles.csv
    (theta against height at the four floor phases, the same mean) and internal_energy.csv
    (E_int of every frame), from dump frames with vx, vy, vz.

    The budget: E_int = sum_i m |v_i - v_cm|^2 / 2 [J] (the kinetic energy in the mass-centre
    frame: thermal plus the mean flow's relative motion), its loss rate -dE_int/dt [W] (central
    differences between frames; in flight, where neither the floor nor gravity does work on
    it, the energy dissipated in the contacts), and Enskog's collisional loss
    12 (1 - e^2) g0 rho_s phi^2 theta^(3/2) / (d sqrt(pi)) with Carnahan-Starling's g0 integrated
    over the frame's own coarse-grained phi(z) and theta(z) (the spheres' squared fluctuations
    about U at their height, (theta_z,i + 2 theta_h,i)/3, coarse-grained: without the kernel's
    share of a mean-velocity gradient) and the cross-section [W]: the continuum's loss closure
    evaluated on the DEM's state."""
    dt, amp = meta["dt_s"], meta["amplitude_m"]
    e = meta.get("restitution", E_REST)
    n0 = meta["cycles_startup"]
    ncyc = n0 + meta["cycles_measured"]
    spc = SAMPLES_PER_CYCLE
    mean_z, mean_h = np.zeros(spc), np.zeros(spc)
    count = np.zeros(spc)
    acc = {q: [np.zeros_like(zg) for _ in range(3)] for q in range(4)}
    nq = np.zeros(4)
    times = np.array([step * dt for (step, _, _) in frames])
    energy = np.array([0.5 * MASS * float(((x[:, 3:6] - x[:, 3:6].mean(axis=0)) ** 2).sum()) for (_, _, x) in frames])
    loss = -np.gradient(energy, times) if len(frames) > 1 else np.zeros(len(frames))
    e_int, e_loss, e_enskog = np.zeros(spc), np.zeros(spc), np.zeros(spc)
    for j, (step, ids, x) in enumerate(frames):
        tt = step * dt
        k = int(round(tt / (PERIOD / spc)))
        cyc, sub = divmod(k, spc)
        if not (n0 <= cyc < ncyc):
            continue
        zr = x[:, 2] - amp * np.sin(OMEGA * tt)
        weights = cg_weights(zr, zg)
        n, nthz, nthh, pz, ph = cg_temperature(zr, x[:, 3:6], zg, g=weights)
        mean_z[sub] += pz.mean()
        mean_h[sub] += ph.mean()
        count[sub] += 1
        phi = VOL * n / meta["lx_m"] ** 2
        # the local theta of Enskog's loss: the spheres' own fluctuations (about U at their height)
        # coarse-grained, without the kernel's share of a mean-velocity gradient
        theta = np.where(n > 0, weights @ ((pz + 2.0 * ph) / 3.0) / np.where(n > 0, n, 1.0), 0.0)
        pc = np.minimum(phi, 0.95)
        g0 = (1.0 - 0.5 * pc) / (1.0 - pc) ** 3
        gamma = 12.0 * (1.0 - e * e) * g0 * RHO * phi ** 2 * theta ** 1.5 / (D * math.sqrt(math.pi))
        e_enskog[sub] += float(np.sum(gamma) * (zg[1] - zg[0])) * meta["lx_m"] ** 2
        e_int[sub] += energy[j]
        e_loss[sub] += loss[j]
        if sub % (spc // 4) == 0:
            q = sub // (spc // 4)
            for a, b in zip(acc[q], (n, nthz, nthh)):
                a += b
            nq[q] += 1
    with open(out / "temperature.csv", "w") as f:
        f.write("# the bed's mean granular temperature against the floor phase (fraction of a cycle, floor at"
                " A sin(2 pi phase)), mean over the measured cycles: theta_z = <(v_z - U_z(z_i))^2>, theta_h ="
                " <((v_x - U_x)^2 + (v_y - U_y)^2)/2> over the spheres, U the coarse-grained (Gaussian sigma = d/2)"
                " mean velocity at the sphere's height; theta = (theta_z + 2 theta_h)/3 [m^2/s^2]; E_internal_J ="
                " sum m |v - v_cm|^2 / 2, loss_W = -dE_internal/dt (the contacts' dissipation in flight),"
                f" enskog_cs_loss_W = Enskog's loss (Carnahan-Starling g0, e = {e:g}) on the frame's coarse-grained"
                " phi(z), theta(z) (write_temperature)\n")
        f.write("phase_cycles,theta_z_m2_s2,theta_h_m2_s2,theta_m2_s2,E_internal_J,loss_W,enskog_cs_loss_W\n")
        for k in range(spc):
            c = max(count[k], 1)
            tz, th = mean_z[k] / c, mean_h[k] / c
            f.write(f"{k / spc:.4f},{tz:.5e},{th:.5e},{(tz + 2 * th) / 3:.5e},{e_int[k] / c:.5e},{e_loss[k] / c:.5e},"
                    f"{e_enskog[k] / c:.5e}\n")
    with open(out / "internal_energy.csv", "w") as f:
        f.write("# every frame (1/(40 f)) from the start of the vibration: E_internal_J = sum m |v - v_cm|^2 / 2 (the"
                " kinetic energy in the mass-centre frame, write_temperature)\n")
        f.write("t_s,E_internal_J\n")
        for tt, en in zip(times, energy):
            f.write(f"{tt:.6f},{en:.5e}\n")
    with open(out / "temperature_profiles.csv", "w") as f:
        f.write("# granular temperature against the height above the floor at floor phase omega t = 0, pi/2, pi,"
                " 3pi/2, mean over the measured cycles: theta_a(z) = sum n theta_a / sum n over the frames (n,"
                " n theta_a: cg_temperature, Gaussian sigma = d/2; a mean-velocity gradient adds its variance"
                " across the kernel, sigma^2 (dU/dz)^2, to theta_z); z = vertical, h = horizontal (mean of x, y)"
                " [m^2/s^2]; phi: the solid fraction on the same frames\n")
        names = ("phase0", "phase_pi2", "phase_pi", "phase_3pi2")
        f.write("z_rel_m,z_rel_over_d," + ",".join(f"phi_{q},theta_z_{q},theta_h_{q}" for q in names) + "\n")
        for i, zz in enumerate(zg):
            row = []
            for q in range(4):
                n, nz_, nh_ = (a[i] for a in acc[q])
                phi = VOL * n / (meta["lx_m"] ** 2 * max(nq[q], 1))
                row += [f"{phi:.5f}", f"{nz_ / n:.5e}" if n > 0 else "nan", f"{nh_ / n:.5e}" if n > 0 else "nan"]
            f.write(f"{zz:.5e},{zz / D:.3f}," + ",".join(row) + "\n")


# ---------------------------------------------------------------- vibration

def vibrate(gamma: float, n: int, lateral: float, model: str, mu: float,
            cycles_startup: int, cycles_measured: int) -> dict:
    lx = lateral * D
    st = WORK / f"settle_{tag(n, lateral)}_walton_braun"
    if not (st / "settled.restart").exists():
        raise SystemExit(f"run --settle --n {n} --lateral {lateral}"
                         + ("" if SEED == DEFAULT_SEED else f" --seed {SEED}")
                         + ("" if K_N == DEFAULT_K_N else f" --stiffness {K_N:.12g}") + " first")
    name = run_name(gamma, n, lateral, model, mu, cycles_startup, cycles_measured)
    wd = WORK / name
    wd.mkdir(parents=True, exist_ok=True)
    write_floor_stl(wd / "floor.stl", lx)
    dt, ndump = timestep()
    amp = gamma * G / OMEGA ** 2
    ncyc = cycles_startup + cycles_measured
    nsteps = ncyc * SAMPLES_PER_CYCLE * ndump
    if model == "walton_braun":
        # restart: keeps the Walton-Braun contact history of the settled bed
        start = f"""# written by reference/liggghts_bed/run_liggghts.py
atom_modify     map array
read_restart    {st / 'settled.restart'}
newton          off
communicate     single vel yes
"""
    else:
        # another contact model cannot read the restart's contact history: start from
        # the same settled positions and velocities (data file written from the dump)
        write_settled_data(st, wd / "settled.data", lx, n)
        start = deck_header(lx, 0, 0) + """read_data       settled.data
"""
    deck = start + f"""neighbor        {0.1*D:.6g} bin
neigh_modify    delay 0
{deck_contact(model, mu)}
timestep        {dt:.12g}
fix floor all mesh/surface/stress file floor.stl type 2 reference_point 0 0 0
fix wall all wall/gran {wall_fix(model, mu, FLOOR_POWER)}
# floor z = A sin(omega t), t = 0 at the start of this run
fix shake all move/mesh mesh floor wiggle amplitude 0 0 {amp:.12g} period {PERIOD:.12g}
fix grav all gravity {G} vector 0 0 -1
fix integr all nve/sphere
compute cm all com
compute pc all pair/gran/local delta
compute wc all wall/gran/local delta
compute mpp all reduce max c_pc[1]
compute mpw all reduce max c_wc[1]
variable st equal step
variable fz equal f_floor[3]
variable zf equal f_floor[9]
variable zc equal c_cm[3]
variable dpp equal c_mpp
variable dpw equal c_mpw
variable na equal atoms
{floor_power_deck(amp, dt) if FLOOR_POWER else ""}fix pr all print {FORCE_EVERY} "${{st}} ${{zf}} ${{fz}} ${{zc}} ${{dpp}} ${{dpw}} ${{na}}" file floor.txt screen no title "# step z_floor_mesh F_z_on_floor com_z max_overlap_pair max_overlap_wall atoms"
dump da all custom {ndump} bed.dump id x y z vx vy vz
dump_modify da sort id format "%d %.8g %.8g %.8g %.6g %.6g %.6g"
thermo_style    custom step time atoms f_floor[3]
thermo          {SAMPLES_PER_CYCLE * ndump}
thermo_modify   lost ignore norm no
reset_timestep  0
run {nsteps}
"""
    (wd / "in.vibrate").write_text(deck)
    wall = run_liggghts(wd / "in.vibrate", wd, Path("log.vibrate"))
    meta = {"name": name, "gamma": gamma, "n": n, "lateral_d": lateral, "lx_m": lx,
            "model": model, "friction": mu, "restitution": E_REST, "K_N_m": K_N, "amplitude_m": amp, "dt_s": dt,
            "steps": nsteps, "steps_per_dump": ndump, "cycles_startup": cycles_startup,
            "cycles_measured": cycles_measured, "wall_time_s": wall, "cpu_time_s": LAST_CPU[0],
            "loop_time_s": loop_time(wd / "log.vibrate")}
    if E_FLOOR is not None:
        meta["floor_restitution"] = E_FLOOR
    if FLOOR_POWER:
        meta["floor_power"] = True
    if SEED != DEFAULT_SEED:
        meta["seed"] = SEED
    (wd / "meta.json").write_text(json.dumps(meta, indent=2))
    return postprocess(name)


def floor_power_deck(amp: float, dt: float) -> str:
    """Deck lines of --floor-power: at every step, into floor_power.txt [W], the power the floor
    gives its contacts, F_z v_floor (F_z the floor's force on the spheres, v_floor =
    A omega cos(omega t)), and the power those contacts give the spheres, sum_i F_z,i v_z,i (F_z,i
    each sphere's force from the floor, fix wall/gran's store_force).  Their difference is the rate
    of the floor contacts' elastic energy plus their dissipation.

    These lines come before floor.txt's fix print: fixes act at the end of a step in the order
    they are defined, and that print's compute wall/gran/local (every FORCE_EVERY steps) sets the
    stored wall forces to 0 (found 2026-12-05 with an elastic floor, whose contacts then seemed to
    lose 10 % of the floor's work).  A fix print, which tests the step number itself: a fix
    ave/time defined before the restart's reset_timestep keeps the restart's step numbers for its
    schedule."""
    # (v_floor at step*dt: the mesh's own phase is one step off it, floor_position_check_max_abs_err_m =
    # A omega dt; about 1e-3 of the loss)
    return f"""variable vfl equal {amp * OMEGA:.12g}*cos({OMEGA:.12g}*step*{dt:.12g})
variable pfl equal -f_floor[3]*v_vfl
variable pat atom f_force_wall[3]*vz
compute psph all reduce sum v_pat
variable psp equal c_psph
fix fpw all print 1 "${{st}} ${{pfl}} ${{psp}}" file floor_power.txt screen no title "# step floor_power_W power_on_spheres_W"
"""


def write_floor_power(out: Path, wd: Path, meta: dict) -> dict:
    """results/RUN/floor_power_per_cycle.csv from work/RUN/floor_power.txt (--floor-power).

    Per window of one period, from the phase where the cycles' mean floor force is smallest (the
    first such bin of 40; the bed in flight, the floor contacts empty), to the same phase a period
    later: the floor's work
    on its contacts W_floor = int F_z v_floor dt, the contacts' work on the spheres
    W_spheres = int sum_i F_z,i v_z,i dt, and their difference, the energy the sphere-floor
    contacts dissipated (their elastic energy is the same, near zero, at the window's two ends;
    the force there is written) [mJ].  Returns the measured windows' means."""
    dt = meta["dt_s"]
    a = read_columns(wd / "floor_power.txt")
    t = a[:, 0] * dt
    p_floor, p_spheres = a[:, 1], a[:, 2]
    f = read_columns(wd / "floor.txt")
    tf, fz = f[:, 0] * dt, -f[:, 2]
    weight = MASS * f[0, 6] * G
    ncyc = meta["cycles_startup"] + meta["cycles_measured"]
    bins = 40
    ph = np.floor((tf / PERIOD % 1.0) * bins).astype(int)
    mean_f = np.array([fz[(ph == b) & (tf >= meta["cycles_startup"] * PERIOD)].mean() for b in range(bins)])
    phase0 = (int(np.argmin(mean_f)) + 0.5) / bins
    h = dt                          # a row per step
    rows = []
    for c in range(ncyc - 1):
        t0, t1 = (c + phase0) * PERIOD, (c + 1 + phase0) * PERIOD
        m = (t > t0) & (t <= t1)
        wf, ws = float(np.sum(p_floor[m]) * h), float(np.sum(p_spheres[m]) * h)
        f0 = float(np.interp(t0, tf, fz)) / weight
        f1 = float(np.interp(t1, tf, fz)) / weight
        rows.append((c, c >= meta["cycles_startup"], wf, ws, wf - ws, f0, f1))
    with open(out / "floor_power_per_cycle.csv", "w") as fo:
        fo.write(f"# the sphere-floor contacts' energy budget per window [cycle + {phase0:.4f}, cycle + 1 + "
                 f"{phase0:.4f}) periods (the phase of the smallest mean floor force), mJ: floor_work = int F_z "
                 "v_floor dt, work_on_spheres = int sum_i F_z,i v_z,i dt, floor_contact_loss their difference\n")
        fo.write("cycle,measured,floor_work_mJ,work_on_spheres_mJ,floor_contact_loss_mJ,"
                 "force_start_over_weight,force_end_over_weight\n")
        for r in rows:
            fo.write(f"{r[0]},{int(r[1])},{r[2]*1e3:.5f},{r[3]*1e3:.5f},{r[4]*1e3:.5f},{r[5]:.4f},{r[6]:.4f}\n")
    meas = [r for r in rows if r[1]]
    closure = floor_loss_by_phase(out, wd, meta, t, p_floor - p_spheres)
    return {"floor_power_window_phase": phase0, **closure,
            "floor_work_per_cycle_mJ": float(np.mean([r[2] for r in meas]) * 1e3),
            "floor_contact_loss_per_cycle_mJ": float(np.mean([r[4] for r in meas]) * 1e3)}


def floor_loss_by_phase(out: Path, wd: Path, meta: dict, t: np.ndarray, loss_rate: np.ndarray) -> dict:
    """results/RUN/floor_loss_by_phase.csv: against the phase of the cycle (40 bins; the measured
    cycles but the first and the last, whose windows are incomplete), the sphere-floor contacts'
    measured loss rate [W] (floor_power.txt) beside the continuum's closure for it evaluated on
    LIGGGHTS's own state at the floor, (1 - e_w) p sqrt(2 theta / pi) A with p = rho_s phi theta
    [1 + 2 (1 + e) phi g0] (Carnahan-Starling g0; bsrflow.physics.granular_bed.wall_loss), phi the
    coarse-grained solid fraction at z = d/2 above the floor (cg_profile) and theta the bottom
    layer's (sphere centres below d) velocity variance about its mean, isotropic (mean of the three
    components) and vertical, from the dump frames (every 1/40 cycle).  Returns the per-cycle sums
    [mJ] of the same cycles."""
    dt, amp, lx = meta["dt_s"], meta["amplitude_m"], meta["lx_m"]
    e = meta.get("restitution", E_REST)                 # the spheres' (the kinetic pressure's)
    e_w = meta.get("floor_restitution", e)              # the floor's (the loss's)
    bins = 40
    n0 = meta["cycles_startup"] + 1
    n1 = meta["cycles_startup"] + meta["cycles_measured"] - 1
    zg = np.array([0.5 * D])
    per_bin = [[] for _ in range(bins)]
    for step, _, x in read_dump(wd / "bed.dump"):
        tf = step * dt
        if not (n0 * PERIOD <= tf < n1 * PERIOD):
            continue
        z = x[:, 2] - amp * math.sin(OMEGA * tf)
        bottom = z < D
        phi = float(cg_profile(z, zg, lx)[0])
        vb = x[bottom, 3:6]
        th = float(np.mean(np.var(vb, axis=0))) if len(vb) > 1 else 0.0
        thz = float(np.var(vb[:, 2])) if len(vb) > 1 else 0.0
        pc = min(phi, 0.95)
        g0 = (1.0 - 0.5 * pc) / (1.0 - pc) ** 3

        def closure(theta):
            p = RHO * phi * theta * (1.0 + 2.0 * (1.0 + e) * phi * g0)
            return (1.0 - e_w) * p * math.sqrt(2.0 * theta / math.pi) * lx * lx
        b = int(round((tf / PERIOD % 1.0) * bins)) % bins     # frames sit at the bins' left edges
        per_bin[b].append((phi, th, thz, closure(th), closure(thz), int(bottom.sum())))
    m = (t >= n0 * PERIOD) & (t < n1 * PERIOD)
    edges = np.floor((t[m] / PERIOD % 1.0) * bins).astype(int)
    empty = [b for b in range(bins) if not per_bin[b] or not np.any(edges == b)]
    if empty:
        raise SystemExit(f"{wd.name}: bed.dump or floor_power.txt holds no data at phase {empty[0] / bins:g} of "
                         f"cycles {n0}-{n1 - 1} (a run stopped early?); rerun it")
    measured = np.array([loss_rate[m][edges == b].mean() for b in range(bins)])
    frames = np.array([np.mean(v, axis=0) for v in per_bin])
    with open(out / "floor_loss_by_phase.csv", "w") as fo:
        fo.write(f"# cycles {n0}-{n1 - 1}: the sphere-floor contacts' measured loss rate (mean over the phase bin; it "
                 f"holds the rate of their elastic energy too, which sums to 0 over a cycle) and "
                 f"the continuum's wall-loss closure on LIGGGHTS's state at the floor (frames at the bin's start), W\n")
        fo.write("phase,measured_loss_W,closure_loss_W,closure_loss_vertical_W,phi_at_half_d,theta_bottom_m2_s2,"
                 "theta_z_bottom_m2_s2,spheres_below_d\n")
        for b in range(bins):
            f = frames[b]
            fo.write(f"{b / bins:.4f},{measured[b]:.6g},{f[3]:.6g},{f[4]:.6g},{f[0]:.4f},{f[1]:.5g},{f[2]:.5g},"
                     f"{f[5]:.1f}\n")
    return {"floor_loss_measured_per_cycle_mJ": float(measured.mean() * PERIOD * 1e3),
            "floor_loss_closure_on_dem_state_per_cycle_mJ": float(frames[:, 3].mean() * PERIOD * 1e3),
            "floor_loss_closure_vertical_on_dem_state_per_cycle_mJ": float(frames[:, 4].mean() * PERIOD * 1e3)}


def write_settled_data(st: Path, path: Path, lx: float, n: int) -> None:
    _, ids, x = last_frame(st / "settled.dump")
    lines = ["LIGGGHTS data file: settled bed (from settled.dump)", "",
             f"{len(ids)} atoms", "2 atom types", "",
             f"0 {lx:.10g} xlo xhi", f"0 {lx:.10g} ylo yhi", f"-0.02 {box_top(n, lx):.10g} zlo zhi",
             "", "Atoms", ""]
    for i, p in zip(ids, x):
        lines.append(f"{i} 1 {D:.10g} {RHO:.10g} {p[0]:.10g} {p[1]:.10g} {p[2]:.10g}")
    lines += ["", "Velocities", ""]
    for i, p in zip(ids, x):
        lines.append(f"{i} {p[3]:.8g} {p[4]:.8g} {p[5]:.8g} 0 0 0")
    path.write_text("\n".join(lines) + "\n")


def loop_time(log: Path) -> float | None:
    for l in log.read_text().splitlines():
        if l.startswith("Loop time of"):
            return float(l.split()[3])
    return None


def run_name(gamma, n, lateral, model, mu, cycles_startup=CYCLES_STARTUP, cycles_measured=CYCLES_MEASURED) -> str:
    """The run's folder name: gamma_<Γ>_<tag>, then _e<e>, _<law>, _mu<μ>, _ew<e_w> where they are
    not the main bed's, and _c<cycles> for a run of another length than 3 + 8 cycles."""
    s = f"gamma_{gamma:.2f}_{tag(n, lateral)}"
    if E_REST != 0.9:
        s += f"_e{E_REST:g}"
    if model != "walton_braun":
        s += f"_{model}"
    if mu > 0:
        s += f"_mu{mu:g}"
    if E_FLOOR is not None:
        s += f"_ew{E_FLOOR:g}"
    if (cycles_startup, cycles_measured) != (CYCLES_STARTUP, CYCLES_MEASURED):
        s += f"_c{cycles_startup + cycles_measured}" + ("" if cycles_startup == CYCLES_STARTUP
                                                         else f"s{cycles_startup}")
    return s


# ---------------------------------------------------------------- post-processing

FLIGHT_SMOOTH_S = 1.0e-3     # moving-average window for the floor force
FLIGHT_THRESHOLD = 0.10      # bed off the floor: smoothed floor force < 0.1 M g
FLIGHT_MIN_S = 1.0e-3        # ignore off-floor intervals shorter than this


FLIGHT_THRESHOLDS = (0.05, 0.1, 0.2, 0.3, 0.5, 0.8)
"""Thresholds (fractions of the bed weight) of flight_vs_threshold.csv: the flight measure's
dependence on where the floor force is cut (0.1 is the flight of every other file)."""


def flights_from_force(t: np.ndarray, f: np.ndarray, weight: float, threshold: float = FLIGHT_THRESHOLD):
    """Flights = maximal intervals with the 1-ms moving average of the floor force
    below ``threshold`` (10 %) of the bed weight, longer than 1 ms. Returns list of (t_off, t_on)."""
    dtp = t[1] - t[0]
    w = max(1, int(round(FLIGHT_SMOOTH_S / dtp)))
    fs = np.convolve(f, np.ones(w) / w, mode="same")
    off = fs < threshold * weight
    out = []
    i = 0
    n = len(off)
    while i < n:
        if off[i]:
            j = i
            while j < n and off[j]:
                j += 1
            if i > 0 and j < n and t[j] - t[i] >= FLIGHT_MIN_S:
                out.append((float(t[i]), float(t[j])))
            elif i > 0 and j == n and t[j - 1] - t[i] >= FLIGHT_MIN_S:
                out.append((float(t[i]), float("nan")))   # still in flight at the end
            i = j
        else:
            i += 1
    return out


def write_floor_force(out: Path, t, zf, fz, weight: float) -> None:
    """floor_force.csv: every T/200 (the series in work/ is every 10 steps)."""
    keep = max(1, int(round((PERIOD / 200) / (t[1] - t[0]))))
    with open(out / "floor_force.csv", "w") as f:
        f.write("# t_s: time since start of vibration; z_floor_m = A sin(omega t);"
                " F_floor_N: total normal force of the spheres on the floor (mesh); every T/200;"
                f" bed weight M g = {weight:.6g} N\n")
        f.write("t_s,z_floor_m,F_floor_N\n")
        for i in range(0, len(t), keep):
            f.write(f"{t[i]:.6f},{zf[i]:.4e},{fz[i]:.4e}\n")


def flights_per_cycle(flights, ncyc: int) -> np.ndarray:
    """The flight time [s] of each forcing cycle 0..ncyc-1: the longest flight taking off in it
    (0 without one, NaN for one still going at the end)."""
    per = np.zeros(ncyc)
    for (t0, t1) in flights:
        c = int(math.floor(t0 / PERIOD))
        if 0 <= c < ncyc:
            per[c] = np.nan if math.isnan(t1 - t0) else max(per[c], t1 - t0)
    return per


def last_six_flights(flights, n0: int, ncyc: int) -> np.ndarray:
    """The last six finished flights [s] of the measured cycles' flight times (cycles n0 to
    ncyc - 1, :func:`flights_per_cycle`; unfinished ones dropped before counting), as
    ``flight_time_mean_last6_s`` of summary.json."""
    tau = flights_per_cycle(flights, ncyc)[n0:]
    return tau[~np.isnan(tau)][-6:]


def write_flight_thresholds(out: Path, t, fz, weight: float, n0: int, ncyc: int) -> None:
    """flight_vs_threshold.csv: the mean of the last six finished flights with the bed off the floor
    while the 1-ms floor force is below each of :data:`FLIGHT_THRESHOLDS` times its weight (the
    full-resolution series, every FORCE_EVERY steps)."""
    with open(out / "flight_vs_threshold.csv", "w") as f:
        f.write("# flight time per cycle (mean of the last six finished flights) against the threshold of the "
                "1-ms moving average of the floor force, as a fraction of the bed weight M g; 0.1 is the flight "
                "of flights.csv and summary.json; flight_time_std_last6_s the population standard deviation "
                "(ddof = 0) of those six flights\n")
        f.write("threshold_over_weight,flight_time_mean_last6_s,flight_time_std_last6_s\n")
        for th in FLIGHT_THRESHOLDS:
            last = last_six_flights(flights_from_force(t, fz, weight, th), n0, ncyc)
            f.write(f"{th:g},{np.mean(last):.6f},{np.std(last):.6f}\n")


def refresh_thresholds(name: str) -> None:
    """Write results/<name>/flight_vs_threshold.csv from work/<name>/floor.txt (no LIGGGHTS run)."""
    wd = WORK / name
    meta = json.loads((wd / "meta.json").read_text())
    a = read_columns(wd / "floor.txt")
    (RESULTS / name).mkdir(parents=True, exist_ok=True)
    write_flight_thresholds(RESULTS / name, a[:, 0] * meta["dt_s"], -a[:, 2], MASS * a[0, 6] * G,
                            meta["cycles_startup"], meta["cycles_startup"] + meta["cycles_measured"])


CRYSTAL_BOND_CUT = 1.2       # neighbours within 1.2 d
CRYSTAL_DOT = 0.7            # ten Wolde-Frenkel: a crystal-like bond has q6(i).q6(j) > 0.7 ...
CRYSTAL_MIN_BONDS = 7        # ... and a crystal-like sphere at least 7 of them


def _y6(polar: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """The spherical harmonics Y_6m, m = -6..6, of the bond directions: array (13, n)."""
    try:
        from scipy.special import sph_harm_y
        return np.array([sph_harm_y(6, m, polar, azimuth) for m in range(-6, 7)])
    except ImportError:                                   # scipy < 1.15
        from scipy.special import sph_harm
        return np.array([sph_harm(m, 6, azimuth, polar) for m in range(-6, 7)])


def crystal_fraction(x: np.ndarray, lx: float) -> float:
    """Fraction of crystal-like spheres (ten Wolde, Ruiz-Montero and Frenkel 1996): the normalised
    q6 vector of each sphere, q6m(i) = mean over its neighbours (centres closer than 1.2 d,
    laterally periodic box of side lx) of Y_6m(bond), and a sphere is crystal-like when at least 7
    of its bonds have q6(i).q6(j) > 0.7. About 0 in a random packing or a gas, 1 inside an fcc/hcp
    crystal (the free top and the floor layer lower it)."""
    from scipy.spatial import cKDTree
    p = np.array(x[:, :3], dtype=float)
    p[:, :2] %= lx
    p[:, :2][p[:, :2] >= lx] -= lx            # a tiny negative coordinate wraps to lx itself
    p[:, 2] -= p[:, 2].min()
    tree = cKDTree(p, boxsize=[lx, lx, p[:, 2].max() + 10.0 * D])
    pairs = tree.query_pairs(CRYSTAL_BOND_CUT * D, output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    b = p[pairs[:, 1]] - p[pairs[:, 0]]
    b[:, :2] -= lx * np.round(b[:, :2] / lx)
    r = np.linalg.norm(b, axis=1)
    y = _y6(np.arccos(np.clip(b[:, 2] / r, -1.0, 1.0)), np.arctan2(b[:, 1], b[:, 0]))   # Y_6m(-b) = Y_6m(b)
    n = len(p)
    q = np.zeros((13, n), dtype=complex)
    for end in (0, 1):
        for m in range(13):
            np.add.at(q[m], pairs[:, end], y[m])
    norm = np.sqrt(np.sum(np.abs(q) ** 2, axis=0))
    q = np.where(norm > 0.0, q / np.where(norm > 0.0, norm, 1.0), 0.0)
    dots = np.real(np.sum(q[:, pairs[:, 0]] * np.conj(q[:, pairs[:, 1]]), axis=0))
    bonds = np.zeros(n)
    good = dots > CRYSTAL_DOT
    np.add.at(bonds, pairs[good, 0], 1.0)
    np.add.at(bonds, pairs[good, 1], 1.0)
    return float(np.mean(bonds >= CRYSTAL_MIN_BONDS))


SEED_LATERAL = 2024          # the shuffles of lateral_mode's baseline
BOTTOM_LAYER_TOP = 0.8       # the floor layer: centres less than 0.8 d above the floor (they sit at 0.5 d)


def bottom_layer_order(x: np.ndarray, z_rel: np.ndarray, lx: float) -> tuple:
    """(number of spheres, mean |psi4|, mean |psi6|) of the floor layer (centres less than
    :data:`BOTTOM_LAYER_TOP` d above the floor): the bond-orientational order of each sphere's
    in-plane bonds to neighbours within 1.2 d, psi_k = mean over its bonds of exp(i k angle),
    laterally periodic (spheres without a neighbour left out). A square layer has |psi4| near 1, a
    hexagonal one |psi6| near 1."""
    from scipy.spatial import cKDTree
    m = z_rel < BOTTOM_LAYER_TOP * D
    p = np.array(x[m, :2], dtype=float) % lx
    p[p >= lx] -= lx
    n = len(p)
    if n < 2:
        return n, 0.0, 0.0
    pairs = cKDTree(p, boxsize=lx).query_pairs(CRYSTAL_BOND_CUT * D, output_type="ndarray")
    if len(pairs) == 0:
        return n, 0.0, 0.0
    b = p[pairs[:, 1]] - p[pairs[:, 0]]
    b -= lx * np.round(b / lx)
    ang = np.arctan2(b[:, 1], b[:, 0])
    out = []
    for k in (4, 6):
        psi = np.zeros(n, dtype=complex)
        cnt = np.zeros(n)
        np.add.at(psi, pairs[:, 0], np.exp(1j * k * ang))
        np.add.at(psi, pairs[:, 1], np.exp(1j * k * (ang + np.pi)))
        np.add.at(cnt, pairs[:, 0], 1.0)
        np.add.at(cnt, pairs[:, 1], 1.0)
        ok = cnt > 0
        out.append(float(np.mean(np.abs(psi[ok] / cnt[ok]))))
    return n, out[0], out[1]


LATERAL_MODES = ((1, 0), (0, 1), (1, 1), (1, -1))
"""The lateral wave vectors (in units of 2π/L) of :func:`lateral_mode`: the box's longest waves."""


def lateral_mode(x: np.ndarray, lx: float, rng) -> tuple:
    """(A, A_shuffled) [m]: the largest amplitude 2 |mean_i (z_i - mean z) exp(i k.x_i)| over the
    box's longest lateral waves k (:data:`LATERAL_MODES`), of the spheres' heights, and the same
    with the heights shuffled among the spheres (their lateral positions kept): a bed with no
    lateral structure (a horizontally uniform one) has A of the order of A_shuffled, a tilted
    surface, heap or standing wave an A well above it.  The shuffled layout is a random one, noisier
    than a packed flat bed (on a synthetic packed bed A/A_shuffled is below 0.3 flat and above 0.9
    with a surface heap of 0.4 d; tests/test_granular_bed.py), so A itself, in d, is the bound to read:
    a wave of the whole bed of peak-to-peak height h has A of about h/2, a heap of the surface alone
    (the displacement growing from 0 at the floor) about h/4."""
    z = x[:, 2] - x[:, 2].mean()
    zs = z[rng.permutation(len(z))]
    ph = [np.exp(2j * np.pi * (kx * x[:, 0] + ky * x[:, 1]) / lx) for kx, ky in LATERAL_MODES]
    return (max(2.0 * abs(np.mean(z * e)) for e in ph), max(2.0 * abs(np.mean(zs * e)) for e in ph))


def write_structure(out: Path, frames, meta: dict) -> None:
    """structure_per_cycle.csv: at the start of every cycle (floor phase 0, floor at rest height,
    moving up), the mass centre's height above the floor, the solid fraction between 1 d and 6 d
    above it (coarse-grained as profiles.csv), the crystal-like fraction of the spheres
    (:func:`crystal_fraction`) and the floor layer's order (:func:`bottom_layer_order`); and the
    lateral structure over the cycle's frames (:func:`lateral_mode`, mean over the frames from that
    start to the next cycle's; the shuffles seeded, so the file is reproducible)."""
    dt, amp, lx = meta["dt_s"], meta["amplitude_m"], meta["lx_m"]
    zg = np.arange(1.0 * D, 6.0 * D + 1e-12, D / 10)
    rng = np.random.default_rng(SEED_LATERAL)
    lateral = {}
    for (step, ids, x) in frames:
        c = int(math.floor(step * dt / PERIOD + 1e-9))
        lateral.setdefault(c, []).append(lateral_mode(x, lx, rng))
    with open(out / "structure_per_cycle.csv", "w") as f:
        f.write("# at floor phase 0 of every cycle (t = cycle T): com_rel_over_d mass-centre height above the floor "
                "[d]; phi_1_6d the coarse-grained (sigma = d/2) solid fraction averaged over 1 d to 6 d above the "
                "floor; crystal_fraction the fraction of crystal-like spheres (q6 bonds, ten Wolde-Frenkel: "
                "neighbours within 1.2 d, q6.q6 > 0.7, at least 7 bonds); floor_layer_n the spheres with centres "
                "less than 0.8 d above the floor, floor_layer_psi4 / floor_layer_psi6 their mean in-plane bond order "
                "|psi4| / |psi6| (neighbours within 1.2 d; square / hexagonal layer near 1); over the cycle's "
                "frames (from this start to the next; the last row: its single frame), lateral_mode_over_d the mean "
                "largest amplitude of the sphere heights' longest lateral waves [d] and lateral_mode_shuffled_over_d "
                "the same with the heights shuffled among the spheres (the amplitude of a random lateral layout, "
                "above a packed flat bed's own)\n")
        f.write("cycle,com_rel_over_d,phi_1_6d,crystal_fraction,floor_layer_n,floor_layer_psi4,floor_layer_psi6,"
                "lateral_mode_over_d,lateral_mode_shuffled_over_d\n")
        for (step, ids, x) in frames:
            c = step * dt / PERIOD
            if abs(c - round(c)) > 1e-6:
                continue
            zf = amp * math.sin(OMEGA * step * dt)
            z = x[:, 2] - zf
            nb, psi4, psi6 = bottom_layer_order(x, z, lx)
            lat = np.mean(lateral[int(round(c))], axis=0) / D
            f.write(f"{int(round(c))},{z.mean() / D:.4f},{cg_profile(z, zg, lx).mean():.4f},"
                    f"{crystal_fraction(x, lx):.4f},{nb},{psi4:.4f},{psi6:.4f},{lat[0]:.4f},{lat[1]:.4f}\n")


def refresh_structure(name: str) -> None:
    """Write results/<name>/structure_per_cycle.csv from work/<name>/bed.dump (no LIGGGHTS run)."""
    wd = WORK / name
    (RESULTS / name).mkdir(parents=True, exist_ok=True)
    write_structure(RESULTS / name, read_dump(wd / "bed.dump"), json.loads((wd / "meta.json").read_text()))


def refresh_floor_force(name: str) -> None:
    """Rewrite results/<name>/floor_force.csv from work/<name>/floor.txt."""
    wd = WORK / name
    meta = json.loads((wd / "meta.json").read_text())
    a = read_columns(wd / "floor.txt")
    t = a[:, 0] * meta["dt_s"]
    write_floor_force(RESULTS / name, t, meta["amplitude_m"] * np.sin(OMEGA * t), -a[:, 2],
                      MASS * a[0, 6] * G)


def postprocess(name: str) -> dict:
    wd = WORK / name
    meta = json.loads((wd / "meta.json").read_text())
    out = RESULTS / name
    out.mkdir(parents=True, exist_ok=True)
    dt, amp, lx = meta["dt_s"], meta["amplitude_m"], meta["lx_m"]
    n0 = meta["cycles_startup"]
    ncyc = n0 + meta["cycles_measured"]

    # --- floor force series (every FORCE_EVERY steps)
    a = read_columns(wd / "floor.txt")
    t = a[:, 0] * dt
    zf_mesh = a[:, 1]
    zf = amp * np.sin(OMEGA * t)
    fz = -a[:, 2]                       # force of the spheres on the floor is -z; store +
    n_atoms = a[:, 6]
    mtot = MASS * n_atoms[0]
    weight = mtot * G
    floor_err = float(np.max(np.abs(zf_mesh - zf)))
    fl = flights_from_force(t, fz, weight)
    # assign each flight to the forcing cycle of its take-off
    rows = []
    for (t0, t1) in fl:
        c = int(math.floor(t0 / PERIOD))
        rows.append((c, t0, t1, t1 - t0, (t0 / PERIOD) % 1.0, (t1 / PERIOD) % 1.0))
    with open(out / "flights.csv", "w") as f:
        f.write("# flights of the bed: smoothed (1 ms) floor force < 0.1 M g for > 1 ms\n")
        f.write("cycle,t_takeoff_s,t_landing_s,flight_time_s,takeoff_phase_cycles,landing_phase_cycles\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]:.6f},{r[2]:.6f},{r[3]:.6f},{r[4]:.4f},{r[5]:.4f}\n")
    # flight time per forcing cycle (0 if no take-off in that cycle), measured cycles
    per = flights_per_cycle(fl, ncyc)
    # off-floor time inside each cycle window (robust to flights spanning cycles)
    dtp = t[1] - t[0]
    wsm = max(1, int(round(FLIGHT_SMOOTH_S / dtp)))
    fs = np.convolve(fz, np.ones(wsm) / wsm, mode="same")
    offfrac = np.zeros(ncyc)
    for c in range(ncyc):
        m = (t >= c * PERIOD) & (t < (c + 1) * PERIOD)
        offfrac[c] = np.mean(fs[m] < FLIGHT_THRESHOLD * weight) * PERIOD
    with open(out / "flight_per_cycle.csv", "w") as f:
        f.write("# cycle: forcing cycle index (t in [cycle*T,(cycle+1)*T)); measured = cycle >= startup\n")
        f.write("cycle,measured,flight_time_s,flight_time_over_T,off_floor_time_in_cycle_s\n")
        for c in range(ncyc):
            f.write(f"{c},{int(c >= n0)},{per[c]:.6f},{per[c]/PERIOD:.5f},{offfrac[c]:.6f}\n")
    # coarser copy of the force series for committing
    write_floor_force(out, t, zf, fz, weight)
    write_flight_thresholds(out, t, fz, weight, n0, ncyc)

    # --- positions (every 1/(40 f))
    frames = read_dump(wd / "bed.dump")
    write_structure(out, frames, meta)
    nz = None
    tr = []
    zg = np.arange(-1.0 * D, 30.0 * D * max(1.0, meta["n"] / 2000 * (13.0 / meta["lateral_d"]) ** 2), D / 10)
    prof_acc = {k: np.zeros_like(zg) for k in range(4)}
    prof_n = {k: 0 for k in range(4)}
    spc = SAMPLES_PER_CYCLE
    for (step, ids, x) in frames:
        tt = step * dt
        z = x[:, 2]
        zfl = amp * np.sin(OMEGA * tt)
        com = z.mean()
        top99 = np.percentile(z, 99)
        bot01 = np.percentile(z, 1)
        zmin = z.min()
        vcom = x[:, -1].mean()          # vz: the last column (dumps before 2026-12-03 had no vx, vy)
        tr.append((tt, tt / PERIOD, zfl, com, com - zfl, top99, top99 - zfl,
                   bot01 - zfl - D / 2, zmin - zfl - D / 2, vcom))
        k = int(round(tt / (PERIOD / spc)))
        cyc, sub = divmod(k, spc)
        if cyc >= n0 and cyc < ncyc and sub % (spc // 4) == 0:
            q = sub // (spc // 4)
            prof_acc[q] += cg_profile(z - zfl, zg, lx)
            prof_n[q] += 1
    tr = np.array(tr)
    if frames and frames[0][2].shape[1] >= 6:
        write_temperature(out, frames, meta, zg)
    with open(out / "trajectory.csv", "w") as f:
        f.write("# every 1/(40 f); lab frame z (floor rest position z=0); *_rel = relative to the floor;"
                " top99 = height below which 99% of sphere centres lie; gap_* = (1st percentile / lowest"
                " centre) - floor - d/2\n")
        f.write("t_s,t_over_T,z_floor_m,com_lab_m,com_rel_m,top99_lab_m,top99_rel_m,gap_p01_m,gap_min_m,vz_com_m_s\n")
        for r in tr:
            f.write(",".join(f"{v:.6e}" if i not in (0, 1) else f"{v:.6f}" for i, v in enumerate(r)) + "\n")
    with open(out / "profiles.csv", "w") as f:
        f.write("# coarse-grained solid fraction vs height above the floor (z - z_floor), Gaussian kernel"
                f" sigma = d/2 of sphere volumes over the periodic cross-section; mean over the {meta['cycles_measured']}"
                " measured cycles at floor phase omega t = 0, pi/2, pi, 3pi/2 (z_floor = 0, +A, 0, -A)\n")
        f.write("z_rel_m,z_rel_over_d,phi_phase0,phi_phase_pi2,phi_phase_pi,phi_phase_3pi2\n")
        cols = [prof_acc[q] / max(1, prof_n[q]) for q in range(4)]
        for i, zz in enumerate(zg):
            f.write(f"{zz:.5e},{zz/D:.3f}," + ",".join(f"{c[i]:.5f}" for c in cols) + "\n")

    # --- summary
    meas = np.arange(n0, ncyc)
    tau = per[meas]
    tm = tr[:, 1] >= n0
    alt = period_doubling_measure(tau)
    # period-2 test on the mass centre (independent of the flight definition):
    # rms of com_rel(t+T)-com_rel(t) vs com_rel(t+2T)-com_rel(t) over the measured cycles
    c = tr[tm, 4]
    spc = SAMPLES_PER_CYCLE
    if len(c) > 3 * spc:
        p1 = float(np.sqrt(np.mean((c[spc:] - c[:-spc]) ** 2)))
        p2 = float(np.sqrt(np.mean((c[2 * spc:] - c[:-2 * spc]) ** 2)))
        alt.update({"com_rms_shift_T_over_d": p1 / D, "com_rms_shift_2T_over_d": p2 / D,
                    "com_std_over_d": float(c.std() / D),
                    "com_period2": bool(p1 > 0.1 * c.std() and p2 < 0.5 * p1)})
    summ = dict(meta)
    summ.update({
        "atoms_final": int(n_atoms[-1]),
        "floor_position_check_max_abs_err_m": floor_err,
        "max_overlap_pair_m": float(np.nanmax(a[:, 4])),
        "max_overlap_floor_m": float(np.nanmax(a[:, 5])),
        "max_overlap_pair_over_d": float(np.nanmax(a[:, 4]) / D),
        "max_overlap_floor_over_d": float(np.nanmax(a[:, 5]) / D),
        "overlap_sampling_steps": FORCE_EVERY,
        "flight_time_per_cycle_s": [None if math.isnan(v) else float(v) for v in tau],
        "flight_time_mean_s": float(np.nanmean(tau)),
        "flight_time_mean_over_T": float(np.nanmean(tau) / PERIOD),
        # the last six *finished* flights (an unfinished last flight dropped before counting,
        # so that a period-doubled bed's long and short flights stay balanced; the committed
        # summaries before 2026-12-02 took nanmean(tau[-6:]), and bsrflow compare-bed recomputes
        # this mean from flight_time_per_cycle_s)
        "flight_time_mean_last6_s": float(np.mean(tau[~np.isnan(tau)][-6:])),
        "flight_time_std_last6_s": float(np.std(tau[~np.isnan(tau)][-6:])),
        "off_floor_time_per_cycle_s": [float(v) for v in offfrac[meas]],
        "com_rel_mean_over_d": float(tr[tm, 4].mean() / D),
        "com_rel_max_over_d": float(tr[tm, 4].max() / D),
        "top99_rel_max_over_d": float(tr[tm, 6].max() / D),
        **alt,
    })
    if meta.get("floor_power"):
        summ.update(write_floor_power(out, wd, meta))
    (out / "summary.json").write_text(json.dumps(summ, indent=2))
    return summ


def period_doubling_measure(tau: np.ndarray) -> dict:
    """Alternation of successive flight times tau_n (measured cycles).

    a = mean over n of |tau_{n+1} - tau_n| / mean(tau); doubled when the even/odd
    cycle means differ by more than 10 % of the mean flight time and successive
    differences alternate in sign in at least 80 % of the cases."""
    tau = np.asarray(tau, dtype=float)
    tau = tau[~np.isnan(tau)]   # a flight still running at the end of the run
    if len(tau) < 4 or tau.mean() <= 0:
        return {"alternation": None, "period_doubled": False}
    d = np.diff(tau)
    a = float(np.mean(np.abs(d)) / tau.mean())
    even, odd = tau[0::2].mean(), tau[1::2].mean()
    split = float(abs(even - odd) / tau.mean())
    s = np.sign(d)
    alt_frac = float(np.mean(s[1:] * s[:-1] < 0)) if len(s) > 1 else 0.0
    return {"alternation": a, "even_odd_split": split, "sign_alternation_fraction": alt_frac,
            "flight_time_even_cycles_s": float(even), "flight_time_odd_cycles_s": float(odd),
            "period_doubled": bool(split > 0.10 and alt_frac >= 0.8)}


# ---------------------------------------------------------------- summary / params

def gap_flight(out: Path) -> dict:
    """Second flight measure from the positions (trajectory.csv, 40 samples/cycle):
    time per cycle during which the lowest 1 % of sphere centres are more than d/2
    above the floor (gap_p01 > 0). Written to flight_gap_per_cycle.csv."""
    s = json.loads((out / "summary.json").read_text())
    b = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=2)
    n0, ncyc = s["cycles_startup"], s["cycles_startup"] + s["cycles_measured"]
    cyc = np.floor(b[:, 1] + 1e-9).astype(int)
    per = np.array([np.mean(b[cyc == c, 7] > 0) * PERIOD if np.any(cyc == c) else np.nan
                    for c in range(ncyc)])
    with open(out / "flight_gap_per_cycle.csv", "w") as f:
        f.write("# time per cycle with the 1st percentile of centre heights > z_floor + d/2"
                " (from the 40 samples per cycle of trajectory.csv; resolution T/40)\n")
        f.write("cycle,measured,gap_flight_time_s,gap_flight_time_over_T\n")
        for c in range(ncyc):
            f.write(f"{c},{int(c >= n0)},{per[c]:.6f},{per[c]/PERIOD:.4f}\n")
    tau = per[n0:ncyc]
    g = {"gap_flight_time_per_cycle_s": [float(v) for v in tau],
         "gap_flight_time_mean_last6_s": float(np.mean(tau[-6:]))}
    pdm = period_doubling_measure(tau[-6:])
    g["gap_flight_period_doubled_last6"] = pdm["period_doubled"]
    g["gap_flight_even_odd_split_last6"] = pdm.get("even_odd_split")
    # the force-based period-doubling test on the last 6 measured cycles only (the
    # start-up transient of the strongest shaking lasts into the first measured cycles)
    finished = np.array([np.nan if v is None else v for v in s["flight_time_per_cycle_s"]], dtype=float)
    p6 = period_doubling_measure(finished[~np.isnan(finished)][-6:])
    g.update({k + "_last6": v for k, v in p6.items()})
    s.update(g)
    (out / "summary.json").write_text(json.dumps(s, indent=2))
    return s


def write_flight_table(path: Path, main: list, e_val: float, e_floor: float | None = None) -> None:
    floor = "" if e_floor is None else f", sphere-floor e={e_floor:g}"
    with open(path, "w") as f:
        f.write(f"# N=2000, {main[0]['model']}, friction {main[0]['friction']:g}, e={e_val:g}{floor};"
                " flight times of the measured cycles\n")
        f.write("gamma,flight_time_mean_s,flight_time_mean_over_T,flight_time_even_s,flight_time_odd_s,"
                "even_odd_split,sign_alternation_fraction,period_doubled,com_period2,"
                "even_odd_split_last6,period_doubled_last6,"
                "flight_time_mean_last6_s,gap_flight_time_mean_last6_s,max_overlap_over_d,wall_time_s,cpu_time_s,"
                "flight_times_s\n")
        for s in main:
            f.write(f"{s['gamma']:.2f},{s['flight_time_mean_s']:.5f},{s['flight_time_mean_over_T']:.4f},"
                    f"{s.get('flight_time_even_cycles_s', float('nan')):.5f},"
                    f"{s.get('flight_time_odd_cycles_s', float('nan')):.5f},"
                    f"{s.get('even_odd_split') or 0:.4f},{s.get('sign_alternation_fraction') or 0:.3f},"
                    f"{int(s['period_doubled'])},{int(bool(s.get('com_period2')))},"
                    f"{s.get('even_odd_split_last6') or 0:.4f},{int(s['period_doubled_last6'])},"
                    f"{s['flight_time_mean_last6_s']:.5f},{s['gap_flight_time_mean_last6_s']:.5f},"
                    f"{max(s['max_overlap_pair_over_d'], s['max_overlap_floor_over_d']):.5f},"
                    f"{s['wall_time_s']:.1f},{s.get('cpu_time_s', float('nan')):.1f},"
                    + " ".join("nan" if v is None else f"{v:.4f}" for v in s["flight_time_per_cycle_s"]) + "\n")


def summary() -> None:
    rows = []
    for p in sorted(RESULTS.glob("gamma_*/summary.json")):
        s = gap_flight(p.parent)
        rows.append(s)
    pdg_by_e = {}
    groups = (("walton_braun", 0.0, 0.9, "flight_vs_gamma.csv", "0.9", None),
              ("walton_braun", 0.0, 0.5, "flight_vs_gamma_e0.5.csv", "0.5", None),
              ("hooke", 0.5, 0.9, "flight_vs_gamma_hooke_mu0.5.csv", "hooke_mu0.5", None),
              ("hooke", 0.0, 0.9, "flight_vs_gamma_hooke.csv", "hooke", None),
              ("walton_braun", 0.0, 0.9, "flight_vs_gamma_ew1.csv", "ew1", 1.0))
    for model_, mu_, e_val, fname, key, e_floor in groups:
        main = [s for s in rows if s["n"] == 2000 and s["model"] == model_ and s["friction"] == mu_
                and s.get("restitution", 0.9) == e_val and s.get("floor_restitution") == e_floor
                and s.get("seed") is None and s.get("K_N_m", DEFAULT_K_N) == DEFAULT_K_N
                and (s["cycles_startup"], s["cycles_measured"]) == (CYCLES_STARTUP, CYCLES_MEASURED)]
        if not main:
            continue
        main.sort(key=lambda s: s["gamma"])
        write_flight_table(OUT / fname, main, e_val, e_floor)
        pd_g = [s["gamma"] for s in main if s["period_doubled_last6"]]
        below = [s["gamma"] for s in main if not s["period_doubled_last6"] and (not pd_g or s["gamma"] < min(pd_g))]
        pdg = None
        if pd_g:
            lo = max(below) if below else None
            pdg = {"first_doubled_gamma": min(pd_g), "last_single_gamma_below": lo,
                   "estimate": 0.5 * (min(pd_g) + lo) if lo is not None else min(pd_g)}
        pdg_by_e[key] = {"gammas": [s["gamma"] for s in main], "period_doubling": pdg}
    pdg = pdg_by_e.get("0.9", {}).get("period_doubling")
    params = json.loads((OUT / "params.json").read_text()) if (OUT / "params.json").exists() else {}
    params["gamma_list_main"] = pdg_by_e.get("0.9", {}).get("gammas")
    params["period_doubling_gamma"] = pdg
    params["period_doubling_gamma_exploratory_e0.5"] = pdg_by_e.get("0.5", {}).get("period_doubling")
    params["period_doubling_gamma_friction_mu0.5"] = pdg_by_e.get("hooke_mu0.5", {}).get("period_doubling")
    params["gamma_list_friction_mu0.5"] = pdg_by_e.get("hooke_mu0.5", {}).get("gammas")
    # the frictionless spring-dashpot bed (the friction runs' control law) over Gamma, since 2026-12-04
    params["period_doubling_gamma_spring_dashpot"] = pdg_by_e.get("hooke", {}).get("period_doubling")
    params["gamma_list_spring_dashpot"] = pdg_by_e.get("hooke", {}).get("gammas")
    # the Walton-Braun bed with elastic sphere-floor contacts (--floor-restitution 1), since 2026-12-04
    params["gamma_list_elastic_floor"] = pdg_by_e.get("ew1", {}).get("gammas")
    params["period_doubling_note"] = ("main runs (e=0.9, frictionless): no period doubling for 1.5 <= Gamma <= 6 "
                                      "(null); e=0.5 runs are exploratory (same settled bed, same K and dt)")
    params["runs"] = [{k: s.get(k) for k in ("name", "gamma", "n", "lateral_d", "model", "friction", "restitution",
                                         "floor_restitution", "seed", "K_N_m", "cycles_measured", "wall_time_s", "cpu_time_s", "loop_time_s", "steps", "flight_time_mean_s",
                                         "flight_time_mean_last6_s", "gap_flight_time_mean_last6_s",
                                         "period_doubled", "period_doubled_last6", "com_period2",
                                         "max_overlap_pair_over_d",
                                         "max_overlap_floor_over_d")} for s in rows]
    (OUT / "params.json").write_text(json.dumps(params, indent=2))
    print(json.dumps(pdg))
    # markdown table for the README
    print("| run | Γ | flight time per measured cycle [ms] | mean of last 6 [ms] | mean/T | even/odd split (last 6) |"
          " com period-2 | flight period-2 | gap-based off-floor time, mean of last 6 [ms] |"
          " max overlap pair/floor [% d] | wall [s] | CPU [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for s in sorted(rows, key=lambda s: (s["n"], s["model"], s["friction"], -s.get("restitution", 0.9), s["gamma"])):
        print(f"| {s['name']} | {s['gamma']:g} | "
              + " ".join("(in flight at end)" if v is None else f"{1e3*v:.1f}" for v in s["flight_time_per_cycle_s"])
              + f" | {1e3*s.get('flight_time_mean_last6_s', float('nan')):.1f} | {s['flight_time_mean_over_T']:.3f} | "
              f"{s.get('even_odd_split_last6') or 0:.3f} | {'yes' if s.get('com_period2') else 'no'} | "
              f"{'yes' if s['period_doubled_last6'] else 'no'} | "
              f"{1e3*s['gap_flight_time_mean_last6_s']:.1f} | "
              f"{100*s['max_overlap_pair_over_d']:.2f} / {100*s['max_overlap_floor_over_d']:.2f} | "
              f"{s['wall_time_s']:.0f} | {s.get('cpu_time_s', float('nan')):.0f} |")


def write_params(extra: dict) -> None:
    p = OUT / "params.json"
    params = json.loads(p.read_text()) if p.exists() else {}
    dt, ndump = timestep()
    params.update({
        "d_m": D, "rho_s_kg_m3": RHO, "mass_kg": MASS, "K_N_m": K_N, "e": E_REST,
        "K_unload_N_m": K_N / E_REST ** 2,
        "contact_law": "edinburgh/stiffness, linear (overlapExponent 1), no adhesion, no dashpot: "
                       "Walton-Braun, loading K, unloading K/e^2",
        "contact_time_pair_s": contact_time(MASS / 2), "contact_time_floor_s": contact_time(MASS),
        "dt_s": dt, "steps_per_dump": ndump, "dump_interval_s": PERIOD / SAMPLES_PER_CYCLE,
        "f_Hz": FREQ, "g_m_s2": G, "cycles_startup": CYCLES_STARTUP,
        "cycles_measured": CYCLES_MEASURED, "floor_force_sampling_steps": FORCE_EVERY,
        "cg_kernel": "Gaussian, sigma = d/2, point volumes at sphere centres",
        "top_definition": "99th percentile of sphere-centre heights",
        "flight_definition": "1-ms moving average of the floor force < 0.1 M g for > 1 ms",
        "N_main": 2000, "box_main_m": {"lx": 13 * D, "ly": 13 * D, "z": [-0.02, box_top(2000, 13 * D)]},
        "N_wide": 10000, "box_wide_m": {"lx": 29 * D, "ly": 29 * D, "z": [-0.02, box_top(10000, 29 * D)]},
        "boundary": "periodic x, y; floor mesh at z_floor = A sin(omega t); open top (fixed boundary at z = 0.5 m)",
        "friction_main": 0.0,
        "friction_runs": {"mu": 0.5, "gammas": "3 (the requested frictional run) and 3.5, 4, 4.5 (period doubling)", "law": "hooke/stiffness + tangential history, k_t = 2K/7, viscoelastic "
                         "dashpot for e (gamman_abs: sphere-sphere 2*sqrt(m/2*K)*(-ln e)/sqrt(pi^2+ln^2 e), "
                         "sphere-floor with m), tangential_damping off, limitForce on",
                         "control": "same law with mu = 0 (tangential no_history)"},
    })
    params.update(extra)
    p.write_text(json.dumps(params, indent=2))


def _refresh_runs(ap, option: str, names, needed: str) -> list:
    """The runs a refresh option names ('all': every finished run, i.e. with its summary.json,
    that has work/<run>/<needed>); a named run without that file is refused in one line."""
    if not names:
        return []
    if names == ["all"]:
        return sorted(p.parent.name for p in WORK.glob(f"gamma_*/{needed}")
                      if (RESULTS / p.parent.name / "summary.json").exists())
    for name in names:
        if not (WORK / name / needed).exists():
            ap.error(f"argument {option}: {name!r} has no work/{name}/{needed} (run it with --gamma)")
    return list(names)


def main(argv=None):
    global E_REST, E_FLOOR, FLOOR_POWER, WORK, RESULTS, OUT, SEED, K_N
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="single-sphere / two-sphere contact checks")
    ap.add_argument("--settle", action="store_true", help="pour and settle the bed")
    ap.add_argument("--gamma", type=float, nargs="*", help="vibrate at these Gamma values")
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--lateral", type=float, default=13.0, help="box side in diameters")
    ap.add_argument("--friction", type=float, default=0.0)
    ap.add_argument("--model", choices=("walton_braun", "hooke"), default="walton_braun")
    ap.add_argument("--startup", type=int, default=CYCLES_STARTUP,
                    help=f"start-up cycles before the measured ones (default {CYCLES_STARTUP}; another value adds "
                         "_c<cycles>s<startup> to the run's name)")
    ap.add_argument("--measured", type=int, default=CYCLES_MEASURED,
                    help=f"measured cycles (default {CYCLES_MEASURED}; another value names the run _c<cycles>, "
                         "cycles = startup + measured, so it never overwrites the main run)")
    ap.add_argument("--restitution", type=float, default=E_REST,
                    help="e for the vibration run (exploratory; the settled bed is the e=0.9 one)")
    ap.add_argument("--floor-restitution", type=float, metavar="E",
                    help="e of the sphere-floor contacts only (default: --restitution's); the runs' folders "
                         "end in _ew<E>")
    ap.add_argument("--floor-power", action="store_true",
                    help="with --gamma: also measure the sphere-floor contacts' energy budget (LIGGGHTS's "
                         "store_force; the run's other files are unchanged): results/RUN/floor_power_per_cycle.csv")
    ap.add_argument("--stiffness", type=float, default=DEFAULT_K_N, metavar="K",
                    help=f"the contacts' loading stiffness [N/m] (default {DEFAULT_K_N:g}); another value settles and "
                         "vibrates its own bed, whose folders end in _K<K> (the time step follows K)")
    ap.add_argument("--post", metavar="RUN", help="re-run the post-processing of work/RUN")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED, metavar="S",
                    help=f"seed of the random insertion before settling (default {DEFAULT_SEED}); another seed "
                         "pours another packing of the same bed: its settle and vibration folders end in _seed<S>")
    ap.add_argument("--thresholds", metavar="RUN", nargs="+",
                    help="write results/RUN/flight_vs_threshold.csv from work/RUN/floor.txt ('all': every finished "
                         "run, with its summary.json, that has one), without running LIGGGHTS")
    ap.add_argument("--structure", metavar="RUN", nargs="+",
                    help="write results/RUN/structure_per_cycle.csv from work/RUN/bed.dump ('all': every finished "
                         "run, with its summary.json, that has one), without running LIGGGHTS")
    ap.add_argument("--summary", action="store_true")
    ap.add_argument("--settle-post", action="store_true", help="redo the packing statistics")
    ap.add_argument("--root", metavar="DIR", help="write work/, results/ and the JSON files under DIR instead of "
                    "this folder (bench/bench_bed.py: a timing run that leaves the committed data alone)")
    a = ap.parse_args(argv)
    for g in a.gamma or []:
        if not (math.isfinite(g) and g > 0):
            ap.error(f"argument --gamma: {g!r} is outside the valid range (0, inf)")
    for name, lo in (("n", 1), ("lateral", 1.0), ("startup", 0), ("measured", 1)):
        if getattr(a, name) < lo:
            ap.error(f"argument --{name}: {getattr(a, name)!r} is outside the valid range [{lo}, inf)")
    if not (0.0 <= a.friction and 0.0 < a.restitution <= 1.0):
        ap.error(f"argument --friction / --restitution: {a.friction!r} / {a.restitution!r} is outside the valid "
                 "range [0, inf) / (0, 1]")
    if a.floor_restitution is not None and not (0.0 < a.floor_restitution <= 1.0):
        ap.error(f"argument --floor-restitution: {a.floor_restitution!r} is outside the valid range (0, 1]")
    if a.floor_restitution is not None and (a.check or a.settle or a.settle_post):
        ap.error("argument --floor-restitution: only for the vibration runs (--gamma); --check, --settle and "
                 "--settle-post keep the contact law's e at the floor")
    if not (math.isfinite(a.stiffness) and a.stiffness > 0):
        ap.error(f"argument --stiffness: {a.stiffness!r} is outside the valid range (0, inf)")
    if a.stiffness != DEFAULT_K_N and (a.check or a.summary or a.thresholds or a.structure):
        ap.error("argument --stiffness: only for --settle, --settle-post, --gamma and --post (the contact checks "
                 "and the summary are the default stiffness's; --thresholds and --structure name their runs)")
    if a.floor_power and not a.gamma:
        ap.error("argument --floor-power: only with --gamma (it measures a vibration run)")
    if a.floor_power and a.measured < 3:
        ap.error(f"argument --floor-power: needs --measured of at least 3 (not {a.measured}): its phase table "
                 "takes the measured cycles but the first and the last")
    if a.floor_power and a.friction != 0.0:
        ap.error(f"argument --floor-power: only for frictionless runs (--friction 0, not {a.friction:g}): it "
                 "measures the floor contacts' normal work, and friction's tangential work would be missed")
    if not 0 <= a.seed < 2 ** 32:
        ap.error(f"argument --seed: {a.seed!r} is outside the valid range [0, 2^32)")
    if a.seed != DEFAULT_SEED and (a.check or a.post or a.thresholds or a.structure or a.summary
                                   or not (a.settle or a.settle_post or a.gamma)):
        ap.error("argument --seed: only for --settle, --settle-post and --gamma (the other actions name their runs "
                 "or use no packing)")
    E_REST = a.restitution
    E_FLOOR = a.floor_restitution
    K_N = a.stiffness
    FLOOR_POWER = a.floor_power
    SEED = a.seed
    if a.root:
        OUT = Path(a.root).resolve()
        WORK, RESULTS = OUT / "work", OUT / "results"
    # the runs --thresholds and --structure refresh, checked before any work
    thresholds_runs = _refresh_runs(ap, "--thresholds", a.thresholds, "floor.txt")
    structure_runs = _refresh_runs(ap, "--structure", a.structure, "bed.dump")
    WORK.mkdir(exist_ok=True)
    RESULTS.mkdir(exist_ok=True)
    if a.check:
        res = {m: check_contacts(m) for m in ("walton_braun", "hooke")}
        name = "contact_check.json" if E_REST == 0.9 else f"contact_check_e{E_REST:g}.json"
        (OUT / name).write_text(json.dumps(res, indent=2))
        print(json.dumps(res, indent=2))
    if a.settle:
        res = settle(a.n, a.lateral, "walton_braun")
        (OUT / f"settled_{tag(a.n, a.lateral)}.json").write_text(json.dumps(res, indent=2))
        if K_N == DEFAULT_K_N:        # params.json holds the default stiffness's bed
            write_params({f"settled_{tag(a.n, a.lateral)}": res})
        print(json.dumps(res, indent=2))
    if a.settle_post:
        res = settle_post(a.n, a.lateral)
        (OUT / f"settled_{tag(a.n, a.lateral)}.json").write_text(json.dumps(res, indent=2))
        if K_N == DEFAULT_K_N:        # params.json holds the default stiffness's bed
            write_params({f"settled_{tag(a.n, a.lateral)}": res})
        print(json.dumps(res, indent=2))
    if a.gamma:
        if E_REST == 0.9 and E_FLOOR is None and K_N == DEFAULT_K_N:
            write_params({})
        for g in a.gamma:
            s = vibrate(g, a.n, a.lateral, a.model, a.friction, a.startup, a.measured)
            s = gap_flight(RESULTS / s["name"])
            print(json.dumps({k: s.get(k) for k in (
                "name", "wall_time_s", "cpu_time_s", "flight_time_per_cycle_s",
                "flight_time_mean_last6_s", "gap_flight_time_mean_last6_s", "period_doubled_last6",
                "com_period2", "max_overlap_pair_over_d", "max_overlap_floor_over_d")}, indent=1))
    if a.post:
        s = postprocess(a.post)
        print(json.dumps(s, indent=1))
    for name in thresholds_runs:
        refresh_thresholds(name)
        print(f"results/{name}/flight_vs_threshold.csv")
    for name in structure_runs:
        refresh_structure(name)
        print(f"results/{name}/structure_per_cycle.csv")
    if a.summary:
        summary()


if __name__ == "__main__":
    main()
