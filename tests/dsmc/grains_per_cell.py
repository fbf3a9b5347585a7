#!/usr/bin/python3
"""Long validation (ctest label "long"): the bath equilibrium of a spatial run does not depend
on how many simulated grains share a cell.

A periodic box is homogeneous in law, so its steady temperature must be the homogeneous run's
whatever the cells. Runs cases/equilibrium (grains in a bath: alpha = 0.5, eps = 0.1, power-law
restitution beta = delta = 0.2; 1e5 grains) as shipped (homogeneous: one collision population)
and as a periodic 1D box of length 4 cut into cells of GRAINS_PER_CELL grains on average, SEEDS
seeds each, and checks |T_box - T_homogeneous| < 4 sigma (seed spreads of both).

Why it can fail: the collision rate in a cell must use the density of a grain's partners,
(N - 1) w / V_c, not the cell's N w / V_c (src/dsmc/collide.hpp, cell_partner_density). The
latter gives each grain n (1 + 1/<N>) on average and a steady temperature lower by about
0.039/<N> here (-0.0018 at 20 grains per cell, 25 sigma of this test with the code before
2026-12-05). The script also prints that prediction beside the measured difference.
Seeds are fixed (1..SEEDS); about 15 s of CPU per run.

usage: grains_per_cell.py GRAINBATH CASES_DIR WORK_DIR [SEEDS] [GRAINS_PER_CELL] [section.key=value ...]
(the overrides go to both runs of each seed, e.g. dsmc.dt=0.04 for the dt dependence in
docs/dsmc.md "What remains at few grains per cell"; at 5 grains per cell the 4-sigma
pass line is expected to fail: it is set for the long test's 20 grains per cell and dt = 0.01)"""
import json
import math
import os
import shutil
import sys

from case_run import run_case

exe, cases, work = sys.argv[1:4]
seeds = int(sys.argv[4]) if len(sys.argv) > 4 else 6
per_cell = int(sys.argv[5]) if len(sys.argv) > 5 else 20
overrides = sys.argv[6:]
case = os.path.join(cases, "equilibrium")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)


def temperature(out, *sets):
    summary = json.load(open(os.path.join(run_case(exe, case, work, out, *sets, *overrides), "summary.json")))
    return summary["temperature"]["mean"], summary["counters"]["particles_final"]


def mean_err(values):
    n = len(values)
    m = sum(values) / n
    return m, math.sqrt(sum((v - m) ** 2 for v in values) / (n - 1) / n)


hom, box = [], []
for s in range(1, seeds + 1):
    T, grains = temperature(f"homogeneous-{s}", f"run.seed={s}")
    hom.append(T)
    cells = grains // per_cell
    box.append(temperature(f"box-{s}", f"run.seed={s}", "domain.dimensions=1", "domain.length=[4.0]",
                           f"domain.cells=[{cells}]")[0])
Th, Th_e = mean_err(hom)
Tb, Tb_e = mean_err(box)
d, de = Tb - Th, math.hypot(Th_e, Tb_e)
print(f"homogeneous: T = {Th:.6f} +- {Th_e:.6f} ({seeds} seeds)")
print(f"periodic box, {per_cell} grains per cell: T = {Tb:.6f} +- {Tb_e:.6f}")
print(f"difference {d:+.6f} +- {de:.6f} ({d / de:+.1f} sigma); counting the grain itself in its "
      f"cell's density would give about {-0.039 / per_cell:+.6f}")
ok = abs(d) < 4 * de and de < 0.039 / per_cell / 5
print(("ok   " if ok else "FAIL ") + "|difference| < 4 sigma, and sigma resolves a fifth of the old bias")
sys.exit(0 if ok else 1)
