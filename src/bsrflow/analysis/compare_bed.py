"""``bsrflow compare-bed``: the vibrated bed's continuum against the committed LIGGGHTS data
(issue #19; the model: :mod:`bsrflow.physics.granular_bed`, the data: reference/liggghts_bed).

The continuum is the horizontally uniform bed, i.e. the 1-D limit of the 3-D bed, on Lagrangian
cells: the packing stress of the contact law plus the granular temperature of kinetic theory,
nothing fitted.  ``--eulerian DIM`` runs the same model on the Eulerian grid of
:mod:`bsrflow.numerics.bed_eulerian` too, as a column (DIM 1) or a 2-D / 3-D bed with periodic
sides (whose horizontally uniform state equals the column bit for bit), at every main Γ
(``eulerian_cases``: against LIGGGHTS and against the Lagrangian run).  For every Γ of the main LIGGGHTS runs (N = 2000, Walton–Braun, e = 0.9, frictionless)
the same measures as the reference's post-processing (``reference/liggghts_bed/run_liggghts.py``):

* flight time per cycle: the maximal intervals with the 1-ms moving average of the floor force
  below 0.1 Mg, longer than 1 ms, each assigned to the cycle of its take-off; the steady value
  is the mean over the last six cycles (cycles 5–10); ``flight_by_threshold`` gives the same
  measure with the force cut at 0.05–0.8 Mg (where the reference has its
  flight_vs_threshold.csv), a diagnostic of where in the landing and take-off the two differ;
* mass-centre RMS: the RMS difference of the mass-centre heights above the floor over the five
  cycles after the three start-up cycles (3T ≤ t < 8T), in d;
* period doubling: the even/odd split of the last six flights above 10 % of their mean with
  alternating successive differences in at least 80 % of the cases; the Γ of the doubling is
  the midpoint between the last single and the first doubled Γ.

The exploratory e = 0.5 runs and the frictional runs (μ = 0.5, spring–dashpot, Γ = 3–4.5) are
compared too, and each main case's continuum run also with the frictionless spring–dashpot bed
at the same Γ (``spring_dashpot_cases``: the same K and e, another contact law), and the Γ = 3
run with the reference's lateral-size run (``large_box_cases``: N = 10 000 in a 29 d box).  The
main bed with elastic sphere–floor contacts (``elastic_floor_cases``, at the Γ it was run) is
compared with the continuum whose floor loss is elastic too (``floor_restitution`` = 1), and
``floor_contact_effect`` gives, per Γ, what the floor's restitution alone changes in either.
The bed settled and vibrated with four times the contacts' stiffness (``stiffer_bed_cases``,
Γ = 3) is compared with the continuum at that stiffness and that bed's φ_c and Z.
The same continuum runs against the main bed poured with other seeds (``other_packing_cases``,
``packing_spread``: the reference value's own spread over packings), where it was, and continuum
runs of 30 cycles against the 30-cycle LIGGGHTS runs (``long_reference_cases``: the main bed at
every Γ, other packings, another box and the other two Γ = 3 beds, where they were run;
LIGGGHTS's crystal-like fraction, floor-layer order and lateral waves per cycle in
``dem_structure``; ``dem_lateral_structure``: the lateral waves' amplitude per main case).  The
frictional runs twice: against the smooth continuum at Γ = 3 (the effect of friction, reported,
not tuned away) and against the continuum with friction μ = 0.5, which
enters only as the collisional losses' effective restitution e − (3/2)μ exp(−3μ) (Chialvo and
Sundaresan 2013, :attr:`BedSetup.dissipation_restitution`; a closure from the literature, not
fitted here).  The continuum's frictional period doubling is also measured over 30 cycles
(``period_doubling_gamma_friction_mu0.5``: its transient outlasts the reference's 11 cycles
near the doubling).  ``cost_s``: the continuum's wall time for the Γ = 3 run
(11 cycles, the same simulated time as the LIGGGHTS run; this machine, this run) and
LIGGGHTS's wall time from the committed summary (its run on this machine type, 2026-12-01,
serial, see reference/liggghts_bed/README.md).
"""

from __future__ import annotations

import contextvars
import json
import math
import os
import re
import time
from pathlib import Path

import numpy as np

from ..numerics.solver import SimulationError
from ..cli import Number, max_workers, workers_range
from ..physics.granular_bed import FLOOR_LOSSES, MAX_CELLS_PER_D, MAX_LATERAL_CELLS, MAX_PERTURBATION, BedSetup

CELLS_RANGE = (4, 1000)
"""``--cells``: the Lagrangian cells over the bed."""

__all__ = ["REFERENCE", "flights_from_force", "flight_per_cycle", "period_doubling_measure", "compare_bed",
           "add_parser"]

REFERENCE = Path(__file__).resolve().parents[3] / "reference" / "liggghts_bed"
FLIGHT_SMOOTH_S, FLIGHT_THRESHOLD, FLIGHT_MIN_S = 1e-3, 0.1, 1e-3
STARTUP_CYCLES = 3
FRICTION = 0.5
"""The Coulomb coefficient of the reference's frictional runs."""
LONG_CYCLES = 30
IN_FLIGHT_MARGIN = 0.05
"""Phases [cycles] kept away from the reference's mean take-off and landing in the in-flight loss ratio."""
LONG_FRICTION_GAMMAS = (3.0, 3.5, 3.75, 4.0, 4.5)
"""The continuum's frictional runs of :data:`LONG_CYCLES` cycles for its period-doubling Γ."""


def smoothed_force(t, force):
    """(the floor force's 1-ms moving average, the window in samples w): the flight measure's
    signal, ``np.convolve(..., mode="same")`` (its first w//2 and last (w − 1)//2 values average
    zero padding in)."""
    t = np.asarray(t, float)
    w = max(1, int(round(FLIGHT_SMOOTH_S / (t[1] - t[0]))))
    return np.convolve(np.asarray(force, float), np.ones(w) / w, mode="same"), w


def flights_from_force(t, force, weight, threshold=FLIGHT_THRESHOLD):
    """Flights: maximal intervals with the 1-ms moving average of the floor force below
    ``threshold`` (10 %) of the bed weight, longer than 1 ms (the reference's definition, written
    again here because reference/liggghts_bed/run_liggghts.py runs without bsrflow;
    tests/test_granular_bed.py checks both on the same series).  [(t_off, t_on)], t_on NaN
    for a flight still going at the end."""
    t = np.asarray(t, float)
    off = smoothed_force(t, force)[0] < threshold * weight
    out, i, n = [], 0, len(off)
    while i < n:
        if off[i]:
            j = i
            while j < n and off[j]:
                j += 1
            if i > 0 and j < n and t[j] - t[i] >= FLIGHT_MIN_S:
                out.append((float(t[i]), float(t[j])))
            elif i > 0 and j == n and t[j - 1] - t[i] >= FLIGHT_MIN_S:
                out.append((float(t[i]), float("nan")))
            i = j
        else:
            i += 1
    return out


def flight_per_cycle(flights, period, cycles):
    """Flight time [s] of each cycle: the longest flight taking off in it, as the reference's
    post-processing (0 if none; NaN if the cycle's flight is unfinished)."""
    out = np.zeros(cycles)
    for t_off, t_on in flights:
        c = int(t_off // period)
        if 0 <= c < cycles:
            dur = t_on - t_off
            out[c] = dur if math.isnan(dur) else (out[c] if math.isnan(out[c]) else max(out[c], dur))
    return out


def flight_phases(flights, period, cycles, n=6):
    """(mean take-off phase, mean landing phase) [fractions of a cycle, from the take-off cycle's
    start] of the longest finished flight of each of the last ``n`` cycles that have one (the
    flights of :func:`flights_from_force`); (None, None) without any."""
    best = {}
    for t_off, t_on in flights:
        c = int(t_off // period)
        if 0 <= c < cycles and not math.isnan(t_on) and (c not in best or t_on - t_off > best[c][1] - best[c][0]):
            best[c] = (t_off, t_on)
    keep = sorted(best)[-n:]
    if not keep:
        return None, None
    return (float(np.mean([best[c][0] / period - c for c in keep])),
            float(np.mean([best[c][1] / period - c for c in keep])))


def last_complete_flights(tau, n=6) -> np.ndarray:
    """The last ``n`` finished flights of the per-cycle flight times ``tau`` [s] (NaN or None:
    a flight still going at the end of the run, dropped before counting).  Counting back from
    the last *finished* flight keeps a period-doubled bed's long and short flights balanced: the
    unfinished flight at the end is the long one of its pair, so dropping it from the last six
    cycles left three short and two long flights and biased their mean low (by up to 13 % at
    Γ = 4.5, e = 0.5; a review, 2026-12-02)."""
    t = np.array([np.nan if v is None else v for v in tau], dtype=float)
    return t[~np.isnan(t)][-n:]


def period_doubling_measure(tau) -> dict:
    """Even/odd split of the flight times and the alternation of their differences (the
    reference's criterion: doubled when split > 10 % and alternation ≥ 80 %)."""
    tau = np.asarray(tau, float)
    tau = tau[~np.isnan(tau)]
    if len(tau) < 4 or tau.mean() <= 0:
        return {"even_odd_split": None, "period_doubled": False}
    d = np.diff(tau)
    split = float(abs(tau[0::2].mean() - tau[1::2].mean()) / tau.mean())
    s = np.sign(d)
    alt = float(np.mean(s[1:] * s[:-1] < 0)) if len(s) > 1 else 0.0
    return {"even_odd_split": split, "sign_alternation_fraction": alt,
            "period_doubled": bool(split > 0.10 and alt >= 0.8)}


def _doubling_gamma(gammas, doubled):
    """Midpoint between the last single Γ below the first doubled one and that one (None if none)."""
    pd = [g for g, d in zip(gammas, doubled) if d]
    if not pd:
        return None
    below = [g for g, d in zip(gammas, doubled) if not d and g < min(pd)]
    return 0.5 * (min(pd) + max(below)) if below else min(pd)


MAIN_RUNS = "N2000_L13d"
"""The tag of the main reference runs (:func:`_run_dir`): N = 2000 in a 13 d box, Walton–Braun,
e = 0.9, frictionless."""
E05_RUNS = "N2000_L13d_e0.5"
"""The exploratory e = 0.5 runs (same bed, same K)."""
FRICTION_RUNS = "N2000_L13d_hooke_mu0.5"
"""The frictional runs (spring–dashpot, μ = 0.5)."""


def _read_csv(path):
    """A CSV of the LIGGGHTS data folder (a comment line, the header, the rows) as a structured
    array; ValueError (one line, naming the file) when it is empty or not such a CSV."""
    import warnings
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")             # (numpy warns "Empty input file" and goes on)
            data = np.genfromtxt(path, delimiter=",", names=True, skip_header=1)
    except (IndexError, ValueError, StopIteration, UserWarning) as exc:
        raise ValueError(f"{path}: not a CSV of the LIGGGHTS data folder (a comment line, a header and rows; "
                         f"{type(exc).__name__}: {' '.join(str(exc).split())})") from None
    if data.dtype.names is None or data.size == 0:
        raise ValueError(f"{path}: not a CSV of the LIGGGHTS data folder (no rows under a header)")
    return data


def _run_dir(ref, gamma: float, tag: str = MAIN_RUNS) -> Path:
    """The folder of the reference run ``tag`` at Γ = ``gamma``: ``results/gamma_<Γ>_<tag>``, the
    tag naming the bed and the variant (:data:`MAIN_RUNS`, :data:`E05_RUNS`, :data:`SPRING_DASHPOT`,
    :data:`FRICTION_RUNS`, :data:`LARGE_BOX`)."""
    return Path(ref) / "results" / f"gamma_{gamma:.2f}_{tag}"


def _dem_flight_list(folder: Path):
    """The reference run's flights [(take-off, landing) in s] from its flights.csv, or None."""
    path = folder / "flights.csv"
    if not path.exists():
        return None
    return [(float(r["t_takeoff_s"]), float(r["t_landing_s"])) for r in np.atleast_1d(_read_csv(path))]


def _reference_case(ref: Path, gamma: float, tag: str):
    """(trajectory, summary) of a LIGGGHTS run, or (None, None)."""
    d = _run_dir(ref, gamma, tag)
    if not (d / "trajectory.csv").exists():
        return None, None
    return _read_csv(d / "trajectory.csv"), json.loads((d / "summary.json").read_text())


def _compare_one(setup: BedSetup, ref: Path, tag: str, progress=None):
    """(the case's dict, the continuum's run as :func:`_continuum_flights` returns it, the
    reference's trajectory) of the continuum bed ``setup`` against the reference run ``tag``
    (:func:`_case_against`)."""
    run = _continuum_flights(setup, progress)
    case, traj = _case_against(run, setup, ref, tag)
    return case, run, traj


def _startup_end(period):
    """The end of the start-up cycles [s], a hair early so that the sample at 3T is in (3 * 0.05 >
    0.15 in floats)."""
    return (STARTUP_CYCLES - 1e-9) * period


def _rms_window(t, period):
    """Mask of the times t in the five cycles after the start-up: the window of
    ``mass_centre_rms_over_d``."""
    t = np.asarray(t, float)
    return (t >= _startup_end(period)) & (t < (STARTUP_CYCLES + 5 - 1e-9) * period)


def _mass_centre_rms_over_d(traj, t, com, s: BedSetup) -> float:
    """The RMS difference [d] of a mass-centre series (t, com) [s, m], interpolated to the
    reference trajectory's times, from the reference's ``com_rel_m`` over the window of
    ``mass_centre_rms_over_d`` (:func:`_rms_window`; at the reference's own times the interpolation
    returns the series' values exactly)."""
    sel = _rms_window(traj["t_s"], s.period)
    return float(math.sqrt(np.mean((np.interp(traj["t_s"][sel], t, com) - traj["com_rel_m"][sel]) ** 2))
                 / s.diameter)


def _last_six(t, force, s: BedSetup, threshold=FLIGHT_THRESHOLD):
    """(flights, flight per cycle [s], the last six finished flights [s]) of a floor-force series
    over the setup's cycles, cut at ``threshold`` of the bed's weight (the flight measure)."""
    flights = flights_from_force(t, force, s.n_spheres * s.sphere_mass * s.gravity, threshold)
    tau = flight_per_cycle(flights, s.period, s.cycles)
    return flights, tau, last_complete_flights(tau)


def _case_against(run, setup: BedSetup, ref: Path, tag: str):
    """(the case's dict, the reference's trajectory) of a continuum run (:func:`_continuum_flights`'
    tuple) against the reference run ``tag`` at the setup's Γ: the same run can be compared with
    several references (the frictionless Walton–Braun and spring–dashpot beds)."""
    s = setup
    res, flights, tau, last6 = run
    traj, summ = _reference_case(ref, s.gamma, tag)
    takeoff, landing = flight_phases(flights, s.period, s.cycles)
    t_startup = _startup_end(s.period)
    case = {"gamma": s.gamma, "restitution": s.restitution, "friction": s.friction,
            **({} if s.floor_restitution is None else {"floor_restitution": s.floor_restitution}),
            "flight_time_s": float(np.mean(last6)), "flight_time_per_cycle_s": tau.tolist(),
            "period_doubled": period_doubling_measure(last6)["period_doubled"],
            "wall_time_s": res.wall_time, "steps": res.steps,
            "takeoff_phase": takeoff, "landing_phase": landing,
            "mass_centre_mean_over_d": float(np.mean(res.mass_centre[res.t >= t_startup]) / s.diameter),
            "top_max_over_d": float(res.top.max() / s.diameter)}
    if summ is not None:
        # the reference's per-cycle flights, with the same rule (its summary's own
        # flight_time_mean_last6_s dropped an unfinished last flight)
        dem_last6 = last_complete_flights(summ["flight_time_per_cycle_s"])
        dem_tau = float(np.mean(dem_last6))
        case.update({
            "dem_flight_time_s": dem_tau,
            "flight_time_rel_diff": case["flight_time_s"] / dem_tau - 1.0,
            "mass_centre_rms_over_d": _mass_centre_rms_over_d(traj, res.t, res.mass_centre, s),
            "dem_mass_centre_mean_over_d": float(summ["com_rel_mean_over_d"]),
            "dem_top_max_over_d": float(summ["top99_rel_max_over_d"]),
            "dem_period_doubled": period_doubling_measure(dem_last6)["period_doubled"],
            **_dem_phases(ref, s, tag),
            "dem_wall_time_s": float(summ["wall_time_s"]),
        })
        temp = _temperature_against_phase(res, flights, ref, s, tag)
        if temp is not None:
            case["temperature"] = temp
        force = _floor_force_against_phase(res, ref, s, tag, summ["n"])
        if force is not None:
            case["floor_force_over_weight"] = force
        by_threshold = _flight_by_threshold(res, ref, s, tag)
        if by_threshold is not None:
            case["flight_by_threshold"] = by_threshold
        structure = _run_dir(ref, s.gamma, tag) / "structure_per_cycle.csv"
        if structure.exists():
            rows = np.atleast_1d(_read_csv(structure))
            case["dem_structure"] = {"cycle": [int(v) for v in rows["cycle"]],
                                     "crystal_fraction": [float(v) for v in rows["crystal_fraction"]],
                                     "phi_1_6d": [float(v) for v in rows["phi_1_6d"]],
                                     "floor_layer_psi4": [float(v) for v in rows["floor_layer_psi4"]],
                                     "floor_layer_psi6": [float(v) for v in rows["floor_layer_psi6"]],
                                     "lateral_mode_over_d": [float(v) for v in rows["lateral_mode_over_d"]],
                                     "lateral_mode_shuffled_over_d": [float(v) for v in
                                                                      rows["lateral_mode_shuffled_over_d"]]}
    return case, traj


def _flight_by_threshold(res, ref: Path, s: BedSetup, tag: str):
    """The flight (mean of the last six finished flights) of both models with the floor force cut
    at each threshold of the reference's flight_vs_threshold.csv (fractions of the bed weight;
    0.1 is the criterion's flight), or None where the reference has no such file."""
    path = _run_dir(ref, s.gamma, tag) / "flight_vs_threshold.csv"
    if not path.exists():
        return None
    rows = np.atleast_1d(_read_csv(path))
    thresholds = [float(v) for v in rows["threshold_over_weight"]]
    dem = [float(v) for v in rows["flight_time_mean_last6_s"]]
    cont = [float(np.mean(_last_six(res.t, res.floor_force, s, th)[2])) for th in thresholds]
    return {"threshold_over_weight": thresholds, "continuum_s": cont, "dem_s": dem,
            "rel_diff": [c / d - 1.0 for c, d in zip(cont, dem)]}


FORCE_PHASE_BINS = 100
"""Phase bins of ``floor_force_over_weight`` (0.5 ms at 20 Hz)."""


def force_by_phase(t, force, weight, period, cycles, bins=FORCE_PHASE_BINS, last=6) -> np.ndarray:
    """The floor force over the bed's weight against the floor phase: the flight measure's signal
    (the 1-ms moving average, :func:`flights_from_force`) averaged per phase bin over the last
    ``last`` cycles of ``cycles`` (those of the flight's mean).  Over a periodic cycle its mean
    is 1: the floor carries the bed's weight on average."""
    t = np.asarray(t, dtype=float)
    smooth, w = smoothed_force(t, force)
    # only the samples whose whole window lies inside the series
    inside = np.zeros(t.size, dtype=bool)
    inside[w // 2:t.size - (w - 1) // 2] = True
    sel = inside & (t >= (cycles - last - 1e-9) * period)
    k = np.floor((t[sel] / period % 1.0) * bins).astype(int) % bins
    n = np.bincount(k, minlength=bins)
    return np.bincount(k, smooth[sel], minlength=bins) / np.maximum(n, 1) / weight


def _floor_force_against_phase(res, ref: Path, s: BedSetup, tag: str, dem_spheres: int):
    """Both beds' :func:`force_by_phase` at the case's Γ (the reference's floor_force.csv), each
    over its own weight (``dem_spheres``: the reference bed's N, 10 000 in the large box), or None."""
    path = _run_dir(ref, s.gamma, tag) / "floor_force.csv"
    if not path.exists():
        return None
    dem = _read_csv(path)
    weight = s.n_spheres * s.sphere_mass * s.gravity
    dem_weight = dem_spheres * s.sphere_mass * s.gravity
    return {"phase": ((np.arange(FORCE_PHASE_BINS) + 0.5) / FORCE_PHASE_BINS).tolist(),
            "continuum": force_by_phase(res.t, res.floor_force, weight, s.period, s.cycles).tolist(),
            "dem": force_by_phase(dem["t_s"], dem["F_floor_N"], dem_weight, s.period, s.cycles).tolist(),
            "note": "the floor force over the bed's weight, smoothed over 1 ms as the flight measure's signal "
                    "(a flight: below 0.1), mean per phase bin (floor at A sin(2 pi phase)) over the last six "
                    "cycles"}


def _temperature_against_phase(res, flights, ref: Path, s: BedSetup, tag: str):
    """The bed's mass-mean granular temperature and internal energy against the floor phase,
    continuum beside the reference's temperature.csv (when that run has one), each averaged over
    the measured cycles (3 to the end); None without the file.  The continuum's θ is isotropic;
    the reference's θ is (θ_z + 2θ_h)/3, its components given too [m²/s²].  Also the start: the
    internal energy T/20 after the floor's start [J] and the first landing [cycles], both beds
    (``flights``: the continuum's)."""
    folder = _run_dir(ref, s.gamma, tag)
    path = folder / "temperature.csv"
    if not path.exists():
        return None
    dem = _read_csv(path)
    phase = np.asarray(dem["phase_cycles"], dtype=float)
    times = (np.arange(STARTUP_CYCLES, s.cycles)[:, None] + phase[None, :]) * s.period
    cont = np.interp(times, res.t, res.theta_mean).mean(axis=0)
    energy = np.interp(times, res.t, res.internal_energy).mean(axis=0)
    dth = np.asarray(dem["theta_m2_s2"], dtype=float)
    col = {k: np.asarray(dem[k], dtype=float) for k in ("E_internal_J", "loss_W", "enskog_cs_loss_W")}
    out = {"phase": phase.tolist(), "continuum_theta_m2_s2": cont.tolist(), "dem_theta_m2_s2": dth.tolist(),
           "dem_theta_z_m2_s2": np.asarray(dem["theta_z_m2_s2"], dtype=float).tolist(),
           "dem_theta_h_m2_s2": np.asarray(dem["theta_h_m2_s2"], dtype=float).tolist(),
           "cycle_mean_ratio": float(cont.mean() / dth.mean()),
           # the DEM's anisotropy, which the continuum's isotropic θ leaves out
           "dem_theta_z_over_theta_cycle_mean": float(np.mean(dem["theta_z_m2_s2"]) / dth.mean()),
           "continuum_internal_energy_J": energy.tolist(), "dem_internal_energy_J": col["E_internal_J"].tolist(),
           "dem_loss_W": col["loss_W"].tolist(), "dem_enskog_cs_loss_W": col["enskog_cs_loss_W"].tolist(),
           "note": "the bed's mass-mean theta against the floor phase (floor at A sin(2 pi phase)), mean over "
                   "cycles 3-10; LIGGGHTS: (theta_z + 2 theta_h)/3 of the spheres' fluctuations about the "
                   "coarse-grained (sigma = d/2) mean velocity; continuum: the cells' mean theta. Internal energy: "
                   "the kinetic energy in the mass-centre frame (thermal + relative mean flow); dem_loss_W = its "
                   "-dE/dt, dem_enskog_cs_loss_W = the continuum's loss closure on LIGGGHTS's coarse-grained state"}
    takeoff, landing = (_dem_phases(ref, s, tag).get(k) for k in ("dem_takeoff_phase", "dem_landing_phase"))
    if takeoff is not None and landing is not None:
        # in flight, away from take-off and landing by 0.05 of a cycle: nothing but the contacts change E_int
        fly = _phase_window(phase, takeoff, landing, IN_FLIGHT_MARGIN)
        if fly.any():
            ratio = col["loss_W"][fly] / col["enskog_cs_loss_W"][fly]
            order = np.argsort((phase[fly] - takeoff) % 1.0)            # in time order, across phase 0
            out["dem_loss_over_enskog_cs_in_flight"] = {"phases": [float(phase[fly][order[0]]),
                                                                   float(phase[fly][order[-1]])],
                                                        "median": float(np.median(ratio)),
                                                        "min": float(ratio.min()), "max": float(ratio.max())}
    series = folder / "internal_energy.csv"
    dem_flights = _dem_flight_list(folder)
    if series.exists() and dem_flights and flights:
        e_dem = _read_csv(series)
        t_kick = s.period / 20.0
        out["start"] = {
            "internal_energy_at_T_over_20_J": {
                "continuum": float(np.interp(t_kick, res.t, res.internal_energy)),
                "dem": float(np.interp(t_kick, e_dem["t_s"], e_dem["E_internal_J"]))},
            "first_landing_cycles": {"continuum": float(flights[0][1] / s.period),
                                     "dem": dem_flights[0][1] / s.period},
            "note": "the floor starts at t = 0 with the velocity a omega (a jump): the internal energy it leaves "
                    "in the bed, and the end of the first flight"}
        budget = _dem_energy_budget(folder, s, e_dem)
        if budget is not None:
            ens = col["enskog_cs_loss_W"]
            ens_mid = 0.5 * (ens + np.roll(ens, -1))
            budget.update({
                "dem_enskog_cs_loss_per_cycle_J": float(ens.mean() * s.period),
                "continuum_floor_work_per_cycle_J": _floor_work_per_cycle(res.t, res.floor_force, s),
                "dem_enskog_cs_loss_at_midpoints_W": ens_mid.tolist()})
            if takeoff is not None and landing is not None:
                # on the floor: from the landing to the next take-off, each by the margin inside
                on = _phase_window(np.asarray(budget["phase_mid"]), landing, takeoff + 1.0, IN_FLIGHT_MARGIN)
                ratio = np.asarray(budget["dem_dissipation_W"]) / ens_mid
                if on.any():
                    budget["dem_dissipation_over_enskog_cs_on_floor"] = {
                        "median": float(np.median(ratio[on])), "min": float(ratio[on].min()),
                        "max": float(ratio[on].max()), "phases": int(on.sum())}
                floor_loss = _dem_floor_contact_loss(folder, len(ratio))
                if floor_loss is not None:
                    spheres = (np.asarray(budget["dem_dissipation_W"]) - floor_loss) / ens_mid
                    budget.update({"dem_floor_contact_loss_W": floor_loss.tolist(),
                                   "dem_floor_contact_loss_per_cycle_J": float(floor_loss.mean() * s.period)})
                    if on.any():
                        budget["dem_spheres_dissipation_over_enskog_cs_on_floor"] = {
                            "median": float(np.median(spheres[on])), "min": float(spheres[on].min()),
                            "max": float(spheres[on].max()), "phases": int(on.sum()),
                            "note": "the budget's dissipation less the sphere-floor contacts' measured loss "
                                    "(floor_loss_by_phase.csv), over Enskog's loss on LIGGGHTS's state"}
            out["energy_budget"] = budget
    return out


FLOOR_LOSS_BINS = 40
"""Rows of a run's floor_loss_by_phase.csv: the phase intervals between the frames (T/40)."""


def _dem_floor_contact_loss(folder: Path, bins: int):
    """The sphere–floor contacts' measured loss rate per phase interval [W] (the reference's
    floor_loss_by_phase.csv, ``run_liggghts.py --floor-power``: the mean over each of ``bins``
    intervals between frames, those of the energy budget), or None where the run has none
    (ValueError, one line, where its rows are not those bins: :func:`check_reference` refuses it
    before any run)."""
    path = folder / "floor_loss_by_phase.csv"
    if not path.exists():
        return None
    loss = np.asarray(_read_csv(path)["measured_loss_W"], dtype=float)
    if len(loss) != bins or not np.all(np.isfinite(loss)):
        raise ValueError(f"{path}: expected {bins} finite rows of measured_loss_W (the energy budget's phase bins)")
    return loss


def _phase_window(phase, start, end, margin):
    """Which of the phases [cycles, 0 to 1] lie in [start + margin, end − margin) taken modulo one
    cycle (start < end < start + 1: a flight from its take-off to its landing, or the time on the
    floor from a landing to the next take-off)."""
    return ((np.asarray(phase) - start - margin) % 1.0) < (end - start) - 2.0 * margin


def _floor_work_per_cycle(t, force, s: BedSetup) -> float:
    """∫ F v_floor dt [J] per cycle over cycles 3 to the end (trapezoids on the series), F [N] the
    floor's force on the bed at the times t [s], v_floor = aω cos ωt."""
    p = force * s.amplitude * s.omega * np.cos(s.omega * t)
    m = t >= STARTUP_CYCLES * s.period - 1e-12
    return float(np.trapezoid(p[m], t[m]) / (t[m][-1] - t[m][0]) * s.period)


def _dem_energy_budget(folder: Path, s: BedSetup, e_int):
    """The reference bed's dissipation rate from its energy budget, D = F v_floor −
    d/dt(M v_z,cm²/2 + M g z_cm + E_int) (its floor_force.csv, trajectory.csv and internal_energy.csv;
    the contacts' elastic energy left out; frictionless runs only: no rotation, no floor
    friction), over each interval between frames, averaged per phase over cycles 3 to the end:
    {"phase_mid", "dem_dissipation_W", "dem_dissipation_per_cycle_J", "dem_floor_work_per_cycle_J"},
    or None without the files.  Per cycle the two are equal up to the bed's change of state over
    the measured cycles (a periodic bed's budget closes by construction); the checks of the terms
    are that D ≥ 0 at every phase and that D is −dE_int/dt in flight (tests)."""
    if not ((folder / "trajectory.csv").exists() and (folder / "floor_force.csv").exists()):
        return None
    tr, ff = _read_csv(folder / "trajectory.csv"), _read_csv(folder / "floor_force.csv")
    t = np.asarray(tr["t_s"], dtype=float)
    if len(t) != len(e_int["t_s"]) or not np.allclose(t, e_int["t_s"], atol=1e-6):
        return None
    m_bed = s.n_spheres * s.sphere_mass
    energy = (0.5 * m_bed * tr["vz_com_m_s"] ** 2 + m_bed * s.gravity * tr["com_lab_m"]
              + np.asarray(e_int["E_internal_J"], dtype=float))
    tf = np.asarray(ff["t_s"], dtype=float)
    power = ff["F_floor_N"] * s.amplitude * s.omega * np.cos(s.omega * tf)
    work = np.interp(t, tf, np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(tf))]))
    rate = (np.diff(work) - np.diff(energy)) / np.diff(t)
    mid = 0.5 * (t[1:] + t[:-1])
    spc = int(round(s.period / (t[1] - t[0])))
    k = np.floor((mid / s.period) % 1.0 * spc).astype(int) % spc
    keep = mid >= STARTUP_CYCLES * s.period
    per_phase = np.array([rate[keep & (k == j)].mean() for j in range(spc)])
    return {"phase_mid": ((np.arange(spc) + 0.5) / spc).tolist(), "dem_dissipation_W": per_phase.tolist(),
            "dem_dissipation_per_cycle_J": float(per_phase.mean() * s.period),
            "dem_floor_work_per_cycle_J": _floor_work_per_cycle(tf, np.asarray(ff["F_floor_N"], dtype=float), s),
            "note": "LIGGGHTS's dissipation from its energy budget (floor work minus the change of its mechanical "
                    "energy, contacts' elastic energy left out) per phase interval, beside Enskog's loss (Carnahan-"
                    "Starling g0) on its coarse-grained state at the same midpoints; per cycle, over cycles 3-10"}


def _dem_phases(ref: Path, s: BedSetup, tag: str) -> dict:
    """The reference run's mean take-off and landing phases (its flights.csv, as :func:`flight_phases`)."""
    flights = _dem_flight_list(_run_dir(ref, s.gamma, tag))
    if flights is None:
        return {}
    takeoff, landing = flight_phases(flights, s.period, s.cycles)
    return {"dem_takeoff_phase": takeoff, "dem_landing_phase": landing}


def _continuum_flights(s: BedSetup, progress=None):
    """(the run, its flights, the flight per cycle [s], the last six finished flights [s]) of the
    continuum bed ``s`` (:func:`bsrflow.numerics.bed_lagrangian.run_bed`)."""
    from ..numerics.bed_lagrangian import run_bed
    res = run_bed(s, progress=progress)
    return (res,) + _last_six(res.t, res.floor_force, s)


def _long_friction_run(setup: BedSetup) -> dict:
    """The continuum's flights over ``setup.cycles`` cycles and whether its last six are doubled."""
    s = setup
    res, _, tau, last6 = _continuum_flights(s)
    m = period_doubling_measure(last6)
    return {"gamma": s.gamma, "friction": s.friction, "cycles": s.cycles, "flight_time_s": float(np.mean(last6)),
            "flight_time_per_cycle_s": tau.tolist(), "even_odd_split": m["even_odd_split"],
            "period_doubled": m["period_doubled"], "wall_time_s": res.wall_time}


def _long_run_line(run: dict) -> str:
    """The log line of a :func:`_long_friction_run`."""
    last6 = last_complete_flights(run["flight_time_per_cycle_s"])
    return (f"  Γ = {run['gamma']:g}, μ = {run['friction']:g}, {run['cycles']} cycles: last six flights "
            f"{' '.join(f'{1e3 * x:.1f}' for x in last6)} ms, period "
            f"{'doubled' if run['period_doubled'] else 'single'}, {run['wall_time_s']:.1f} s")


def _bed_task(kind, setup, ref, tag, progress=None):
    """One run of :func:`compare_bed`: ("ok", case, run, traj) for a comparison with the reference
    run ``tag`` (``run``: :func:`_continuum_flights`' tuple, so that the parent can compare it with
    another reference without recomputing), ("ok", run) for a long friction run; a stop raises
    SimulationError."""
    if kind == "long":
        return ("ok", _long_friction_run(setup))
    return ("ok",) + _compare_one(setup, ref, tag, progress)


def _bed_task_in_worker(kind, setup, ref, tag):
    """:func:`_bed_task` in a worker process: a stop comes back as ("stopped", message, time,
    position, status) (a SimulationError does not survive pickling)."""
    try:
        return _bed_task(kind, setup, ref, tag)
    except SimulationError as exc:
        return ("stopped", str(exc), exc.time, exc.position, exc.status)


def reference_bed(ref: Path, n_cells=200):
    """(the Γ of the LIGGGHTS runs, params.json as a dict, the continuum's bed of those runs) from
    the reference folder's flight_vs_gamma.csv and params.json.  ValueError (one line) when they are not that folder's."""
    try:
        gammas = [float(g) for g in np.atleast_1d(_read_csv(ref / "flight_vs_gamma.csv")["gamma"])]
        params = json.loads((ref / "params.json").read_text())
        base = BedSetup(n_spheres=2000, diameter=params["d_m"], density=params["rho_s_kg_m3"],
                        stiffness=params["K_N_m"], restitution=params["e"], side=params["settled_N2000_L13d"]["lx_m"],
                        gravity=params["g_m_s2"], frequency=params["f_Hz"],
                        cycles=params["cycles_startup"] + params["cycles_measured"], n_cells=n_cells)
    except (ValueError, KeyError, TypeError, OSError) as exc:
        raise ValueError(f"--reference {ref}: not the LIGGGHTS data folder's files "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())})") from None
    _check_gammas(ref, "flight_vs_gamma.csv", gammas, base)
    return gammas, params, base


def _data_lines(lines) -> list:
    """[(line number, text)] of the rows of a CSV of the LIGGGHTS data folder, as :func:`_read_csv`
    reads it (``lines``: the file's lines): after the first line and the header, blank lines and
    comments left out."""
    rows = [(k + 1, t) for k, t in enumerate(lines) if k >= 1 and t.strip() and not t.lstrip().startswith("#")]
    return rows[1:]


def _raw_cells(lines, column: str) -> list:
    """[(line number, text)] of ``column`` in each row of a CSV's ``lines`` (for the messages: the
    value as written, which the parser read as NaN); [] when the rows do not split as the header."""
    rows = [t for k, t in enumerate(lines) if k >= 1 and t.strip() and not t.lstrip().startswith("#")]
    head = [h.strip() for h in rows[0].split(",")] if rows else []
    if column not in head:
        return []
    i = head.index(column)
    cells = [(n, t.split(",")) for n, t in _data_lines(lines)]
    return [(n, c[i].strip()) for n, c in cells] if all(len(c) > i for _, c in cells) else []


def _check_gammas(ref: Path, name: str, gammas, base: BedSetup, shown=None) -> None:
    """Refuse (ValueError naming --reference and the file) a Γ of the reference's ``name`` (a
    flight_vs_gamma CSV, read as ``gammas``) that is not a number the bed takes: the file is at
    fault, not --gammas (it listed 'abc' as NaN, which --gammas then did not match)."""
    for k, g in enumerate(gammas):
        try:
            base.with_(gamma=g)
            continue
        except ValueError as exc:
            msg = str(exc).splitlines()[0]
        try:
            raw = dict(enumerate(_raw_cells((Path(ref) / name).read_text().splitlines(), "gamma")))[k]
            where, text = f"{name} line {raw[0]}", raw[1]
        except (OSError, UnicodeDecodeError, KeyError):
            where, text = f"{name} row {k + 1}", f"{g!r}"
        if not math.isfinite(g):
            rng = msg[msg.index("valid range"):] if "valid range" in msg else "a finite number"
            msg = f"gamma = {text!r} is not a number in the {rng}"
        raise ValueError(f"--reference {ref if shown is None else shown}: {where}: {msg} (the Γ of a LIGGGHTS run)")


SPRING_DASHPOT = "N2000_L13d_hooke"
"""The reference runs' tag of the frictionless spring–dashpot bed (the same K and e)."""
SPRING_DASHPOT_RUNS = "LIGGGHTS spring-dashpot, frictionless"
LARGE_BOX = "N10000_L29d"
"""The tag of the reference's lateral-size run: N = 10 000 spheres in a 29 d × 29 d box, the same
depth per area, law and Γ = 3."""
LARGE_BOX_RUNS = "LIGGGHTS Walton-Braun, N = 10 000 in a 29 d box"
ELASTIC_FLOOR = "N2000_L13d_ew1"
"""The tag of the main bed with elastic sphere–floor contacts (Walton–Braun, e = 0.9 between the
spheres, unloading stiffness K at the floor: e_w = 1; ``--floor-restitution 1``)."""
ELASTIC_FLOOR_RUNS = "LIGGGHTS Walton-Braun, elastic sphere-floor contacts; the continuum with floor_restitution 1"
LONG_REFERENCE = MAIN_RUNS + f"_c{LONG_CYCLES}"
"""The tag of the main bed's longer LIGGGHTS runs (3 + 27 cycles, ``run_liggghts.py --measured
27``): the same bed, packing and law, followed to cycle 30."""
LONG_REFERENCE_RUNS = f"LIGGGHTS Walton-Braun, {LONG_CYCLES} cycles; the continuum over {LONG_CYCLES} cycles too"
OTHER_BOXES = ((2157, 13.5),)
"""(N, side [d]) of the reference's 30-cycle runs in other boxes at the main bed's spheres per area
(``run_liggghts.py --n 2157 --lateral 13.5``: a side that is not a whole number of diameters);
the continuum runs with the same N and side."""
LONG_VARIANTS = (("N2000_L13d_hooke", "LIGGGHTS spring-dashpot, frictionless", {}),
                 ("N2000_L13d_ew1", "LIGGGHTS Walton-Braun, elastic sphere-floor contacts; the continuum with "
                                    "floor_restitution 1", {"floor_restitution": 1.0}))
"""(tag, label, the continuum's setup changes) of the other beds' 30-cycle runs, where run."""
STIFFER_BED = (MAIN_RUNS + "_K200000", 2.0e5)
"""(tag, K [N/m]) of the reference's bed with four times the contacts' stiffness (``run_liggghts.py
--settle --stiffness 2e5``, then ``--gamma 3 --floor-power --stiffness 2e5``): the same random
insertion settled with that K and vibrated at Γ = 3; the continuum runs with that K and the φ_c and Z
of that settled bed (``settled_N2000_L13d_K200000.json``), nothing else changed."""
STIFFER_BED_RUNS = "LIGGGHTS Walton-Braun, 4 K (the bed settled with it); the continuum with 4 K and its phi_c, Z"
OTHER_PACKING = MAIN_RUNS + "_seed"
"""The tags' start of the main bed poured with other seeds (``run_liggghts.py --seed S``: another
random packing of the same spheres, settled alike), ``N2000_L13d_seed<S>``."""


def _long_reference_tags(ref: Path, gamma: float) -> list:
    """[(tag, seed)] of the reference's 30-cycle runs at Γ = ``gamma``: the main packing's first
    (seed None), then those of other packings by seed."""
    out = [(LONG_REFERENCE, None)] if (_run_dir(ref, gamma, LONG_REFERENCE) / "summary.json").exists() else []
    for tag in _other_packing_tags(ref, gamma, suffix=f"_c{LONG_CYCLES}"):
        out.append((tag, int(tag[len(OTHER_PACKING):-len(f"_c{LONG_CYCLES}")])))
    return out


def _long_runs(ref: Path, gamma: float, base: BedSetup) -> list:
    """[(tag, label, the continuum's setup, in the main law's spread)] of the reference's finished
    30-cycle runs at Γ = ``gamma``: the main packing, the other packings (by seed), the other boxes
    (the continuum at the box's N and side), then the other laws' and floors' beds
    (:data:`LONG_VARIANTS`, against the continuum they are compared with at 11 cycles; not in
    ``packing_spread.late``, which is the main law's)."""
    long = base.with_(gamma=gamma, cycles=LONG_CYCLES)
    out = [(tag, LONG_REFERENCE_RUNS + ("" if seed is None else f" (packing of seed {seed})"), long, True)
           for tag, seed in _long_reference_tags(ref, gamma)]
    for n, side in OTHER_BOXES:
        tag = f"N{n}_L{side:g}d_c{LONG_CYCLES}"
        if (_run_dir(ref, gamma, tag) / "summary.json").exists():
            out.append((tag, LONG_REFERENCE_RUNS + f" (a {side:g} d box, N = {n})",
                        long.with_(n_spheres=n, side=side * base.diameter), True))
    for tag, label, kw in LONG_VARIANTS:
        if (_run_dir(ref, gamma, f"{tag}_c{LONG_CYCLES}") / "summary.json").exists():
            out.append((f"{tag}_c{LONG_CYCLES}", f"{label}, {LONG_CYCLES} cycles; the continuum over {LONG_CYCLES} "
                        "cycles too", long.with_(**kw), False))
    return out


def _stiffer_bed(ref: Path, base: BedSetup, gammas, shown=None) -> list:
    """The continuum's setups for :data:`STIFFER_BED` at those of ``gammas`` where the reference ran
    it: its K, and φ_c and the sphere–sphere Z of the bed settled with that K (ValueError, one line
    naming ``--reference`` and the file, where these are not a bed's)."""
    tag, k = STIFFER_BED
    done = [g for g in gammas if (_run_dir(ref, g, tag) / "summary.json").exists()]
    if not done:
        return []
    settled = ref / f"settled_{tag}.json"
    where = f"--reference {ref if shown is None else shown}: settled_{tag}.json"
    try:
        packing = json.loads(settled.read_text())
        phi_c, z = float(packing["phi_interior_cg"]), float(packing["Z_mean_pairs"])
        setups = [base.with_(gamma=g, stiffness=k, phi_c=phi_c, coordination=z) for g in done]
    except (OSError, UnicodeDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{where}: not the settled bed's statistics ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())})") from None
    except ValueError as exc:           # not JSON, or phi_c / Z outside the bed's valid ranges
        raise ValueError(f"{where}: not the settled bed's statistics ({' '.join(str(exc).split())})") from None
    return setups


def _other_packing_tags(ref: Path, gamma: float, suffix: str = "") -> list:
    """The tags of the reference's other-packing runs at Γ = ``gamma`` (the main bed's law and
    floor, by seed; not the variants of such a packing, whose tags go on after the seed; only
    finished runs: summary.json is written last)."""
    pre = f"gamma_{gamma:.2f}_"

    def seed(name):
        rest = name[len(pre) + len(OTHER_PACKING):]
        return rest[:len(rest) - len(suffix)] if suffix and rest.endswith(suffix) else (rest if not suffix else "")

    found = [p.name[len(pre):] for p in (Path(ref) / "results").glob(f"{pre}{OTHER_PACKING}*")
             if seed(p.name).isdigit() and (p / "trajectory.csv").exists() and (p / "summary.json").exists()]
    return sorted(found, key=lambda t: int(seed(pre + t)))

MODEL = ("packing stress + granular temperature (bsrflow.physics.granular_bed), horizontally uniform bed "
         "(1-D limit of the 3-D bed)")


def compare_bed(gammas=None, n_cells=200, reference=REFERENCE, figures=None, progress=None, include_extra=True,
                log=None, workers=1, eulerian=None, floor_loss="kinetic_pressure"):
    """Run the comparison (module docstring); returns the JSON-ready dict.  ``log(line)`` is called
    after every run.  ``workers`` > 1: the runs on that many processes (the same numbers, every
    run being serial and deterministic; the wall times then those of a shared machine;
    ``progress`` is not called from them).  An interrupt (KeyboardInterrupt, also SIGTERM) or a
    stop (SimulationError) carries the finished runs as ``exc.partial`` (the JSON's form without
    the summaries).  ``eulerian``: None, or the keywords (dim, cells_per_d, lateral_cells,
    perturbation) of :func:`bsrflow.numerics.bed_eulerian.run_eulerian_bed`: the same model on the
    Eulerian grid at every main Γ too (``eulerian_cases``, :func:`eulerian_case`; serial, after the
    other runs).  ``floor_loss``: the closure of the floor's loss in every continuum run
    (:attr:`bsrflow.physics.granular_bed.BedSetup.floor_loss`; the Eulerian grid takes only the
    default)."""
    ref = Path(reference)
    known, params, base = reference_bed(ref, n_cells)
    base = base.with_(floor_loss=floor_loss)
    if eulerian is not None and floor_loss != "kinetic_pressure":
        raise ValueError(f"floor_loss = {floor_loss!r} is an option of the Lagrangian cells; the Eulerian grid "
                         "takes only 'kinetic_pressure'")
    gammas = [float(g) for g in (known if gammas is None else gammas)]
    cases, runs, extra, long_runs, spring_dashpot, large_box, elastic_floor = [], {}, [], [], [], [], []
    other_packing, long_reference, stiffer = [], [], []
    long_reference_runs = {}            # Γ -> _long_runs(...)
    # (kind, setup, reference tag, list it joins, what the reference run is)
    tasks = [("case", base.with_(gamma=g), MAIN_RUNS, cases, None) for g in gammas]
    if include_extra:
        e05 = _read_csv(ref / "flight_vs_gamma_e0.5.csv")
        tasks += [("case", base.with_(gamma=g, restitution=0.5), E05_RUNS, extra,
                   "LIGGGHTS Walton-Braun e = 0.5, frictionless")
                  for g in [float(x) for x in np.atleast_1d(e05["gamma"])]]      # (one row: a 0-d array)
        tasks += [("case", base.with_(gamma=3.0), FRICTION_RUNS, extra,
                   "LIGGGHTS spring-dashpot, friction 0.5; the continuum smooth")]
        fric = _read_csv(ref / "flight_vs_gamma_hooke_mu0.5.csv")
        tasks += [("case", base.with_(gamma=g, friction=FRICTION), FRICTION_RUNS, extra,
                   f"LIGGGHTS spring-dashpot, friction {FRICTION:g}; the continuum with friction {FRICTION:g}")
                  for g in [float(x) for x in np.atleast_1d(fric["gamma"])]]
        tasks += [("long", base.with_(gamma=g, friction=FRICTION, cycles=LONG_CYCLES), None, long_runs, None)
                  for g in LONG_FRICTION_GAMMAS]
        tasks += [("case", base.with_(gamma=float(g), floor_restitution=1.0), ELASTIC_FLOOR, elastic_floor,
                   ELASTIC_FLOOR_RUNS) for g in params.get("gamma_list_elastic_floor") or [] if float(g) in gammas]
        tasks += [("case", setup, STIFFER_BED[0], stiffer, STIFFER_BED_RUNS) for setup in _stiffer_bed(ref, base, gammas)]
        long_reference_runs.update({g: _long_runs(ref, g, base) for g in gammas})
        tasks += [("case", setup, tag, long_reference, label)
                  for g in gammas for tag, label, setup, _ in long_reference_runs[g]]

    def finish(task, got):
        kind, setup, _, into, dem = task
        if got[0] == "stopped":
            raise SimulationError(got[1], None, *got[2:])
        if kind == "long":
            into.append(got[1])
            if log:
                log(_long_run_line(got[1]))
            return
        _, case, run, traj = got
        if dem is not None:
            case["dem"] = dem
        if into is long_reference:
            case["dem_tag"] = task[2]
            case["n_spheres"], case["side_over_d"] = setup.n_spheres, setup.side / setup.diameter
        into.append(case)
        _log_case(case, dem)
        if into is cases:
            runs[case["gamma"]] = (run[0], traj)
            # the same continuum run against the frictionless spring-dashpot bed (same K and e) and
            # the reference's lateral-size run (the same bed per area), where they were run
            for tag, label, joins in ((SPRING_DASHPOT, SPRING_DASHPOT_RUNS, spring_dashpot),
                                      (LARGE_BOX, LARGE_BOX_RUNS, large_box)):
                if include_extra and (_run_dir(ref, setup.gamma, tag) / "trajectory.csv").exists():
                    other, _ = _case_against(run, setup, ref, tag)
                    other["dem"] = label
                    joins.append(other)
                    _log_case(other, label)
            # and the same bed poured with other seeds, where it was
            for tag in (_other_packing_tags(ref, setup.gamma) if include_extra else []):
                other, _ = _case_against(run, setup, ref, tag)
                other["dem"] = f"LIGGGHTS Walton-Braun, another packing (seed {tag[len(OTHER_PACKING):]})"
                other["dem_tag"] = tag
                other_packing.append(other)
                _log_case(other, other["dem"])

    def _log_case(case, dem):
        if log:
            mu = f", μ = {case['friction']:g}" if case["friction"] else ""
            log(f"  Γ = {case['gamma']:g}, e = {case['restitution']:g}{mu}{' (' + dem + ')' if dem else ''}: flight "
                f"{1e3 * case['flight_time_s']:.1f} ms (LIGGGHTS {1e3 * case.get('dem_flight_time_s', math.nan):.1f} ms), "
                f"mass-centre RMS {case.get('mass_centre_rms_over_d', math.nan):.2f} d, {case['wall_time_s']:.1f} s")

    try:
        if workers > 1:
            from .worker_pool import worker_pool
            with worker_pool(workers) as pool:
                futures = [pool.apply_async(_bed_task_in_worker, (kind, setup, ref, tag))
                           for kind, setup, tag, _, _ in tasks]
                for task, fut in zip(tasks, futures):
                    finish(task, fut.get())
        else:
            for task in tasks:
                finish(task, _bed_task(task[0], task[1], ref, task[2], progress))
    except (KeyboardInterrupt, SimulationError) as exc:
        exc.partial = {"model": MODEL, "fitted_constants": {}, "closures": {"floor_loss": floor_loss}, "n_cells": n_cells, "cases": cases,
                       "extra_cases": extra, "spring_dashpot_cases": spring_dashpot, "large_box_cases": large_box,
                       "elastic_floor_cases": elastic_floor, "other_packing_cases": other_packing,
                       "long_reference_cases": long_reference, "stiffer_bed_cases": stiffer,
                       f"friction_{LONG_CYCLES}_cycles_runs": long_runs}
        raise
    g3 = next((c for c in cases if c["gamma"] == 3.0), None)
    out = {
        "model": MODEL,
        "fitted_constants": {},
        "inputs": {"phi_c": base.phi_c, "coordination": base.coordination,
                   "note": "phi_c and the sphere-sphere Z of the settled LIGGGHTS bed (reference README), measured, "
                           "not fitted"},
        "closures": {
            "kinetic_theory": "Lun, Savage, Jeffrey and Chepurniy (1984) in Gidaspow's (1994) form, Carnahan-Starling "
                              "g0 (bsrflow.physics.granular_bed)",
            "packing_stress": "Walton-Braun law per layer, stiffness 3 Z phi_c K A / (5 pi d^2) (affine uniaxial "
                              "compression of an isotropic packing)",
            "friction": f"only in the runs with friction {FRICTION:g}: the collisional losses' effective restitution "
                        "e - 1.5 mu exp(-3 mu) (Chialvo and Sundaresan 2013)",
            "floor_loss": floor_loss + (": (1 - e_w) p sqrt(2 theta / pi), p the kinetic pressure at the floor"
                                        if floor_loss == "kinetic_pressure" else
                                        ": (1 - e_w) R sqrt(2 theta / pi), R the whole floor reaction")},
        "n_cells": n_cells,
        "cases": cases,
        "flight_threshold_note": ("cases[].flight_by_threshold (and the other cases' where the reference has "
                                  "flight_vs_threshold.csv): the flight of both models with the 1-ms floor force cut "
                                  "at each fraction of the bed weight, the rest of the measure unchanged; the "
                                  "criterion's flight is the 0.1 row. A diagnostic: low thresholds weigh the first "
                                  "spheres to land and the last to leave, high ones the bulk of the bed"),
        "extra_cases": extra,
        "spring_dashpot_cases": spring_dashpot,
        "spring_dashpot_note": ("the main cases' continuum runs (the same runs, smooth, e = 0.9) against LIGGGHTS's "
                                "frictionless spring-dashpot bed (hooke/stiffness with a viscous dashpot for e, the same "
                                "K and e as the main Walton-Braun runs; the issue's simpler alternative law) at every "
                                "Gamma it was run; the main comparison stays the Walton-Braun one"),
        "large_box_cases": large_box,
        "large_box_note": ("the main cases' continuum runs against LIGGGHTS's lateral-size run (N = 10 000 in a "
                           "29 d x 29 d box, the same spheres per area, law and settling; Gamma = 3): the horizontally "
                           "uniform continuum is the same for both boxes, so the difference between the two references "
                           "is the DEM's own box-size effect"),
        "elastic_floor_cases": elastic_floor,
        "stiffer_bed_cases": stiffer,
        "stiffer_bed_note": ("the reference's bed with four times the contacts' stiffness (settled and vibrated with "
                             "it, Gamma = 3) against the continuum with that stiffness and that settled bed's phi_c "
                             "and Z: whether the reduced stiffness of the main comparison matters to either model"),
        "other_packing_cases": other_packing,
        "long_reference_cases": long_reference,
        "long_reference_note": (f"the main bed followed to cycle {LONG_CYCLES} (LIGGGHTS run_liggghts.py --measured "
                                f"{LONG_CYCLES - STARTUP_CYCLES}, the same law; the main packing, other packings "
                                "(--seed) and other boxes at the same spheres per area, where run) against the "
                                f"continuum over {LONG_CYCLES} cycles (with the box's N and side): the flights are "
                                f"the last six finished ones (cycles {LONG_CYCLES - 6}-{LONG_CYCLES - 1}); the "
                                "mass-centre RMS keeps its window (3T-8T); dem_structure: LIGGGHTS's crystal-like "
                                "fraction, solid fraction and floor-layer order at the start of every cycle "
                                "(structure_per_cycle.csv)"),
        "packing_spread": _packing_spread(cases, other_packing, ref, base, long_reference,
                                          {(g, tag) for g, runs in long_reference_runs.items()
                                           for tag, _, _, spread in runs if spread}),
        "dem_lateral_structure": _lateral_structure(cases),
        "dem_lateral_structure_note": ("how far from horizontally uniform (the continuum's assumption) is LIGGGHTS's "
                                       "bed? Per main case, over the measured cycles (3-10): the mean amplitude [d] "
                                       "of the sphere heights' longest lateral waves in the 13 d box (a wave of the "
                                       "whole bed of peak-to-peak height h gives about h/2, a heap of the surface "
                                       "alone about h/4), beside the same with the heights "
                                       "shuffled among the spheres (a random layout's, noisier than a packed flat "
                                       "bed: not a noise floor, so the ratio is no test)"),
        "packing_spread_note": ("the main bed poured with other seeds of the random insertion (run_liggghts.py "
                                "--seed S: another packing of the same spheres, settled and vibrated alike) at the "
                                "Gamma it was run: LIGGGHTS's flight over the packings (sample standard deviation) "
                                "and the continuum's difference from their mean, beside the criterion's difference "
                                "from the main packing; the spread is the reference value's own uncertainty. late: "
                                "the same over the last six flights of every 30-cycle run at that Gamma (the "
                                "packings' and the other boxes' runs, named in runs), against the continuum's "
                                "30-cycle run of the main box"),
        "floor_contact_effect": _floor_contact_effect(cases, elastic_floor, ref, base),
        "floor_contact_note": ("the sphere-floor contacts' restitution alone changed, 0.9 -> 1 (elastic), in LIGGGHTS "
                               "(Walton-Braun, the main bed's settled packing) and in the continuum (floor_restitution: "
                               "its floor's collisional loss only): the flights of both, and the RMS difference of the "
                               "two LIGGGHTS beds' mass-centre heights over the same five cycles as "
                               "mass_centre_rms_over_d"),
        "period_doubling_gamma": {
            "continuum": _doubling_gamma([c["gamma"] for c in cases], [c["period_doubled"] for c in cases]),
            "dem": (params.get("period_doubling_gamma") or {}).get("estimate"),
            "note": "null: no period doubling in the Gamma range (the reference's frictionless e = 0.9 bed has none)"},
        "period_doubling_gamma_friction_mu0.5": {
            "continuum": _doubling_gamma([c["gamma"] for c in extra if c["friction"] == FRICTION],
                                         [c["period_doubled"] for c in extra if c["friction"] == FRICTION]),
            f"continuum_{LONG_CYCLES}_cycles": _doubling_gamma([r["gamma"] for r in long_runs],
                                                               [r["period_doubled"] for r in long_runs]),
            "dem": (params.get("period_doubling_gamma_friction_mu0.5") or {}).get("estimate"),
            f"continuum_{LONG_CYCLES}_cycles_runs": long_runs,
            "note": f"the frictional runs (spring-dashpot, mu = {FRICTION:g}) against the continuum with friction "
                    f"{FRICTION:g} (effective restitution, Chialvo and Sundaresan 2013); 'continuum' over the "
                    f"reference's 11 cycles, the {LONG_CYCLES}-cycle runs' last six flights for its settled state"},
        "period_doubling_gamma_spring_dashpot": {
            "continuum": _doubling_gamma([c["gamma"] for c in spring_dashpot],
                                         [c["period_doubled"] for c in spring_dashpot]),
            "dem": (params.get("period_doubling_gamma_spring_dashpot") or {}).get("estimate"),
            "note": "the main continuum runs against the frictionless spring-dashpot bed; its doubling is one "
                    "Gamma's (7.5: alternating, single at 7 and 8; reference README)"},
        "period_doubling_gamma_e0.5": {
            "continuum": _doubling_gamma([c["gamma"] for c in extra if c["restitution"] == 0.5],
                                         [c["period_doubled"] for c in extra if c["restitution"] == 0.5]),
            "dem": (params.get("period_doubling_gamma_exploratory_e0.5") or {}).get("estimate"),
            "note": "the exploratory e = 0.5 runs (same bed, same K)"},
        "cost_s": {"continuum": g3["wall_time_s"] if g3 else None,
                   "dem": g3.get("dem_wall_time_s") if g3 else None,
                   "workers": workers,
                   "note": "Gamma = 3, 11 cycles each; continuum measured in this run (with workers > 1 on a machine "
                           "shared with the other runs; bench/bench_bed.py measures the cost alone), LIGGGHTS from the "
                           "committed summary of its serial run on this machine type (2026-12-01)"},
    }
    if not include_extra:
        for key in ("period_doubling_gamma_friction_mu0.5", "spring_dashpot_cases", "spring_dashpot_note",
                    "period_doubling_gamma_spring_dashpot", "large_box_cases", "large_box_note",
                    "elastic_floor_cases", "stiffer_bed_cases", "stiffer_bed_note", "floor_contact_effect", "floor_contact_note", "other_packing_cases",
                    "long_reference_cases", "long_reference_note", "dem_lateral_structure", "dem_lateral_structure_note",
                    "packing_spread", "packing_spread_note"):
            del out[key]
    if eulerian is not None:
        out["eulerian_cases"] = []
        for case in cases:
            try:
                got = eulerian_case(base.with_(gamma=case["gamma"]), case, runs[case["gamma"]], progress=progress,
                                    **eulerian)
            except (KeyboardInterrupt, SimulationError) as exc:
                exc.partial = out                    # every run so far, with the finished Eulerian cases
                raise
            out["eulerian_cases"].append(got)
            if log:
                across = "" if got["dim"] == 1 else f", {got['lateral_cells']} across"
                log(f"  Γ = {got['gamma']:g}, Eulerian {got['dim']}-D ({got['cells_per_d']} cells per d{across}): flight "
                    f"{1e3 * got['flight_time_s']:.1f} ms (Lagrangian {1e3 * got['lagrangian_flight_time_s']:.1f}, "
                    f"LIGGGHTS {1e3 * got.get('dem_flight_time_s', math.nan):.1f} ms), mass-centre RMS "
                    f"{got.get('mass_centre_rms_over_d', math.nan):.2f} d, {got['wall_time_s']:.1f} s")
        out["eulerian_note"] = EULERIAN_NOTE
    if figures:
        token = FIGURE_NOTE.set(None if floor_loss == "kinetic_pressure" else f"continuum floor loss: {floor_loss}")
        try:
            _figures(out, runs, base, Path(figures), ref)
        finally:
            FIGURE_NOTE.reset(token)
    return out


FIGURE_NOTE = contextvars.ContextVar("FIGURE_NOTE", default=None)
"""A note :func:`_save_figure` writes in the lower right corner of every figure (compare-bed sets
it to a non-default floor-loss closure, so that those figures are not taken for the default's)."""


EULERIAN_NOTE = (
    "the same model (packing stress + granular temperature, nothing fitted) on the Eulerian grid of "
    "bsrflow.numerics.bed_eulerian (1-D column, or a 2-D / 3-D bed with periodic sides, perturbed laterally by "
    "'perturbation' at the start), against LIGGGHTS (as the main cases) and against the main cases' Lagrangian run: "
    "a second discretisation of one model; lateral_spread_max_over_d is the largest standard deviation of the "
    "columns' mass centres over the run (0 for a horizontally uniform bed), lateral_spread_max_per_cycle_over_d "
    "the same per cycle")


def eulerian_case(setup: BedSetup, case: dict, lagrangian, dim=1, cells_per_d=4, lateral_cells=1, perturbation=0.0,
                  progress=None) -> dict:
    """The bed ``setup`` on the Eulerian grid (:func:`bsrflow.numerics.bed_eulerian.run_eulerian_bed`)
    against LIGGGHTS (the main ``case``'s reference values: the same flight measure and mass-centre
    RMS window) and against the Lagrangian run ``lagrangian`` = (its BedResult, the reference's
    trajectory or None)."""
    from ..numerics.bed_eulerian import run_eulerian_bed
    s = setup
    res, traj = lagrangian
    r = run_eulerian_bed(s, dim, cells_per_d, lateral_cells, perturbation, save_every=s.save_every, progress=progress)
    flights, tau, last6 = _last_six(r["t"], r["floor_force"], s)
    flight = float(np.mean(last6))
    takeoff, landing = flight_phases(flights, s.period, s.cycles)
    window = _rms_window(r["t"], s.period)
    out = {"gamma": s.gamma, "dim": dim, "cells_per_d": cells_per_d, "lateral_cells": lateral_cells,
           "perturbation": perturbation, "grid_shape": list(r["shape"]), "cell_size_m": r["dx"],
           "flight_time_s": flight, "flight_time_per_cycle_s": tau.tolist(),
           "takeoff_phase": takeoff, "landing_phase": landing,
           "lagrangian_flight_time_s": case["flight_time_s"],
           "flight_rel_diff_to_lagrangian": flight / case["flight_time_s"] - 1.0,
           "mass_centre_rms_to_lagrangian_over_d": float(math.sqrt(np.mean(
               (r["mass_centre"][window] - np.interp(r["t"][window], res.t, res.mass_centre)) ** 2)) / s.diameter),
           "lateral_spread_max_over_d": float(r["lateral_spread"].max() / s.diameter),
           "lateral_spread_max_per_cycle_over_d": [
               float(r["lateral_spread"][(r["t"] >= c * s.period - 1e-12) & (r["t"] <= (c + 1) * s.period + 1e-12)].max()
                     / s.diameter) for c in range(s.cycles)],
           "mass_error": r["mass_error"], "steps": r["steps"], "wall_time_s": r["wall_time_s"],
           "floor_force_over_weight": {
               "phase": ((np.arange(FORCE_PHASE_BINS) + 0.5) / FORCE_PHASE_BINS).tolist(),
               "continuum": force_by_phase(r["t"], r["floor_force"], s.n_spheres * s.sphere_mass * s.gravity,
                                           s.period, s.cycles).tolist(),
               "note": "as cases[].floor_force_over_weight, the Eulerian grid's floor force"}}
    if "dem_flight_time_s" in case and traj is not None:
        out.update({"dem_flight_time_s": case["dem_flight_time_s"],
                    "flight_time_rel_diff": flight / case["dem_flight_time_s"] - 1.0,
                    "mass_centre_rms_over_d": _mass_centre_rms_over_d(traj, r["t"], r["mass_centre"], s)})
    return out


def _lateral_structure(cases) -> list:
    """Per main case with LIGGGHTS's structure table: the means over the measured cycles (3 to 10)
    of the lateral-wave amplitude and of its shuffled baseline [d], and their ratio."""
    out = []
    for c in cases:
        st = c.get("dem_structure")
        if st is None:
            continue
        keep = [k for k, cyc in enumerate(st["cycle"]) if STARTUP_CYCLES <= cyc < st["cycle"][-1]]
        if not keep:
            continue
        a = float(np.mean([st["lateral_mode_over_d"][k] for k in keep]))
        b = float(np.mean([st["lateral_mode_shuffled_over_d"][k] for k in keep]))
        out.append({"gamma": c["gamma"], "lateral_mode_over_d": a, "lateral_mode_shuffled_over_d": b, "ratio": a / b})
    return out


def _packing_spread(cases, other_packing, ref: Path, s: BedSetup, long_reference=(), spread_runs=frozenset()) -> list:
    """Per Γ with other-packing runs: LIGGGHTS's flights over every packing (the main one first),
    their mean and sample standard deviation, the continuum's difference from that mean, and the
    RMS difference [d] of each other packing's mass centre from the main one's over the window of
    ``mass_centre_rms_over_d``; where 30-cycle runs exist, the same over their last six flights
    (``late``: the runs of ``spread_runs``, {(Γ, tag)}: the packings' and the other boxes' 30-cycle
    runs, :func:`_long_runs`, against the continuum's 30-cycle run of the main box)."""
    main = {c["gamma"]: c for c in cases}
    out = []
    for g in sorted({c["gamma"] for c in other_packing}):
        c = main.get(g)
        if c is None or "dem_flight_time_s" not in c:
            continue
        others = [o for o in other_packing if o["gamma"] == g and "dem_flight_time_s" in o]
        flights = [c["dem_flight_time_s"]] + [o["dem_flight_time_s"] for o in others]
        a, _ = _reference_case(ref, g, MAIN_RUNS)
        rms = []
        for o in others:
            b, _ = _reference_case(ref, g, o["dem_tag"])
            rms.append(_mass_centre_rms_over_d(a, b["t_s"], b["com_rel_m"], s))
        mean = float(np.mean(flights))
        out.append({"gamma": g, "packings": ["main"] + [o["dem"] for o in others], "dem_flight_time_s": flights,
                    "dem_flight_mean_s": mean, "dem_flight_std_s": float(np.std(flights, ddof=1)),
                    "dem_flight_std_rel": float(np.std(flights, ddof=1)) / mean,
                    "continuum_flight_time_s": c["flight_time_s"],
                    "continuum_rel_diff_to_mean": c["flight_time_s"] / mean - 1.0,
                    "continuum_rel_diff_to_main": c["flight_time_rel_diff"],
                    "dem_mass_centre_rms_from_main_over_d": rms})
        late = [c for c in long_reference
                if c["gamma"] == g and (g, c["dem_tag"]) in spread_runs and "dem_flight_time_s" in c]
        if len(late) >= 2:
            fl = [c["dem_flight_time_s"] for c in late]
            out[-1]["late"] = {"runs": [c["dem_tag"] for c in late], "dem_flight_time_s": fl,
                               "dem_flight_mean_s": float(np.mean(fl)), "dem_flight_std_s": float(np.std(fl, ddof=1)),
                               "continuum_flight_time_s": late[0]["flight_time_s"],
                               "continuum_rel_diff_to_mean": late[0]["flight_time_s"] / float(np.mean(fl)) - 1.0,
                               "cycles": [LONG_CYCLES - 6, LONG_CYCLES - 1]}
    return out


def _floor_contact_effect(cases, elastic_floor, ref: Path, s: BedSetup) -> list:
    """Per Γ with both runs: the flights with the floor's restitution e and 1 (LIGGGHTS and the
    continuum), their relative changes, and the RMS difference [d] of the two LIGGGHTS beds'
    mass-centre heights over the window of ``mass_centre_rms_over_d`` (3T <= t < 8T); where the
    reference has them (Γ = 3), also LIGGGHTS's flights of the main bed at e_w = 0.95 and of the
    spring–dashpot bed with its floor at e and elastic."""
    main = {c["gamma"]: c for c in cases}
    out = []
    for el in elastic_floor:
        g = el["gamma"]
        c = main.get(g)
        if c is None or "dem_flight_time_s" not in c or "dem_flight_time_s" not in el:
            continue
        a, _ = _reference_case(ref, g, MAIN_RUNS)
        b, _ = _reference_case(ref, g, ELASTIC_FLOOR)
        rms = None
        if a is not None and b is not None and len(a) == len(b) and np.array_equal(a["t_s"], b["t_s"]):
            rms = _mass_centre_rms_over_d(a, b["t_s"], b["com_rel_m"], s)
        dem = {"floor_e": c["dem_flight_time_s"], "floor_elastic": el["dem_flight_time_s"]}
        # where they were run: the main bed at e_w = 0.95, and the spring-dashpot bed with both floors
        for key, tag in (("floor_e0.95", MAIN_RUNS + "_ew0.95"), ("spring_dashpot_floor_e", SPRING_DASHPOT),
                         ("spring_dashpot_floor_elastic", SPRING_DASHPOT + "_ew1")):
            _, summ = _reference_case(ref, g, tag)
            if summ is not None:
                dem[key] = float(np.mean(last_complete_flights(summ["flight_time_per_cycle_s"])))
        if "spring_dashpot_floor_elastic" not in dem:      # the spring-dashpot bed only as a pair
            dem.pop("spring_dashpot_floor_e", None)
        out.append({"gamma": g, "restitution": c["restitution"],
                    "dem_flight_time_s": dem,
                    "continuum_flight_time_s": {"floor_e": c["flight_time_s"], "floor_elastic": el["flight_time_s"]},
                    "dem_change_rel": el["dem_flight_time_s"] / c["dem_flight_time_s"] - 1.0,
                    "continuum_change_rel": el["flight_time_s"] / c["flight_time_s"] - 1.0,
                    "dem_mass_centre_rms_between_beds_over_d": rms})
    return out


def _dem_flights(path) -> dict:
    """{Γ: the reference's per-cycle flights [s] of its measured cycles} from a flight_vs_gamma CSV."""
    import csv
    if not Path(path).exists():
        return {}
    with open(path, newline="") as fh:
        rows = [r for r in csv.reader(line for line in fh if not line.startswith("#"))]
    head, out = rows[0], {}
    ig, it = head.index("gamma"), head.index("flight_times_s")
    for r in rows[1:]:
        out[float(r[ig])] = [float(x) for x in r[it].split()]
    return out


def _bifurcation_figure(out, ref, folder, plt):
    """The bifurcation diagram: the last six flights per Γ, frictionless and with friction."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)

    def branches(ax, runs, shift, marker, color, label):
        """The last six finished flights of each (Γ, per-cycle flights) in ``runs`` [ms]."""
        for k, (g, tau) in enumerate(runs):
            tau = [x for x in tau if x is not None and not math.isnan(x)][-6:]
            ax.plot([g + shift] * len(tau), 1e3 * np.asarray(tau), marker, ms=3, color=color,
                    label=label if k == 0 else None)

    ax = axes[0]
    branches(ax, [(c["gamma"], c["flight_time_per_cycle_s"]) for c in out["cases"]], -0.04, "o", "C0",
             "continuum (11 cycles)")
    branches(ax, sorted(_dem_flights(ref / "flight_vs_gamma.csv").items()), 0.04, "s", "C1", "LIGGGHTS Walton–Braun")
    branches(ax, sorted(_dem_flights(ref / "flight_vs_gamma_hooke.csv").items()), 0.12, "d", "C2",
             "LIGGGHTS spring-dashpot")
    ax.set_title("frictionless, e = 0.9")
    ax.set_xlabel("Γ = aω²/g")
    ax.set_ylabel("flight time of the last six cycles [ms]")
    ax.legend(fontsize=8)
    ax = axes[1]
    pf = out.get("period_doubling_gamma_friction_mu0.5") or {}
    branches(ax, [(r["gamma"], r["flight_time_per_cycle_s"]) for r in pf.get(f"continuum_{LONG_CYCLES}_cycles_runs", [])],
             -0.02, "o", "C0", f"continuum ({LONG_CYCLES} cycles)")
    branches(ax, sorted(_dem_flights(ref / "flight_vs_gamma_hooke_mu0.5.csv").items()), 0.02, "s", "C1",
             "LIGGGHTS (spring-dashpot)")
    ax.set_title(f"friction μ = {FRICTION:g} (continuum: effective restitution)")
    ax.set_xlabel("Γ = aω²/g")
    ax.legend(fontsize=8)
    _save_figure(fig, "Bifurcation diagram of the vibrated bed (f = 20 Hz): a doubled period shows as two branches",
                 folder / "bed_bifurcation.png", plt)


def _flight_threshold_figure(out, folder, plt):
    """bed_flight_vs_threshold.png: the continuum's flight against LIGGGHTS's at each threshold of
    the floor force, against Γ (the main cases and, where run, the elastic-floor ones); nothing
    written without the reference's threshold tables."""
    panels = [(key, title) for key, title in (("cases", "floor e = 0.9 (the main comparison)"),
                                              ("elastic_floor_cases", "floor contacts elastic, both models"))
              if any("flight_by_threshold" in c for c in out.get(key, []))]
    if not panels:
        return
    fig, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 4), sharey=True, squeeze=False)
    for ax, (key, title) in zip(axes[0], panels):
        cs = [c for c in out[key] if "flight_by_threshold" in c]
        for k, th in enumerate(cs[0]["flight_by_threshold"]["threshold_over_weight"]):
            ax.plot([c["gamma"] for c in cs], [100 * c["flight_by_threshold"]["rel_diff"][k] for c in cs],
                    "o-" if th == FLIGHT_THRESHOLD else ".--", lw=2 if th == FLIGHT_THRESHOLD else 1,
                    label=f"{th:g} M g" + (" (the criterion's)" if th == FLIGHT_THRESHOLD else ""))
        ax.axhspan(-5, 5, color="0.9", zorder=0)
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xlabel("Γ = aω²/g")
        ax.set_title(title, fontsize=10)
    axes[0][0].set_ylabel("flight: continuum / LIGGGHTS − 1 [%]")
    axes[0][0].legend(title="floor force below", fontsize=8)
    _save_figure(fig, "Flight per cycle with the floor force cut at several fractions of the bed weight (grey: ±5 %)",
                 folder / "bed_flight_vs_threshold.png", plt)


def _long_reference_figure(out, folder, plt, ref):
    """bed_long_runs.png: the flight per cycle over the long runs (both models) and LIGGGHTS's
    crystal-like fraction, one panel per Γ; nothing written without long runs."""
    cs = sorted(out.get("long_reference_cases") or [],
                key=lambda c: (c["gamma"], c["dem_tag"] != LONG_REFERENCE, "_seed" not in c["dem_tag"], c["dem_tag"]))
    if not cs:
        return
    ncol = min(len(cs), 5)
    nrow = -(-len(cs) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(max(7.0, 3.6 * ncol), 3.4 * nrow + 0.6), squeeze=False)
    for ax in axes.flat[len(cs):]:
        ax.set_visible(False)
    for k, (ax, c) in enumerate(zip(axes.flat, cs)):
        n = len(c["flight_time_per_cycle_s"])
        ax.plot(range(n), [1e3 * v if v is not None else np.nan for v in c["flight_time_per_cycle_s"]], "o-", ms=3,
                label="continuum")
        summ = json.loads((_run_dir(ref, c["gamma"], c["dem_tag"]) / "summary.json").read_text())
        dem = summ["flight_time_per_cycle_s"]
        ax.plot(range(STARTUP_CYCLES, STARTUP_CYCLES + len(dem)), [1e3 * v if v is not None else np.nan for v in dem],
                "s--", ms=3, color="C1", label="LIGGGHTS Walton–Braun")
        ax.set_ylim(0.0, 45.0)
        if k // ncol == nrow - 1 or k + ncol >= len(cs):
            ax.set_xlabel("cycle (the floor's period T = 1/f)")
        if k % ncol == 0:
            ax.set_ylabel("flight per cycle [ms] (0.1 M g)")
        tag = c["dem_tag"]
        variant = ("" if tag == LONG_REFERENCE else f", packing of seed {tag.split('_seed')[1].split('_')[0]}"
                   if "_seed" in tag else ", spring-dashpot" if "_hooke" in tag else ", floor elastic"
                   if "_ew1" in tag else f", {tag.split('_')[1][1:]} box")
        ax.set_title(f"Γ = {c['gamma']:g}{variant}", fontsize=10)
        if "dem_structure" in c:
            ax2 = ax.twinx()
            st = c["dem_structure"]
            ax2.plot(st["cycle"], st["crystal_fraction"], ":", color="C2", label="LIGGGHTS crystal-like fraction")
            ax2.set_ylim(0.0, 1.0)
            if k % ncol == ncol - 1 or k == len(cs) - 1:
                ax2.set_ylabel("crystal-like fraction (q6)", color="C2")
            if k == 0:
                ax2.legend(loc="lower right", fontsize=8)
    axes[0][0].legend(loc="upper right", fontsize=8)
    _save_figure(fig, f"The bed over {LONG_CYCLES} cycles: flights and LIGGGHTS's crystallisation",
                 folder / "bed_long_runs.png", plt)


def _floor_force_figure(out, folder, plt, gamma=3.0):
    """bed_floor_force_gamma3.png: the flight measure's signal against the phase at Γ = 3, both
    beds, with the floor's contacts at e and (where run) elastic; nothing written without it."""
    rows = []
    for key, style, label in (("cases", "-", "floor e = 0.9"), ("elastic_floor_cases", ":", "floor elastic")):
        c = next((c for c in out.get(key, []) if c["gamma"] == gamma and "floor_force_over_weight" in c), None)
        if c is not None:
            rows.append((style, label, c["floor_force_over_weight"]))
    if not rows:
        return
    eulerian = [c for c in out.get("eulerian_cases", []) if c["gamma"] == gamma and "floor_force_over_weight" in c]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    for ax, top in zip(axes, (None, 0.6)):
        for style, label, f in rows:
            ax.plot(f["phase"], f["continuum"], style, color="C0", label=f"continuum (Lagrangian cells), {label}")
            ax.plot(f["phase"], f["dem"], style, color="C1", label=f"LIGGGHTS Walton–Braun, {label}")
        for c in eulerian:
            f = c["floor_force_over_weight"]
            ax.plot(f["phase"], f["continuum"], "--", color="C2",
                    label=f"continuum, Eulerian {c['dim']}-D, {c['cells_per_d']} cells per d, floor e = 0.9")
        ax.axhline(0.1, color="0.5", lw=0.8, label="flight threshold (0.1 M g)")
        ax.set_xlabel("floor phase [cycles] (floor at A sin 2π·phase)")
        if top is not None:
            ax.set_ylim(0.0, top)
            ax.set_title("near the threshold")
    axes[0].set_ylabel("floor force / M g (1-ms moving average)")
    axes[0].legend(fontsize=8)
    _save_figure(fig, f"Γ = {gamma:g}, frictionless, e = 0.9: the floor force over the last six cycles",
                 folder / "bed_floor_force_gamma3.png", plt)


def _temperature_vs_gamma_figure(out, folder, plt):
    """bed_temperature_vs_gamma.png: the bed's cycle-mean θ against Γ (the continuum, both
    frictionless LIGGGHTS beds where their velocities were dumped) and the continuum's over
    LIGGGHTS's, beside the flight's relative difference; nothing written without a reference θ."""
    series = []
    for label, marker, color, key in (("LIGGGHTS Walton–Braun", "s", "C1", "cases"),
                                      ("LIGGGHTS spring-dashpot", "d", "C2", "spring_dashpot_cases")):
        rows = [(c["gamma"], c["temperature"], c) for c in out.get(key, []) if "temperature" in c]
        if rows:
            series.append((label, marker, color, rows))
    if not series:
        return
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    cont = {}
    for label, marker, color, rows in series:
        g = [r[0] for r in rows]
        axes[0].plot(g, [1e3 * np.mean(r[1]["dem_theta_m2_s2"]) for r in rows], marker + "--", color=color,
                     label=label)
        axes[1].plot(g, [r[1]["cycle_mean_ratio"] for r in rows], marker + "-", color=color,
                     label=f"θ: continuum / {label}")
        axes[1].plot(g, [1.0 + r[2]["flight_time_rel_diff"] for r in rows], marker + ":", color=color,
                     mfc="none", label=f"flight: continuum / {label}")
        cont.update({r[0]: np.mean(r[1]["continuum_theta_m2_s2"]) for r in rows})
    gs = sorted(cont)
    axes[0].plot(gs, [1e3 * cont[g] for g in gs], "o-", color="C0", label="continuum")
    axes[0].set_yscale("log")
    axes[0].set_xlabel("Γ = aω²/g")
    axes[0].set_ylabel("bed's mass-mean θ, cycle mean [10⁻³ m²/s²]")
    axes[0].legend(fontsize=8)
    axes[1].axhline(1.0, color="0.6", lw=0.8)
    axes[1].set_xlabel("Γ = aω²/g")
    axes[1].set_ylabel("continuum / LIGGGHTS")
    axes[1].legend(fontsize=7)
    _save_figure(fig, "Frictionless bed, e = 0.9: granular temperature against Γ (cycles 3–10)",
                 folder / "bed_temperature_vs_gamma.png", plt)


def _figures(out, runs, base, folder, ref=REFERENCE):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = base.diameter
    cases = out["cases"]
    fig, ax = plt.subplots(figsize=(10, 4.5))
    g = [c["gamma"] for c in cases]
    ax.plot(g, [1e3 * c["flight_time_s"] for c in cases], "o-", label="continuum, e = 0.9")
    ax.plot(g, [1e3 * c.get("dem_flight_time_s", np.nan) for c in cases], "s--", label="LIGGGHTS Walton–Braun, e = 0.9")
    sd = out.get("spring_dashpot_cases") or []
    if sd:
        ax.plot([c["gamma"] for c in sd], [1e3 * c.get("dem_flight_time_s", np.nan) for c in sd], "d:", color="C2",
                label="LIGGGHTS spring-dashpot, e = 0.9")
    big = out.get("large_box_cases") or []
    if big:
        ax.plot([c["gamma"] for c in big], [1e3 * c.get("dem_flight_time_s", np.nan) for c in big], "*", color="C1",
                ms=10, label="LIGGGHTS Walton–Braun, N = 10 000 (29 d box)")
    ef = out.get("elastic_floor_cases") or []
    if ef:
        ax.plot([c["gamma"] for c in ef], [1e3 * c["flight_time_s"] for c in ef], "o:", color="C0", mfc="none",
                label="continuum, elastic floor (e_w = 1)")
        ax.plot([c["gamma"] for c in ef], [1e3 * c.get("dem_flight_time_s", np.nan) for c in ef], "s:", color="C1",
                mfc="none", label="LIGGGHTS Walton–Braun, elastic floor contacts")
    e05 = [c for c in out["extra_cases"] if c["restitution"] == 0.5]
    if e05:
        ax.plot([c["gamma"] for c in e05], [1e3 * c["flight_time_s"] for c in e05], "^-", label="continuum, e = 0.5")
        ax.plot([c["gamma"] for c in e05], [1e3 * c.get("dem_flight_time_s", np.nan) for c in e05], "v--",
                label="LIGGGHTS Walton–Braun, e = 0.5")
    fr = [c for c in out["extra_cases"] if c.get("friction")]
    if fr:
        ax.plot([c["gamma"] for c in fr], [1e3 * c["flight_time_s"] for c in fr], "<-",
                label=f"continuum, μ = {FRICTION:g} (effective e)")
        ax.plot([c["gamma"] for c in fr], [1e3 * c.get("dem_flight_time_s", np.nan) for c in fr], ">--",
                label=f"LIGGGHTS spring-dashpot, μ = {FRICTION:g}")
    for c in cases:
        tau = np.asarray(c["flight_time_per_cycle_s"][-6:]) * 1e3
        ax.plot([c["gamma"]] * len(tau), tau, ".", color="C0", alpha=0.4)
    ax.set_xlabel("Γ = aω²/g")
    ax.set_ylabel("flight time per cycle [ms] (last six cycles)")
    ax.set_title("Vibrated bed, f = 20 Hz: flight time against Γ")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    _save_figure(fig, None, folder / "bed_flight_vs_gamma.png", plt)
    _bifurcation_figure(out, Path(ref), folder, plt)
    _temperature_vs_gamma_figure(out, folder, plt)
    _floor_force_figure(out, folder, plt)
    _flight_threshold_figure(out, folder, plt)
    _long_reference_figure(out, folder, plt, Path(ref))
    if 3.0 in runs:
        res, traj = runs[3.0]
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(res.t, res.mass_centre / d, label="continuum mass centre")
        ax.plot(res.t, res.top / d, label="continuum top (99 % of the mass)")
        if traj is not None:
            ax.plot(traj["t_s"], traj["com_rel_m"] / d, "--", label="LIGGGHTS mass centre")
            ax.plot(traj["t_s"], traj["top99_rel_m"] / d, "--", label="LIGGGHTS top (99 % of the centres)")
        ax.set_xlabel("t [s] (floor vibrating from t = 0)")
        ax.set_ylabel("height above the floor [d]")
        ax.set_title("Γ = 3, e = 0.9, frictionless")
        ax.legend(fontsize=8)
        _save_figure(fig, None, folder / "bed_trajectory_gamma3.png", plt)
        dem_dir = _run_dir(ref, 3.0)
        prof = dem_dir / "profiles.csv"
        fig, axes = plt.subplots(1, 4, figsize=(11, 4), sharey=True)
        ref_phi = _read_csv(prof) if prof.exists() else None
        for axk, (key, (z, phi)) in zip(axes, res.profiles.items()):
            axk.plot(phi, z / d, label="continuum (CG σ = d/2)")
            if ref_phi is not None:
                axk.plot(ref_phi[f"phi_{key}"], ref_phi["z_rel_over_d"], "--", label="LIGGGHTS (CG σ = d/2)")
            axk.set_title(PHASE_LABELS[key])
            axk.set_xlabel("solid fraction φ")
        _finish_profile_figure(fig, axes[0], "Γ = 3: solid fraction at four floor phases, mean over cycles 3–10",
                               folder / "bed_profiles_gamma3.png", plt)
        g3 = next((c for c in cases if c["gamma"] == 3.0), None)
        if g3 is not None and "temperature" in g3:
            _temperature_figure(g3["temperature"], res, dem_dir, base, folder, plt)
            _energy_figure(g3, res, dem_dir, base, folder, plt)


def _energy_figure(case, res, dem_dir: Path, base, folder, plt):
    """bed_energy_gamma3.png: the internal energy over the run and against the phase, both beds,
    and LIGGGHTS's loss beside Enskog's loss on its own state."""
    temp = case["temperature"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    ax = axes[0]
    ax.plot(res.t / base.period, 1e3 * res.internal_energy, "-", label="continuum")
    path = dem_dir / "internal_energy.csv"
    if path.exists():
        e = _read_csv(path)
        ax.plot(e["t_s"] / base.period, 1e3 * e["E_internal_J"], "k--", label="LIGGGHTS")
    ax.set_xlabel("t [cycles] (floor vibrating from t = 0)")
    ax.set_ylabel("internal kinetic energy [mJ]")
    ax.set_title("in the mass-centre frame: thermal + relative mean flow")
    ax.legend(fontsize=8)
    ph = np.asarray(temp["phase"])
    ax = axes[1]
    ax.plot(ph, 1e3 * np.asarray(temp["continuum_internal_energy_J"]), "-", label="continuum")
    ax.plot(ph, 1e3 * np.asarray(temp["dem_internal_energy_J"]), "k--", label="LIGGGHTS")
    ax.set_xlabel("floor phase [cycles]")
    ax.set_ylabel("internal energy [mJ], cycles 3–10")
    ax.legend(fontsize=8)
    ax = axes[2]
    ax.plot(ph, temp["dem_loss_W"], "k:", label="LIGGGHTS −dE_int/dt")
    budget = temp.get("energy_budget")
    if budget:
        ax.plot(budget["phase_mid"], budget["dem_dissipation_W"], "k--",
                label=f"LIGGGHTS dissipation, energy budget ({1e3 * budget['dem_dissipation_per_cycle_J']:.1f} mJ/cycle)")
        ax.plot(budget["phase_mid"], budget["dem_enskog_cs_loss_at_midpoints_W"], "-", color="C1",
                label=f"Enskog's loss (CS g0) on LIGGGHTS's φ, θ ({1e3 * budget['dem_enskog_cs_loss_per_cycle_J']:.1f} "
                      "mJ/cycle)")
    else:
        ax.plot(ph, temp["dem_enskog_cs_loss_W"], "-", color="C1", label="Enskog's loss (CS g0) on LIGGGHTS's φ, θ")
    fl = temp.get("dem_loss_over_enskog_cs_in_flight")
    if fl:
        a, b = fl["phases"]
        label = f"in flight: ratio median {fl['median']:.2f}"
        for lo, hi in ([(a, b)] if a <= b else [(a, 1.0), (0.0, b)]):     # a window across phase 0: two spans
            ax.axvspan(lo, hi, color="0.9", label=label)
            label = None
    ax.set_ylim(bottom=min(0.0, ax.get_ylim()[0]))
    ax.set_xlabel("floor phase [cycles]")
    ax.set_ylabel("rate of loss [W]")
    ax.legend(fontsize=7)
    _save_figure(fig, "Γ = 3, e = 0.9, frictionless: the bed's internal energy", folder / "bed_energy_gamma3.png",
                 plt)


def _temperature_figure(temp, res, dem_dir: Path, base, folder, plt):
    """bed_temperature_gamma3.png: the bed's mean θ against the phase, and θ against height at the
    four floor phases (reference: vertical and horizontal components where its φ > 0.01)."""
    d = base.diameter
    fig, axes = plt.subplots(1, 5, figsize=(15, 4))
    ph = np.asarray(temp["phase"])
    ax = axes[0]
    ax.plot(ph, temp["continuum_theta_m2_s2"], "-", label="continuum θ")
    ax.plot(ph, temp["dem_theta_m2_s2"], "k--", label="LIGGGHTS (θ_z + 2θ_h)/3")
    ax.plot(ph, temp["dem_theta_z_m2_s2"], ":", color="C3", label="LIGGGHTS θ_z")
    ax.plot(ph, temp["dem_theta_h_m2_s2"], ":", color="C2", label="LIGGGHTS θ_h")
    ax.set_xlabel("floor phase [cycles] (floor at A sin 2π·phase)")
    ax.set_ylabel("bed's mass-mean θ [m²/s²]")
    ax.set_title("Γ = 3: the bed's mean θ")
    ax.legend(fontsize=7)
    path = dem_dir / "temperature_profiles.csv"
    dem = _read_csv(path) if path.exists() else None
    for axk, (key, (z, tz, th)) in zip(axes[1:], res.theta_profiles.items()):
        axk.plot(th, z / d, "-", color="C0", label="continuum θ (horizontal CG)")
        axk.plot(tz, z / d, "-", color="C1", label="continuum vertical CG")
        if dem is not None:
            m = np.asarray(dem[f"phi_{key}"]) > 0.01
            zz = np.asarray(dem["z_rel_over_d"])[m]
            axk.plot(np.asarray(dem[f"theta_z_{key}"])[m], zz, ":", color="C3", label="LIGGGHTS θ_z")
            axk.plot(np.asarray(dem[f"theta_h_{key}"])[m], zz, ":", color="C2", label="LIGGGHTS θ_h")
        axk.set_title(PHASE_LABELS[key])
        axk.set_xlabel("θ [m²/s²] (CG σ = d/2)")
    _finish_profile_figure(fig, axes[1], "Γ = 3, e = 0.9, frictionless: granular temperature, mean over cycles 3–10",
                           folder / "bed_temperature_gamma3.png", plt)


PHASE_LABELS = {"phase0": "ωt = 0", "phase_pi2": "ωt = π/2", "phase_pi": "ωt = π", "phase_3pi2": "ωt = 3π/2"}
"""The four floor phases of the profiles, as the figures name them."""


def _save_figure(fig, title, path, plt):
    """The figure's title (None: none above its panels'), and :data:`FIGURE_NOTE` where set;
    saved to ``path`` at 120 dpi, closed.  Every figure of compare-bed is written here."""
    if title is not None:
        fig.suptitle(title)
    note = FIGURE_NOTE.get()
    if note:
        fig.text(0.995, 0.005, note, ha="right", va="bottom", fontsize=7, color="0.3")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _finish_profile_figure(fig, first_panel, title, path, plt):
    """The height axis and legend on the first profile panel; then :func:`_save_figure`."""
    first_panel.set_ylabel("height above the floor [d]")
    first_panel.legend(fontsize=7)
    _save_figure(fig, title, path, plt)


def format_table(out) -> str:
    rows = ["| Γ | flight continuum [ms] | flight LIGGGHTS [ms] | difference | mass-centre RMS [d] | period doubled "
            "(continuum / LIGGGHTS) |", "|---|---|---|---|---|---|"]
    for c in (out["cases"] + out["extra_cases"] + out.get("spring_dashpot_cases", []) + out.get("large_box_cases", [])
              + out.get("elastic_floor_cases", []) + out.get("other_packing_cases", [])
              + out.get("long_reference_cases", [])):
        name = f"{c['gamma']:g}" + ("" if "dem" not in c else f" ({c['dem']})")
        rows.append(f"| {name} | {1e3 * c['flight_time_s']:.1f} | {1e3 * c.get('dem_flight_time_s', float('nan')):.1f} | "
                    f"{100 * c.get('flight_time_rel_diff', float('nan')):+.1f} % | "
                    f"{c.get('mass_centre_rms_over_d', float('nan')):.2f} | "
                    f"{'yes' if c['period_doubled'] else 'no'} / {'yes' if c.get('dem_period_doubled') else 'no'} |")
    return "\n".join(rows)


RUN_COLUMNS = {
    "trajectory.csv": ("t_s", "com_rel_m"),
    "flights.csv": ("t_takeoff_s", "t_landing_s"),
    "temperature.csv": ("phase_cycles", "theta_m2_s2", "theta_z_m2_s2", "theta_h_m2_s2", "E_internal_J", "loss_W",
                        "enskog_cs_loss_W"),
    "internal_energy.csv": ("t_s", "E_internal_J"),
    "floor_force.csv": ("t_s", "F_floor_N"),
    "flight_vs_threshold.csv": ("threshold_over_weight", "flight_time_mean_last6_s"),
    "structure_per_cycle.csv": ("cycle", "crystal_fraction", "phi_1_6d", "floor_layer_psi4", "floor_layer_psi6",
                                "lateral_mode_over_d", "lateral_mode_shuffled_over_d"),
    "profiles.csv": ("z_rel_over_d",) + tuple(f"phi_{k}" for k in PHASE_LABELS),
    "temperature_profiles.csv": ("z_rel_over_d",) + tuple(f"{q}_{k}" for k in PHASE_LABELS
                                                          for q in ("phi", "theta_z", "theta_h")),
    "floor_loss_by_phase.csv": ("phase", "measured_loss_W"),
}
"""The columns compare-bed reads from each CSV of a LIGGGHTS run's folder (results/gamma_<Γ>_<tag>/);
the trajectory's also vz_com_m_s and com_lab_m for the energy budget, top99_rel_m for the Γ = 3
figure (:func:`check_reference`)."""
NAN_COLUMNS = frozenset({"t_landing_s"})
"""Columns where NaN is data (a flight still going at the end of the run); every other column read
must hold finite numbers."""
SUMMARY_NUMBERS = ("n", "com_rel_mean_over_d", "top99_rel_max_over_d", "wall_time_s")
"""The numbers compare-bed reads from a run's summary.json, beside its flight_time_per_cycle_s."""


class _ReferenceFolder:
    """The files of a LIGGGHTS data folder that one compare-bed command will read, each read and
    parsed once as the comparison reads it (:func:`check_reference`); a problem is a ValueError of
    one line naming ``--reference``, the file relative to the folder and what is wrong."""

    def __init__(self, ref: Path, shown: str):
        self.ref, self.shown = Path(ref), shown
        self.parsed = {}                                  # relative path -> (its structured array, its lines)
        self.runs = set()                                 # (Γ, tag, compared, gamma3_figures) checked

    def refuse(self, text: str):
        raise ValueError(f"--reference {self.shown}: {text}")

    def _text(self, rel: str, why: str) -> str:
        path = self.ref / rel
        if not path.exists():
            self.refuse(f"no {rel} there ({why})")
        try:
            return path.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            self.refuse(f"{rel} cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())})")

    def csv(self, rel: str, columns, why: str):
        """The CSV ``rel`` with ``columns`` (each holding finite numbers, but :data:`NAN_COLUMNS`)
        and at least one row."""
        import warnings
        expected = f"expected a comment line, then a header naming {', '.join(columns)}, then rows of numbers"
        data = self.parsed.get(rel)
        if data is None:
            text = self._text(rel, why)
            if not text.strip():
                self.refuse(f"{rel} is empty ({expected})")
            lines = text.splitlines()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("error")        # (numpy warns "Empty input file" and goes on)
                    data = np.genfromtxt(lines, delimiter=",", names=True, skip_header=1)
            except (IndexError, ValueError, StopIteration, UserWarning) as exc:
                self.refuse(f"{rel} is not a CSV of the LIGGGHTS data folder ({expected}; {type(exc).__name__}: "
                            f"{' '.join(str(exc).split())})")
            self.parsed[rel] = data = (data, lines)
        data, lines = data
        names = data.dtype.names or ()
        missing = [c for c in columns if c not in names]
        if missing:
            head = lines[1].strip() if len(lines) > 1 else ""
            self.refuse(f"{rel} has no column {missing[0]} (its header, line 2: {head[:80]!r}"
                        f"{'...' if len(head) > 80 else ''}; {expected})")
        if data.size == 0:
            self.refuse(f"{rel} has no rows under its header ({expected})")
        for c in columns:
            if c in NAN_COLUMNS:
                continue
            bad = np.flatnonzero(~np.isfinite(np.atleast_1d(data[c]).astype(float)))
            if bad.size:
                raw = dict(enumerate(_raw_cells(lines, c))).get(int(bad[0]))
                where = f"line {raw[0]}" if raw else f"row {int(bad[0]) + 1}"
                value = raw[1] if raw else "nan"
                self.refuse(f"{rel} {where}: {c} = {value!r} is not a finite number")

    def summary(self, rel: str, why: str, numbers=SUMMARY_NUMBERS):
        """A run's summary.json: a JSON object with flight_time_per_cycle_s (numbers ≥ 0 or null, at
        least one flight) and ``numbers`` (finite; n a count of spheres)."""
        text = self._text(rel, why)
        expected = f"expected the run's summary, a JSON object with flight_time_per_cycle_s, {', '.join(numbers)}"
        if not text.strip():
            self.refuse(f"{rel} is empty ({expected})")
        try:
            summ = json.loads(text)
        except ValueError as exc:
            self.refuse(f"{rel} is not JSON ({' '.join(str(exc).split())}; {expected})")
        if not isinstance(summ, dict):
            self.refuse(f"{rel} is not a JSON object ({expected})")
        for key in ("flight_time_per_cycle_s",) + tuple(numbers):
            if key not in summ:
                self.refuse(f"{rel} has no key {key!r} ({expected})")
        flights = summ["flight_time_per_cycle_s"]

        def number(v):
            return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        if (not isinstance(flights, list) or not any(number(v) for v in flights)
                or not all(v is None or (number(v) and v >= 0) for v in flights)):
            self.refuse(f"{rel}: flight_time_per_cycle_s is {json.dumps(flights)[:60]}, expected a list of the "
                        "flight per measured cycle [s] (numbers >= 0, null for a flight unfinished at the end), at "
                        "least one")
        for key in numbers:
            v = summ[key]
            if not number(v) or (key == "n" and not (v == int(v) and v >= 1)):
                self.refuse(f"{rel}: {key} is {json.dumps(v)[:40]}, expected "
                            + ("the number of spheres, an integer >= 1" if key == "n" else "a finite number"))

    def run(self, gamma: float, tag: str, why: str, compared=True, gamma3_figures=False):
        """The reference run ``tag`` at Γ = ``gamma``: its folder, trajectory.csv and summary.json,
        and the optional files that :func:`_case_against` reads where present (``compared``: a run
        the continuum is compared with; otherwise only its trajectory and flights are read), the
        Γ = 3 figures' where ``gamma3_figures``."""
        if (gamma, tag, compared, gamma3_figures) in self.runs:
            return
        self.runs.add((gamma, tag, compared, gamma3_figures))
        d = _run_dir(self.ref, gamma, tag).relative_to(self.ref).as_posix()
        if not (self.ref / d).is_dir():
            self.refuse(f"no {d}/ there ({why})")
        why = f"{why}; a run's folder holds trajectory.csv and summary.json"
        has = {name: (self.ref / d / name).exists() for name in RUN_COLUMNS}
        budget = all(has[n] for n in ("temperature.csv", "internal_energy.csv", "flights.csv", "floor_force.csv"))
        self.csv(f"{d}/trajectory.csv", RUN_COLUMNS["trajectory.csv"]
                 + (("vz_com_m_s", "com_lab_m") if compared and budget else ())
                 + (("top99_rel_m",) if gamma3_figures else ()), why)
        self.summary(f"{d}/summary.json", why, SUMMARY_NUMBERS if compared else ())
        if not compared:
            return
        for name in ("flights.csv", "temperature.csv", "floor_force.csv", "flight_vs_threshold.csv",
                     "structure_per_cycle.csv"):
            if has[name]:
                self.csv(f"{d}/{name}", RUN_COLUMNS[name], why)
        if has["internal_energy.csv"] and has["temperature.csv"]:
            self.csv(f"{d}/internal_energy.csv", RUN_COLUMNS["internal_energy.csv"], why)
        if gamma3_figures and has["profiles.csv"]:
            self.csv(f"{d}/profiles.csv", RUN_COLUMNS["profiles.csv"], why)
        if gamma3_figures and has["temperature_profiles.csv"] and has["temperature.csv"]:
            self.csv(f"{d}/temperature_profiles.csv", RUN_COLUMNS["temperature_profiles.csv"], why)
        if has["floor_loss_by_phase.csv"] and has["temperature.csv"]:       # the energy budget's floor share
            rel = f"{d}/floor_loss_by_phase.csv"
            self.csv(rel, RUN_COLUMNS["floor_loss_by_phase.csv"], why)
            rows = np.atleast_1d(self.parsed[rel][0]).size
            if rows != FLOOR_LOSS_BINS:
                self.refuse(f"{rel} has {rows} rows, expected {FLOOR_LOSS_BINS} (the phase bins between the frames "
                            "of the energy budget)")

    def gamma_list(self, name: str, base: BedSetup, why: str) -> list:
        """The Γ of a flight_vs_gamma CSV, each one the bed takes."""
        self.csv(name, ("gamma",), why)
        gammas = [float(g) for g in np.atleast_1d(self.parsed[name][0]["gamma"])]
        _check_gammas(self.ref, name, gammas, base, self.shown)
        return gammas

    def flight_lists(self, name: str):
        """A flight_vs_gamma CSV as the bifurcation figure reads it (:func:`_dem_flights`, where
        present): a gamma and a flight_times_s column, numbers (NaN: a flight unfinished)."""
        import csv
        if not (self.ref / name).exists():
            return
        lines = self._text(name, "")
        rows = list(csv.reader(line for line in lines.splitlines(keepends=True) if not line.startswith("#")))
        head = rows[0] if rows else []
        for col in ("gamma", "flight_times_s"):
            if col not in head:
                self.refuse(f"{name} has no column {col} (the bifurcation figure of --figures reads gamma and "
                            "flight_times_s: the flights of the measured cycles, separated by spaces)")
        ig, it = head.index("gamma"), head.index("flight_times_s")
        for k, r in enumerate(rows[1:], start=1):
            try:
                float(r[ig])
                [float(x) for x in r[it].split()]
            except (ValueError, IndexError):
                self.refuse(f"{name} data row {k}: gamma and flight_times_s are {r[ig] if len(r) > ig else ''!r} and "
                            f"{r[it] if len(r) > it else ''!r}, expected numbers (the flights separated by spaces)")


EULERIAN_FIELDS = {"--eulerian-cells-per-d": "cells_per_d", "--eulerian-lateral-cells": "lateral_cells",
                   "--eulerian-perturbation": "perturbation", "--eulerian": "dimension"}
"""compare-bed's options of the Eulerian grid and the fields of
:class:`~bsrflow.physics.granular_bed.EulerianBedSetup` they set."""


def _eulerian_option_text(msg: str) -> str:
    """An :class:`EulerianBedSetup` message in compare-bed's words: the option for the field, and a
    range "at most N with the other fields as given" as the option's integers."""
    import re
    option = next((o for o, k in EULERIAN_FIELDS.items() if msg.startswith(k + " = ")), None)
    if option is not None:
        field = EULERIAN_FIELDS[option]
        msg = option + " " + msg[len(field) + 3:]
        lo, hi = (1, MAX_CELLS_PER_D) if field == "cells_per_d" else (2, MAX_LATERAL_CELLS)
        msg = re.sub(r"valid range at these settings \((at most|at least) (\d+) with the other fields as given\)",
                     lambda m: (f"valid range at these settings, integers in "
                                f"{f'[{lo}, {m[2]}]' if m[1] == 'at most' else f'[{m[2]}, {hi}]'} with the other "
                                "options as given"), msg)
    return msg.replace("at dimension = ", "at --eulerian ").replace("with the other fields as given",
                                                                     "with the other options as given")


def check_eulerian_options(setup: BedSetup, eulerian: dict, given) -> None:
    """Refuse (ValueError, one line naming an option and its valid range) the Eulerian grid of
    ``compare-bed --eulerian`` (``eulerian``: :func:`compare_bed`'s keywords) for the bed ``setup``
    (the longest case run): its options' ranges and its cost (nothing allocated).  ``given``: the
    fields (:data:`EULERIAN_FIELDS`) of the options given.  The cost check blames cells_per_d; when
    that option is not given, or no value of it fits (``--eulerian 3 --eulerian-lateral-cells 256``
    said "--eulerian-cells-per-d 4 ..., none fits"), the given option that mends the grid is named
    with its range at the other settings, the one furthest from its default first, as ``bsrflow
    run``'s config (:func:`bsrflow.io.layer_runner._bed_reblamed`); if none mends it alone, the
    message says which must change together."""
    from ..io.layer_runner import _bed_reblamed
    from ..physics.granular_bed import EulerianBedSetup
    kw = {**setup.to_dict(), "dimension": eulerian["dim"], "cells_per_d": eulerian["cells_per_d"],
          "lateral_cells": eulerian["lateral_cells"], "perturbation": eulerian["perturbation"]}
    try:
        EulerianBedSetup(**kw)
        return
    except ValueError as exc:
        msg = str(exc).splitlines()[0]
    blamed = next((k for k in EULERIAN_FIELDS.values() if msg.startswith(k + " = ")), None)
    states_range = re.search(r"valid range[^\[(]*[\[(]\s*[-\d]", msg) is not None and "none fits" not in msg
    if blamed is None or (blamed in given and states_range):
        raise ValueError(_eulerian_option_text(msg))        # names the option given, with its range
    defaults = {"cells_per_d": 4, "lateral_cells": 1 if kw["dimension"] == 1 else 4}    # (_main's)
    menders = sorted((k for k in defaults if k in given and kw[k] != defaults[k] and kw[k] > 0),
                     key=lambda k: abs(math.log(kw[k] / defaults[k])), reverse=True)
    for name in menders:
        problem = _bed_reblamed(EulerianBedSetup, kw, {name}, msg)
        if problem is not None:
            raise ValueError(_eulerian_option_text(problem[1]))
    why = msg.split(": ", 1)[1] if ": " in msg else msg
    options = [o for o, k in EULERIAN_FIELDS.items() if k in menders]
    if len(options) > 1:
        try:
            EulerianBedSetup(**{**kw, **defaults})
            fix = f" (their defaults, {' and '.join(f'{o} {defaults[EULERIAN_FIELDS[o]]}' for o in options)}, fit)"
        except ValueError:
            fix = ""
        raise ValueError(f"{' and '.join(f'{o} {kw[EULERIAN_FIELDS[o]]}' for o in options)} do not fit together at "
                         f"these settings: neither alone mends it, lower them together{fix}: {why}")
    raise ValueError(_eulerian_option_text(msg))


def check_reference(reference, gammas=None, include_extra=True, figures=False, shown=None) -> None:
    """Refuse (ValueError, one line naming ``--reference``, the file relative to the folder and what
    is wrong) a LIGGGHTS data folder that lacks a run or holds a damaged file that
    ``compare_bed(gammas, reference=reference, include_extra=..., figures=...)`` would read, before
    any run: the main run at every Γ of ``gammas`` (default: every Γ of flight_vs_gamma.csv), with
    ``include_extra`` the e = 0.5, frictional and elastic-floor runs the reference lists, and the
    runs taken where present (spring-dashpot, large box, other packings, 30-cycle runs), each file
    read and parsed once.  Without these checks a folder with no runs gave NaN for LIGGGHTS and
    exit 0, and a damaged file a message naming no file after the work had started."""
    ref = Path(reference)
    f = _ReferenceFolder(ref, os.fspath(reference) if shown is None else shown)
    if not (ref / "results").is_dir():
        f.refuse(f"results is not a folder ({'missing' if not (ref / 'results').exists() else 'a file'}; it holds "
                 "the LIGGGHTS runs, results/gamma_<Γ>_<tag>/)")
    known, params, base = reference_bed(ref)
    gammas = known if gammas is None else [float(g) for g in gammas]
    for g in gammas:
        f.run(g, MAIN_RUNS, f"the main LIGGGHTS run at Γ = {g:g}, listed in flight_vs_gamma.csv",
              gamma3_figures=bool(figures) and g == 3.0)
    for key in ("period_doubling_gamma",) + (() if not include_extra else (
            "period_doubling_gamma_friction_mu0.5", "period_doubling_gamma_spring_dashpot",
            "period_doubling_gamma_exploratory_e0.5")):
        entry = params.get(key)
        estimate = entry.get("estimate") if isinstance(entry, dict) else None
        if not isinstance(entry, (dict, type(None))) or not (
                estimate is None or (isinstance(estimate, (int, float)) and not isinstance(estimate, bool)
                                     and math.isfinite(estimate))):
            f.refuse(f"params.json: {key} is {json.dumps(entry)[:40]}, expected an object "
                     "({\"estimate\": Γ or null, ...})")
    if figures:
        for name in ("flight_vs_gamma.csv", "flight_vs_gamma_hooke.csv", "flight_vs_gamma_hooke_mu0.5.csv"):
            f.flight_lists(name)
    if not include_extra:
        return
    skip = "; --no-extra skips it"
    for g in f.gamma_list("flight_vs_gamma_e0.5.csv", base, "the e = 0.5 runs' Γ" + skip):
        f.run(g, E05_RUNS, f"the e = 0.5 LIGGGHTS run at Γ = {g:g}, listed in flight_vs_gamma_e0.5.csv{skip}")
    f.run(3.0, FRICTION_RUNS, f"the frictional LIGGGHTS run at Γ = 3 (μ = {FRICTION:g}){skip}")
    for g in f.gamma_list("flight_vs_gamma_hooke_mu0.5.csv", base, "the frictional runs' Γ" + skip):
        f.run(g, FRICTION_RUNS, f"the frictional LIGGGHTS run at Γ = {g:g}, listed in "
                                f"flight_vs_gamma_hooke_mu0.5.csv{skip}")
    elastic = params.get("gamma_list_elastic_floor") or []
    if not isinstance(elastic, list) or not all(isinstance(g, (int, float)) and not isinstance(g, bool)
                                                and math.isfinite(g) for g in elastic):
        f.refuse(f"params.json: gamma_list_elastic_floor is {json.dumps(elastic)[:40]}, expected a list of the "
                 "elastic-floor runs' Γ (numbers)")
    elastic = [float(g) for g in elastic if float(g) in gammas]
    for g in elastic:
        f.run(g, ELASTIC_FLOOR, f"the elastic-floor LIGGGHTS run at Γ = {g:g}, listed in params.json's "
                                f"gamma_list_elastic_floor{skip}")
    for g in gammas:                                   # the runs taken where present, as compare_bed finds them
        for tag in (SPRING_DASHPOT, LARGE_BOX):
            if (_run_dir(ref, g, tag) / "trajectory.csv").exists():
                f.run(g, tag, "a LIGGGHTS run taken where present")
        for tag in _other_packing_tags(ref, g):
            f.run(g, tag, "a LIGGGHTS run taken where present")
        if (_run_dir(ref, g, STIFFER_BED[0]) / "summary.json").exists():
            f.run(g, STIFFER_BED[0], "a LIGGGHTS run taken where its summary.json is")
            _stiffer_bed(ref, base, [g], f.shown)         # its settled bed's phi_c and Z
        for tag, _, _, _ in _long_runs(ref, g, base):
            f.run(g, tag, "a 30-cycle LIGGGHTS run, taken where its summary.json is")
        if g in elastic:                               # the floor's effect (_floor_contact_effect)
            for tag in (MAIN_RUNS + "_ew0.95", SPRING_DASHPOT + "_ew1"):
                if (_run_dir(ref, g, tag) / "trajectory.csv").exists():
                    f.run(g, tag, "a LIGGGHTS run taken where present", compared=False)


def add_parser(sub):
    helptext = ("the vibrated bed's continuum (packing stress + granular temperature, horizontally uniform) "
                "against the committed LIGGGHTS data")
    p = sub.add_parser("compare-bed", help=helptext, description=helptext)
    p.add_argument("--json", metavar="PATH", help="write the results as JSON (its folder must exist)")
    p.add_argument("--figures", metavar="DIR", help="write the figures to DIR (created if missing; the folder "
                                                     "holding it must exist)")
    p.add_argument("--gammas", type=Number(float, "the LIGGGHTS runs' Γ, 1.5 to 8 in steps of 0.5 (the repository's "
                                            "data)"), nargs="*", metavar="G",
                   help="only these Γ of the main runs (default: every Γ of the LIGGGHTS runs, 1.5 to 8)")
    p.add_argument("--cells", type=Number(int, f"[{CELLS_RANGE[0]}, {CELLS_RANGE[1]}]"), default=200, metavar="N", help="Lagrangian cells over the bed (default 200)")
    p.add_argument("--no-extra", action="store_true",
                   help="skip the e = 0.5, friction, spring-dashpot, 10 000-sphere and elastic-floor comparisons")
    p.add_argument("--workers", type=Number(int, workers_range), default=1, metavar="N",
                   help="run the continuum's runs on N processes (default 1; at most 4 per CPU); the same numbers, "
                        "the wall times then those of a shared machine")
    p.add_argument("--eulerian", type=int, choices=(1, 2, 3), metavar="DIM",
                   help="also run the model on the Eulerian grid in DIM = 1, 2 or 3 dimensions at every main Γ "
                        "(eulerian_cases; serial, 20-40 s per Γ in 1-D at 4 cells per d on this VM, far more in 3-D)")
    p.add_argument("--eulerian-cells-per-d", type=Number(int, f"integers in [1, {MAX_CELLS_PER_D}]"), metavar="N",
                   help="the Eulerian grid's cells per diameter, vertically (default 4; 1 to 64)")
    p.add_argument("--eulerian-lateral-cells", type=Number(int, f"integers in [2, {MAX_LATERAL_CELLS}]"), metavar="N",
                   help="in 2-D / 3-D: cells across the box's side (default 4; 2 to 256)")
    p.add_argument("--eulerian-perturbation", type=Number(float, f"[0, {MAX_PERTURBATION:g}]"), metavar="EPS",
                   help="in 2-D / 3-D: the start's lateral mode, columns 1 + EPS cos(2πx/L) times as tall and "
                   "heavy as the static bed (default 0; [0, 0.05])")
    p.add_argument("--floor-loss", choices=FLOOR_LOSSES, default="kinetic_pressure",
                   help="the continuum's closure of the floor's collisional loss: kinetic_pressure (default; "
                        "(1 - e_w) p sqrt(2θ/π)) or floor_reaction ((1 - e_w) R sqrt(2θ/π), R the whole floor "
                        "reaction, the form LIGGGHTS's measured floor loss supports; not with --eulerian)")
    p.add_argument("--reference", default=os.fspath(REFERENCE), metavar="DIR",
                   help="the LIGGGHTS data folder (default: the repository's reference/liggghts_bed)")
    p.set_defaults(func=_main)


def _main(args) -> int:
    from ..io.paths import check_distinct, check_output_dir, check_output_file

    check_distinct(("--reference", args.reference), ("--json", args.json), ("--figures", args.figures))
    inside = os.path.realpath(args.reference) + os.sep
    for opt, path in (("--json", args.json), ("--figures", args.figures)):
        if path is not None and os.path.realpath(path).startswith(inside):
            raise ValueError(f"{opt} {path} is inside --reference {args.reference} (the LIGGGHTS data, an input); "
                             "write it elsewhere")
    if args.json is not None:
        check_output_file(args.json, "--json")
    if args.figures is not None:                     # checked now, created once everything else is
        check_output_dir(args.figures, "--figures")
    ref = Path(args.reference)
    need = ["flight_vs_gamma.csv", "params.json", "results"] + ([] if args.no_extra else [
        "flight_vs_gamma_e0.5.csv", "flight_vs_gamma_hooke_mu0.5.csv"])
    missing = [n for n in need if not (ref / n).exists()]
    if missing:
        raise ValueError(f"--reference {args.reference}: no {missing[0]} there (the LIGGGHTS data folder holds "
                         f"{', '.join(need)})")
    if not (ref / "results").is_dir():
        raise ValueError(f"--reference {args.reference}: results is not a folder (the LIGGGHTS data folder's "
                         "results/ holds the runs, results/gamma_<Γ>_<tag>/)")
    known, _, _ = reference_bed(ref)
    if args.gammas == []:              # (nargs "*": argparse's "expected at least one argument" named no value)
        raise ValueError("--gammas needs at least one value: the LIGGGHTS runs' Γ, "
                         + ", ".join(f"{k:g}" for k in known))
    if not (CELLS_RANGE[0] <= args.cells <= CELLS_RANGE[1]):
        raise ValueError(f"--cells {args.cells} is outside the valid range [{CELLS_RANGE[0]}, {CELLS_RANGE[1]}]")
    if args.gammas:
        snapped = []
        for g in args.gammas:
            match = [k for k in known if abs(g - k) < 1e-9]
            if not match:
                raise ValueError(f"--gammas {g:g} is not one of the LIGGGHTS runs' Γ: {', '.join(f'{k:g}' for k in known)}")
            snapped.append(match[0])
        if len(set(snapped)) < len(snapped):
            raise ValueError(f"--gammas: a value is given twice ({' '.join(f'{g:g}' for g in args.gammas)})")
        args.gammas = snapped
    if not 1 <= args.workers <= max_workers():
        raise ValueError(f"--workers {args.workers} is outside the valid range {workers_range()}")
    eulerian = None
    given = {k: v for k, v in (("--eulerian-cells-per-d", args.eulerian_cells_per_d),
                               ("--eulerian-lateral-cells", args.eulerian_lateral_cells),
                               ("--eulerian-perturbation", args.eulerian_perturbation)) if v is not None}
    if args.eulerian is None and given:
        raise ValueError(f"{next(iter(given))} needs --eulerian DIM")
    if args.eulerian is not None and args.floor_loss != "kinetic_pressure":
        raise ValueError(f"--floor-loss {args.floor_loss} is an option of the Lagrangian cells: with --eulerian the "
                         "valid value is kinetic_pressure (the Eulerian grid's only floor loss)")
    if args.eulerian == 1:
        lateral = [k for k in given if k != "--eulerian-cells-per-d"]
        if lateral:
            raise ValueError(f"{lateral[0]} applies to --eulerian 2 or 3 (a column has no lateral cells)")
    if args.eulerian is not None:
        eulerian = {"dim": args.eulerian,
                    "cells_per_d": 4 if args.eulerian_cells_per_d is None else args.eulerian_cells_per_d,
                    "lateral_cells": (1 if args.eulerian == 1 else 4 if args.eulerian_lateral_cells is None
                                      else args.eulerian_lateral_cells),
                    "perturbation": 0.0 if args.eulerian_perturbation is None else args.eulerian_perturbation}
        # the grid's options and its cost, for the longest case run (nothing allocated)
        check_eulerian_options(reference_bed(ref)[2].with_(gamma=max(args.gammas or known)), eulerian,
                               {EULERIAN_FIELDS[o] for o in given} | {"dimension"})
    # every file of the reference that the comparison will read, before the banner and the runs
    check_reference(ref, args.gammas, include_extra=not args.no_extra, figures=args.figures is not None,
                    shown=args.reference)
    if args.figures is not None:                     # created only once everything else is checked
        check_output_dir(args.figures, "--figures", create=True)
    t0 = time.perf_counter()
    n_main = len(args.gammas or known)
    print(f"bsrflow compare-bed: {n_main} Γ of the LIGGGHTS runs{'' if args.no_extra else ' and the e = 0.5 and friction runs'}, "
          f"{args.cells} cells{f', {args.workers} workers' if args.workers > 1 else ''}"
          f"{'' if args.floor_loss == 'kinetic_pressure' else f', floor loss {args.floor_loss}'}", flush=True)
    from .compare import _keeping_partial, _log
    with _keeping_partial(args.json, lambda p: f"{len(p['cases']) + len(p['extra_cases'])} finished run(s)"):
        out = compare_bed(args.gammas, args.cells, ref, args.figures, include_extra=not args.no_extra, log=_log,
                          workers=args.workers, eulerian=eulerian, floor_loss=args.floor_loss)
    print(format_table(out))
    pd, cost = out["period_doubling_gamma"], out["cost_s"]

    def gamma_text(g):
        return "none in the range" if g is None else f"{g:g}"

    def seconds(v):
        return "not measured" if v is None else f"{v:.1f} s"
    pf = out.get("period_doubling_gamma_friction_mu0.5")
    if pf is not None:
        print(f"period-doubling Γ with friction {FRICTION:g}: continuum {gamma_text(pf['continuum'])} (11 cycles), "
              f"{gamma_text(pf[f'continuum_{LONG_CYCLES}_cycles'])} ({LONG_CYCLES} cycles); LIGGGHTS "
              f"{gamma_text(pf['dem'])}")
    for f in out.get("floor_contact_effect") or []:
        dem, cont = f["dem_flight_time_s"], f["continuum_flight_time_s"]
        rms = f["dem_mass_centre_rms_between_beds_over_d"]
        print(f"floor contacts elastic instead of e = {f['restitution']:g}, Γ = {f['gamma']:g}: LIGGGHTS flight {1e3 * dem['floor_e']:.1f} -> "
              f"{1e3 * dem['floor_elastic']:.1f} ms ({100 * f['dem_change_rel']:+.1f} %, mass centre moved "
              f"{'n/a' if rms is None else f'{rms:.3f} d'} RMS), continuum {1e3 * cont['floor_e']:.1f} -> "
              f"{1e3 * cont['floor_elastic']:.1f} ms ({100 * f['continuum_change_rel']:+.1f} %)"
              + (f"; LIGGGHTS at floor e = 0.95 {1e3 * dem['floor_e0.95']:.1f} ms" if "floor_e0.95" in dem else "")
              + (f"; LIGGGHTS spring-dashpot {1e3 * dem['spring_dashpot_floor_e']:.1f} -> "
                 f"{1e3 * dem['spring_dashpot_floor_elastic']:.1f} ms" if "spring_dashpot_floor_elastic" in dem else ""))
    for f in out.get("packing_spread") or []:
        print(f"other packings, Γ = {f['gamma']:g}: LIGGGHTS flight over {len(f['dem_flight_time_s'])} packings "
              f"{1e3 * f['dem_flight_mean_s']:.1f} ± {1e3 * f['dem_flight_std_s']:.1f} ms (sample std), "
              f"continuum {1e3 * f['continuum_flight_time_s']:.1f} ms: {100 * f['continuum_rel_diff_to_mean']:+.1f} % "
              f"from the mean ({100 * f['continuum_rel_diff_to_main']:+.1f} % from the main packing's)"
              + ("" if "late" not in f else
                 f"; cycles {f['late']['cycles'][0]}-{f['late']['cycles'][1]} of {len(f['late']['runs'])} "
                 f"30-cycle runs (packings and boxes): {1e3 * f['late']['dem_flight_mean_s']:.1f} ± {1e3 * f['late']['dem_flight_std_s']:.1f} ms, "
                 f"continuum {100 * f['late']['continuum_rel_diff_to_mean']:+.1f} %"))
    psd = out.get("period_doubling_gamma_spring_dashpot")
    if psd is not None:
        print(f"period-doubling Γ against the spring-dashpot bed: continuum {gamma_text(psd['continuum'])}, "
              f"LIGGGHTS spring-dashpot {gamma_text(psd['dem'])}")
    print(f"period-doubling Γ: continuum {gamma_text(pd['continuum'])}, LIGGGHTS {gamma_text(pd['dem'])}; "
          f"cost (Γ = 3): continuum {seconds(cost['continuum'])}, LIGGGHTS {seconds(cost['dem'])}; "
          f"total {time.perf_counter() - t0:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
        print(f"wrote {args.json}")
    return 0
