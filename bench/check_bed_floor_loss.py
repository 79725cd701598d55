"""How much the floor's contacts dissipate: LIGGGHTS against the continuum (issue #19).

    python bench/check_bed_floor_loss.py [--gamma 2 3 4.5] [--floor-loss kinetic_pressure|floor_reaction]
                                         [--json PATH]

LIGGGHTS's side comes from the committed reference
(``reference/liggghts_bed/results/gamma_<Γ>_N2000_L13d/``, written by ``run_liggghts.py --gamma 2 3
4.5 --floor-power``): per window of one period, the floor's work on its contacts ∫F v_floor dt and the
energy those sphere–floor contacts dissipated (the floor's work minus the contacts' work on the
spheres, ``floor_power_per_cycle.csv``), the continuum's wall-loss closure evaluated on
LIGGGHTS's own state at the floor (``floor_loss_by_phase.csv``), and the hard-sphere contact
theorem's loss with the whole floor force instead of the kinetic pressure,
(1 − e_w) F √(2θ_z/π) (F the committed force series' mean per phase bin, √θ_z the bottom layer's at the bin's two
frames, averaged).  The continuum's side is the
reference bed (:func:`bsrflow.analysis.compare_bed.reference_bed`, compare-bed's, at that Γ) on the Lagrangian
cells, started as ``compare-bed`` starts it and stepped here one step at a time with the package's
compiled step function (:func:`bsrflow.numerics.bed_lagrangian.bed_step`; a run cuts its steps at the
saves, so its steps differ slightly) so as to
sum, over the same windows, the floor's work R A v_floor Δt and the floor's collisional loss, the
only loss the continuum puts at the floor ((1 − e_w) p √(2θ/π) A,
:func:`bsrflow.physics.granular_bed.wall_loss`; with ``--floor-loss floor_reaction`` the whole
reaction's (1 − e_w) R √(2θ/π) A, :func:`~bsrflow.physics.granular_bed.wall_loss_from_reaction`).  Then, from the committed files alone, the Γ = 3
floor budgets of the main bed, of the bed at four times the stiffness and of the control with
elastic floor contacts (whose loss must be 0).  Energies in mJ per cycle; about 5 s per Γ.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from _args import Parser, output_json, repo_path, write_json
from bsrflow.analysis.compare_bed import REFERENCE, _read_csv, reference_bed
from bsrflow.numerics.bed_lagrangian import GranularBedColumn, _compile_bed, bed_step
from bsrflow.physics.granular_bed import FLOOR_LOSSES

GAMMAS = (2.0, 3.0, 4.5)
"""The Γ of the committed --floor-power runs."""


def run_folder(gamma: float) -> str:
    return f"reference/liggghts_bed/results/gamma_{gamma:.2f}_N2000_L13d"


def dem_side(folder: str) -> dict:
    """LIGGGHTS's floor budget from the committed CSVs (module docstring)."""
    path = f"{folder}/floor_power_per_cycle.csv"
    with open(path) as fh:
        phase = float(fh.readline().split("[cycle + ")[1].split(",")[0])
    a = _read_csv(path)
    m = a["measured"] == 1
    with open(f"{folder}/floor_loss_by_phase.csv") as fh:
        first, last = (int(c) for c in fh.readline().split("cycles ")[1].split(":")[0].split("-"))
    b = _read_csv(f"{folder}/floor_loss_by_phase.csv")
    with open(f"{folder}/summary.json") as fh:
        summ = json.load(fh)
    base = reference_bed(REFERENCE)[2]
    # the floor's restitution: the run's own where its summary gives it (older summaries give neither)
    e_w = summ.get("floor_restitution") or summ.get("restitution") or base.restitution
    period = 1.0 / base.frequency
    # the hard-sphere contact theorem with the whole floor force: (1 - e_w) F sqrt(2 theta_z / pi), F the
    # committed force series' mean in each phase bin over the bins' cycles, sqrt(theta_z) the bottom layer's
    # at the bin's two frames (its start and end), averaged
    f = _read_csv(f"{folder}/floor_force.csv")
    tf, force = f["t_s"], f["F_floor_N"]
    bins = len(b["phase"])
    late = (tf >= first * period) & (tf < (last + 1) * period)
    k = np.floor((tf[late] / period % 1.0) * bins).astype(int)
    force_by_phase = np.array([force[late][k == j].mean() for j in range(bins)])
    speed = np.sqrt(2.0 * b["theta_z_bottom_m2_s2"] / np.pi)
    contact = (1.0 - e_w) * force_by_phase * 0.5 * (speed + np.roll(speed, -1))
    return {"window_phase": phase, "startup_cycles": int(summ["cycles_startup"]),
            "contact_theorem_with_floor_force_per_cycle_mJ": float(np.mean(contact) * period * 1e3),
            "cycles": [int(c) for c in a["cycle"][m]],
            "floor_work_mJ": [float(v) for v in a["floor_work_mJ"][m]],
            "floor_contact_loss_mJ": [float(v) for v in a["floor_contact_loss_mJ"][m]],
            "closure_on_dem_state_per_cycle_mJ": float(np.mean(b["closure_loss_W"]) * period * 1e3),
            "closure_vertical_on_dem_state_per_cycle_mJ": float(np.mean(b["closure_loss_vertical_W"]) * period * 1e3),
            "measured_by_phase_per_cycle_mJ": float(np.mean(b["measured_loss_W"]) * period * 1e3)}


def continuum_side(gamma: float, phase: float, first: int, floor_loss: str = "kinetic_pressure") -> dict:
    """The continuum's floor work and floor loss per window [cycle + phase, cycle + 1 + phase), the
    reference's bed (compare-bed's) at Γ with the floor loss's closure ``floor_loss``
    (:attr:`bsrflow.physics.granular_bed.BedSetup.floor_loss`), the windows from cycle ``first``
    (after the start-up)."""
    _compile_bed()
    s = reference_bed(REFERENCE)[2].with_(gamma=gamma, floor_loss=floor_loss)
    bed = GranularBedColumn(s)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    n = s.n_cells
    sig, pq = np.empty(n), np.empty(n)
    flux, cond = np.empty(n + 1), np.empty(n + 1)
    mu, rho_s, d, e, phi_c, k1, k2, g, amp, w = bed._args
    period, area = 1.0 / s.frequency, s.area
    ncyc = s.cycles
    work, loss = np.zeros(ncyc), np.zeros(ncyc)
    edge_force = np.zeros(ncyc)          # the floor reaction at each window's start [N]
    t, dt, steps = 0.0, float(bed.dt_next[0]), 0
    wall = time.perf_counter()
    while t < ncyc * period:
        gl = g - amp * w * w * math.sin(w * t)
        c_before = math.floor(t / period - phase)
        r, status, bound = bed_step(bed.zf, bed.vf, bed.th, bed.hist, sig, pq, flux, cond, dt, gl, mu, rho_s, d,
                                    e, phi_c, k1, k2, s.cfl, bed.c, s.dissipation_restitution,
                                    s.floor_dissipation_restitution, s.floor_loss_mode)
        if status:
            raise SystemExit(f"check_bed_floor_loss: a cell's thickness reached 0 at t = {t:.6g} s")
        t += dt
        c = math.floor(t / period - phase)
        if 0 <= c < ncyc:
            if c != c_before:
                edge_force[c] = r * area
            work[c] += r * area * amp * w * math.cos(w * t) * dt
            loss[c] += -flux[0] * area * dt
        dt = bound
        steps += 1
    cyc = list(range(first, ncyc - 1))      # whole windows only
    return {"cycles": cyc, "floor_work_mJ": [float(work[c] * 1e3) for c in cyc],
            "floor_loss_mJ": [float(loss[c] * 1e3) for c in cyc],
            "reaction_at_window_start_over_weight": [float(edge_force[c] / (s.mass_per_area * area * s.gravity))
                                                     for c in cyc],
            "steps": steps, "wall_time_s": time.perf_counter() - wall}


def compare(gamma: float, floor_loss: str = "kinetic_pressure") -> dict:
    """Both sides at one Γ, printed (module docstring)."""
    dem = dem_side(repo_path(run_folder(gamma)))
    cont = continuum_side(gamma, dem["window_phase"], dem["startup_cycles"], floor_loss)
    print(f"Γ = {gamma:g}: windows [cycle + {dem['window_phase']:.4f}, cycle + 1 + {dem['window_phase']:.4f}) "
          "periods, mJ")
    print(f"cycle  LIGGGHTS: floor work  floor-contact loss   continuum ({floor_loss}): floor work  floor loss")
    for i, c in enumerate(dem["cycles"]):
        j = cont["cycles"].index(c) if c in cont["cycles"] else None
        cw = f"{cont['floor_work_mJ'][j]:10.2f}  {cont['floor_loss_mJ'][j]:10.3f}" if j is not None else ""
        print(f"{c:5d}  {dem['floor_work_mJ'][i]:19.2f}  {dem['floor_contact_loss_mJ'][i]:18.3f}   {cw}")
    mean = {"dem_floor_work_mJ": float(np.mean(dem["floor_work_mJ"][1:])),
            "dem_floor_contact_loss_mJ": float(np.mean(dem["floor_contact_loss_mJ"][1:])),
            "continuum_floor_work_mJ": float(np.mean(cont["floor_work_mJ"][1:])),
            "continuum_floor_loss_mJ": float(np.mean(cont["floor_loss_mJ"][1:]))}
    print("means over cycles {}-{}: LIGGGHTS {:.2f} / {:.3f} mJ ({:.1f} % of the floor's work), continuum {:.2f} / "
          "{:.3f} mJ ({:.1f} %)".format(dem["cycles"][1], dem["cycles"][-1], mean["dem_floor_work_mJ"],
                                        mean["dem_floor_contact_loss_mJ"],
                                        100 * mean["dem_floor_contact_loss_mJ"] / mean["dem_floor_work_mJ"],
                                        mean["continuum_floor_work_mJ"], mean["continuum_floor_loss_mJ"],
                                        100 * mean["continuum_floor_loss_mJ"] / mean["continuum_floor_work_mJ"]))
    print(f"the continuum's wall-loss closure on LIGGGHTS's own floor state: "
          f"{dem['closure_on_dem_state_per_cycle_mJ']:.3f} mJ per cycle (vertical theta: "
          f"{dem['closure_vertical_on_dem_state_per_cycle_mJ']:.3f}) against the measured "
          f"{dem['measured_by_phase_per_cycle_mJ']:.3f}; the contact theorem with the whole floor force and the "
          f"bottom layer's theta_z: {dem['contact_theorem_with_floor_force_per_cycle_mJ']:.3f}\n")
    return {"gamma": gamma, "floor_loss": floor_loss, "liggghts": dem, "continuum": cont, "means": mean}


CONTROLS = (("N2000_L13d", "the main bed at K"),
            ("N2000_L13d_K200000", "the bed at 4 K (settled with it)"),
            ("N2000_L13d_ew1", "the control: elastic sphere-floor contacts"))
"""The Γ = 3 runs whose floor budgets the controls' lines print (reference folder tags)."""


def dem_controls() -> list:
    """The floor budget of each of :data:`CONTROLS` over its measured windows (the start-up's end
    to the last whole window, as run_liggghts.py's summary takes them), printed: the floor's work,
    the contacts' loss and the loss over the work."""
    out = []
    print("Γ = 3, LIGGGHTS, means over the measured windows (mJ per cycle):")
    for tag, label in CONTROLS:
        rows = _read_csv(repo_path(f"reference/liggghts_bed/results/gamma_3.00_{tag}/floor_power_per_cycle.csv"))
        m = rows["measured"] == 1
        work, loss = float(rows["floor_work_mJ"][m].mean()), float(rows["floor_contact_loss_mJ"][m].mean())
        print(f"  {label}: floor's work {work:.2f}, floor contacts' loss {loss:.4f} ({loss / work:+.1e} of the work)")
        out.append({"tag": tag, "label": label, "floor_work_mJ": work, "floor_contact_loss_mJ": loss})
    return out


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--gamma", type=float, nargs="+", choices=GAMMAS, default=list(GAMMAS), metavar="G",
                    help="Γ of the committed --floor-power runs: " + ", ".join(f"{g:g}" for g in GAMMAS))
    ap.add_argument("--floor-loss", choices=FLOOR_LOSSES, default="kinetic_pressure",
                    help="the continuum's floor-loss closure (BedSetup.floor_loss; default: kinetic_pressure)")
    ap.add_argument("--json", type=output_json, metavar="PATH", help="write the numbers as JSON")
    a = ap.parse_args(argv)
    cases = [compare(g, a.floor_loss) for g in dict.fromkeys(a.gamma)]
    controls = dem_controls()
    if a.json:
        write_json(a.json, {"cases": cases, "gamma3_controls": controls})


if __name__ == "__main__":
    main()
