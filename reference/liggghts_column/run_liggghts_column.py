"""LIGGGHTS reference for the tapped column (issue #18's cases): the package's DEM checked
against a real, independent engine.

    python reference/liggghts_column/run_liggghts_column.py            # every case (about 10 min)
    python reference/liggghts_column/run_liggghts_column.py --cases d22mm_a0.75,demo_three_taps_a0.75
    python reference/liggghts_column/run_liggghts_column.py --compare    # the package DEM against them

For each case of ``bsrflow compare --kernel packing`` (d = 5, 10, 22 mm at a/d = 0.5, 0.75,
1.0, 1.5, single taps; three taps 1.0 s apart at d = 22 mm, a/d = 0.75 and 1.0) and the demo's
three-tap case (0.6 s apart), the script writes a LIGGGHTS 3.8.0 deck (Debian package
``liggghts``), runs it serially and reduces its dump with the package's own reader
(:func:`bsrflow.io.lammps.read_dump`) into ``results/<case>.csv``: time [s], floor, top sphere
and mass-centre heights [m] (lab frame, from the floor at rest), every 5 ms (the package's
samples).  ``summary.json`` holds each case's parameters, time step, wall time and the top
sphere's maximum after the first tap.  One real dump is kept, gzipped, for the reader's tests
(``results/d22mm_a0.75.dump.gz``).  Work files go to ``work/`` (not committed).

The column is the package's (``bsrflow.analysis.compare_packing.case_setup``): N = 20 spheres of
1200 kg/m³ stacked on a line, starting at rest and touching, K = 1.366e7 N/m, e = 0.9, half-sine
taps of the floor at f = 10 Hz from t = 0.4 s.  Contacts: LIGGGHTS's ``edinburgh/stiffness``
in its linear, non-adhesive limit without dashpot, which is the Walton-Braun law of
:mod:`bsrflow.physics.dem` (loading K, unloading K/e²; the deck is the bed reference's,
``reference/liggghts_bed/run_liggghts.py``, with this column's K and e), between spheres and
with the floor, a mesh moved by ``move/mesh wiggle`` during each tap (its position a sin(ωt')
from the tap's start, the package's ϑ) and at rest otherwise.  The spheres start exactly on a
vertical line and their horizontal forces are zeroed (``fix setforce 0 0 NULL``), so the
column stays one-dimensional like the package's.  The time step is the package DEM's rule
(the shortest contact's half period on the stiff line over 50), made a whole fraction of the
5-ms sample interval so that the taps start on a step.
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
WORK = HERE / "work"
RESULTS = HERE / "results"
STEPS_PER_CONTACT = 50
KEPT_DUMP = "d22mm_a0.75"


def _bed_reference():
    """The bed reference's deck pieces (contact law, floor mesh, the LIGGGHTS runner)."""
    path = HERE.parent / "liggghts_bed" / "run_liggghts.py"
    spec = importlib.util.spec_from_file_location("run_liggghts_bed", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def cases(variants: bool = False) -> dict:
    """name -> ColumnSetup: issue #18's 14 cases and the demo's three taps 0.6 s apart; with
    ``variants`` also the "outside the 14 cases" columns of docs/packing-column.md (``bench/check_packing_generality.py``:
    one of e, N, f, K changed at d = 22 mm, a/d = 0.75 and 1.0), named ``<variant>_<case>``."""
    from bsrflow.analysis.compare_packing import PACKING_CASES, case_setup
    from bsrflow.physics.column import ColumnSetup
    out = {c["name"]: case_setup(c) for c in PACKING_CASES}
    demo = {"name": "demo_three_taps_a0.75", "diameter": ColumnSetup().diameter, "a_over_d": 0.75,
            "n_taps": 3, "tap_period": 0.6}
    out[demo["name"]] = case_setup(demo)
    if variants:
        path = HERE.parent.parent / "bench" / "check_packing_generality.py"
        if str(path.parent) not in sys.path:
            sys.path.insert(0, str(path.parent))          # its own imports (bench/_args.py)
        spec = importlib.util.spec_from_file_location("check_packing_generality", path)
        gen = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(gen)
        for vname, change in gen.VARIANTS.items():
            base = ColumnSetup(kernel_name="packing").with_(**change)
            for c in PACKING_CASES:
                if c["name"] in ("d22mm_a0.75", "d22mm_a1.0"):
                    out[f"{vname}_{c['name']}"] = case_setup(c, base)
    return out


def timestep(s) -> tuple[float, int]:
    """(Δt [s], steps per 5-ms sample): the package DEM's t_c/50 with t_c = π √((m/2)/K2),
    shortened to a whole fraction of the sample interval."""
    m = s.density * math.pi * s.diameter ** 3 / 6.0
    tc = math.pi * math.sqrt(0.5 * m / (s.stiffness / s.restitution ** 2))
    n = math.ceil(s.save_every / (tc / STEPS_PER_CONTACT))
    return s.save_every / n, n


def deck(s, dt: float, n_sample: int, bed) -> str:
    """The LIGGGHTS input of column ``s`` (a ColumnSetup)."""
    d = s.diameter
    lx = 3.0 * d                                        # periodic sides: no image within reach
    launch = 2.5 * s.amplitude * s.omega                # above the DEM's top launch speed, 2.05 aω
    zhi = (s.n_spheres + 5) * d + launch ** 2 / (2.0 * s.gravity)
    bed.K_N, bed.E_REST = s.stiffness, s.restitution    # the bed's deck pieces with this law
    atoms = "\n".join(f"create_atoms 1 single {lx / 2:.10g} {lx / 2:.10g} {(k + 0.5) * d:.12g} units box"
                      for k in range(s.n_spheres))
    steps = lambda t: int(round(t / dt))               # noqa: E731 (times are whole steps)
    run = [f"run {steps(s.tap_start)}"]
    t = s.tap_start
    half = 0.5 / s.frequency
    for k in range(s.n_taps):
        tk = s.tap_start + k * s.tap_period
        if tk > t:
            run.append(f"run {steps(tk) - steps(t)}")
        run += [f"fix tap all move/mesh mesh floor wiggle amplitude 0 0 {s.amplitude:.12g} "
                f"period {1.0 / s.frequency:.12g}",
                f"run {steps(tk + half) - steps(tk)}",
                "unfix tap"]
        t = tk + half
    run.append(f"run {steps(s.t_end) - steps(t)}")
    header = bed.deck_header(lx, 0.0, zhi).replace("liggghts_bed/run_liggghts.py",
                                                   "liggghts_column/run_liggghts_column.py")
    return header + f"""region          box block 0 {lx:.10g} 0 {lx:.10g} {-0.5 * d:.10g} {zhi:.10g} units box
create_box      2 box
neighbor        {0.1 * d:.6g} bin
neigh_modify    delay 0
{bed.deck_contact("walton_braun", 0.0)}
timestep        {dt:.12g}
fix floor all mesh/surface/stress file floor.stl type 2 reference_point 0 0 0
fix wall all wall/gran {bed.wall_fix("walton_braun", 0.0)}
{atoms}
set group all diameter {d:.12g} density {s.density:.12g}
fix grav all gravity {s.gravity:.12g} vector 0 0 -1
fix integr all nve/sphere
fix line all setforce 0.0 0.0 NULL
variable zf equal f_floor[9]
variable st equal step
fix pr all print {n_sample} "${{st}} ${{zf}}" file floor.txt screen no title "# step z_floor_mesh"
dump da all custom {n_sample} column.dump id type x y z vz
dump_modify da sort id format "%d %d %.10g %.10g %.12g %.8g"
thermo_style    custom step time atoms
thermo          {100 * n_sample}
{chr(10).join(run)}
"""


def reduce(s, wd: Path, dt: float) -> np.ndarray:
    """(t, floor, top, mass centre) rows from the dump and the floor file [s, m, m, m]."""
    from bsrflow.io.lammps import read_dump
    traj = read_dump(wd / "column.dump", timestep_size=dt)
    z = traj.heights()
    if z.shape[1] != s.n_spheres or not np.all(np.isfinite(z)):
        raise SystemExit(f"{wd}: the dump does not hold {s.n_spheres} finite sphere heights")
    if np.any(np.abs(traj.positions[:, :, :2] - traj.positions[:1, :1, :2]) > 1e-9 * s.diameter):
        raise SystemExit(f"{wd}: the column left its vertical line")
    printed = np.loadtxt(wd / "floor.txt", comments="#", ndmin=2)   # fix print skips step 0
    at = dict(zip(printed[:, 0].astype(np.int64), printed[:, 1]))
    at.setdefault(0, 0.0)                                             # the floor starts at rest at 0
    missing = [int(st) for st in traj.timestep if int(st) not in at]
    if missing:
        raise SystemExit(f"{wd}: no floor position at steps {missing[:5]}")
    floor = np.array([at[int(st)] for st in traj.timestep])
    return np.column_stack([traj.t, floor, z.max(axis=1), z.mean(axis=1)])


def run_case(name: str, s, bed) -> dict:
    wd = WORK / name
    wd.mkdir(parents=True, exist_ok=True)
    bed.write_floor_stl(wd / "floor.stl", 3.0 * s.diameter)
    dt, n_sample = timestep(s)
    (wd / "in.column").write_text(deck(s, dt, n_sample, bed))
    wall = bed.run_liggghts(wd / "in.column", wd, Path("log.column"))
    rows = reduce(s, wd, dt)
    RESULTS.mkdir(exist_ok=True)
    np.savetxt(RESULTS / f"{name}.csv", rows, delimiter=",", fmt="%.10g",
               header="t_s,floor_m,top_m,mass_centre_m  (lab frame, from the floor at rest; "
                      "top = the highest sphere centre)", comments="# ")
    if name == KEPT_DUMP:
        with open(wd / "column.dump", "rb") as src, gzip.open(RESULTS / f"{name}.dump.gz", "wb", 9) as dst:
            shutil.copyfileobj(src, dst)
    after = rows[:, 0] >= s.tap_start - 1e-12
    k = int(np.argmax(np.where(after, rows[:, 2], -np.inf)))
    return {"diameter_m": s.diameter, "a_over_d": s.a_over_d, "n_taps": s.n_taps, "tap_period_s": s.tap_period,
            "t_end_s": s.t_end, "n_spheres": s.n_spheres, "stiffness_N_m": s.stiffness,
            "restitution": s.restitution, "density_kg_m3": s.density, "frequency_Hz": s.frequency,
            "tap_start_s": s.tap_start, "dt_s": dt, "steps": int(round(s.t_end / dt)),
            "top_max_over_d": float(rows[k, 2] / s.diameter), "t_top_max_s": float(rows[k, 0]),
            "wall_time_s": wall}


def compare(name: str, s) -> dict:
    """The package's DEM (:func:`bsrflow.analysis.compare.run_dem_column`) against the committed
    LIGGGHTS run of case ``name`` (ColumnSetup ``s``): per tap the top maxima [d] and times [s],
    their difference, the mass-centre and top RMS over the run [d], the largest floor difference
    [m]; no LIGGGHTS needed."""
    from bsrflow.analysis.compare import run_dem_column
    t, pos, floor = run_dem_column(s)
    lig = np.loadtxt(RESULTS / f"{name}.csv", delimiter=",")
    if lig.shape[0] != t.size or np.max(np.abs(lig[:, 0] - t)) > 1e-9:
        raise SystemExit(f"{name}: the committed run's samples are not the package DEM's")
    d = s.diameter
    top, centre = pos.max(axis=1), pos.mean(axis=1)
    starts = list(s.tap_times()) + [np.inf]
    taps = []
    for t0, t1 in zip(starts[:-1], starts[1:]):
        w = (t >= t0 - 1e-12) & (t < t1)
        i, j = int(np.argmax(np.where(w, top, -np.inf))), int(np.argmax(np.where(w, lig[:, 2], -np.inf)))
        taps.append({"dem_top_max_over_d": float(top[i] / d), "dem_t_top_max_s": float(t[i]),
                     "liggghts_top_max_over_d": float(lig[j, 2] / d), "liggghts_t_top_max_s": float(lig[j, 0]),
                     "diff_over_d": float((top[i] - lig[j, 2]) / d), "rel_diff": float(top[i] / lig[j, 2] - 1.0)})
    return {"taps": taps,
            "mass_centre_rms_over_d": float(np.sqrt(np.mean((centre - lig[:, 3]) ** 2)) / d),
            "top_rms_over_d": float(np.sqrt(np.mean((top - lig[:, 2]) ** 2)) / d),
            "floor_max_diff_m": float(np.max(np.abs(lig[:, 1] - floor)))}


def print_comparison(names, every) -> None:
    print("case                     tap  DEM top/d  LIGGGHTS top/d   diff [d]    rel     same t  mc RMS/d")
    for name in names:
        c = compare(name, every[name])
        for k, tap in enumerate(c["taps"]):
            same = abs(tap["dem_t_top_max_s"] - tap["liggghts_t_top_max_s"]) < 1e-9
            print(f"{name:24s} {k + 1:3d}  {tap['dem_top_max_over_d']:9.3f}  {tap['liggghts_top_max_over_d']:14.3f}"
                  f"  {tap['diff_over_d']:+9.3f}  {100 * tap['rel_diff']:+6.2f}%  {str(same):>6s}"
                  + (f"  {c['mass_centre_rms_over_d']:8.4f}" if k == 0 else ""))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", default=None, help="comma-separated case names (default: all)")
    p.add_argument("--compare", action="store_true",
                   help="no LIGGGHTS run: print the package DEM against the committed LIGGGHTS results")
    p.add_argument("--variants", action="store_true",
                   help="also the columns of bench/check_packing_generality.py (e, N, f or K changed)")
    args = p.parse_args(argv)
    every = cases(args.variants)
    names = list(every) if args.cases is None else [c.strip() for c in args.cases.split(",")]
    unknown = [n for n in names if n not in every]
    if unknown:
        print(f"run_liggghts_column.py: --cases: unknown {', '.join(unknown)}; valid: {', '.join(every)}",
              file=sys.stderr)
        return 2
    if args.compare:
        print_comparison(names, every)
        return 0
    if shutil.which("liggghts") is None:
        print("run_liggghts_column.py: the `liggghts` executable is not on the PATH "
              "(Debian: apt-get install liggghts)", file=sys.stderr)
        return 2
    bed = _bed_reference()
    summary_path = HERE / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else {}
    summary.setdefault("cases", {})
    summary["engine"] = "LIGGGHTS 3.8.0 (Debian package liggghts), serial"
    summary["contact_law"] = ("edinburgh/stiffness, linear (overlapExponent 1), no adhesion, no dashpot: "
                              "Walton-Braun, loading K, unloading K/e^2; spheres and floor mesh alike")
    for name in names:
        res = run_case(name, every[name], bed)
        summary["cases"][name] = res
        print(f"{name}: top max {res['top_max_over_d']:.3f} d at {res['t_top_max_s']:.3f} s, "
              f"dt {res['dt_s']:.4g} s, wall {res['wall_time_s']:.1f} s", flush=True)
        summary_path.write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
