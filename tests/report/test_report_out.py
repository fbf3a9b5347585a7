#!/usr/bin/python3
"""report_out_guard: `grainbath report --out DIR` replaces only what a report wrote.

Until 2026-12-06 the report removed every *.png in its directory before writing ("stale plots
of an earlier report"), so `--out` pointing at a directory of the user's (a paper's figures, the
case directory itself) deleted the user's plots. Now --out takes a new or empty directory, or
one a report wrote (marker file .grainbath-report, or the report.md of a report from before the
marker); a second report there removes the first one's plots, and only those.
Exit 77 (ctest SKIP) only when /usr/bin/python3 lacks numpy, matplotlib or h5py."""
import argparse
import os
import shutil
import subprocess
import sys

try:
    import numpy  # noqa: F401
    import matplotlib  # noqa: F401
    import h5py  # noqa: F401
except ImportError as e:
    print(f"SKIP: {sys.executable} lacks {e.name} (install python3-matplotlib python3-h5py)")
    sys.exit(77)

ap = argparse.ArgumentParser()
ap.add_argument("--grainbath", required=True)
ap.add_argument("--cases", required=True)
ap.add_argument("--work", required=True)
a = ap.parse_args()

failures = []


def check(ok, msg):
    if not ok:
        failures.append(msg)
        print("FAIL:", msg)


def run(*args):
    return subprocess.run([a.grainbath, *args], capture_output=True, text=True)


shutil.rmtree(a.work, ignore_errors=True)
os.makedirs(a.work)
dsmc_out = os.path.join(a.work, "dsmc")
r = run("run", os.path.join(a.cases, "equilibrium"), "--out", dsmc_out, "-q", "--set", "run.threads=1",
        "--set", "dsmc.particles=2000", "--set", "dsmc.t_end=2", "--set", "dsmc.dt=0.02",
        "--set", "sampling.steady_from=1")
check(r.returncode == 0, f"the DSMC run failed: {r.stderr[-500:]}")
edmd_out = os.path.join(a.work, "edmd")
r = run("run", os.path.join(a.cases, "free-cooling-disks"), "--out", edmd_out, "-q",
        "--set", "edmd.particles=400", "--set", "edmd.collisions=4")
check(r.returncode == 0, f"the EDMD run failed: {r.stderr[-500:]}")

# a directory of the user's: refused, nothing in it touched
mine = os.path.join(a.work, "figures")
os.makedirs(mine)
for name in ("fig1.png", "a2.png", "report.md"):
    with open(os.path.join(mine, name), "w") as f:
        f.write("the user's " + name)
before = {n: open(os.path.join(mine, n), "rb").read() for n in os.listdir(mine)}
r = run("report", dsmc_out, "--out", mine)
check(r.returncode == 2, f"report --out into a directory of the user's: exit {r.returncode}, expected 2")
check("holds files no report wrote" in r.stderr, f"no reason given: {r.stderr.strip()}")
after = {n: open(os.path.join(mine, n), "rb").read() for n in os.listdir(mine)}
check(after == before, f"the user's directory changed: {sorted(before)} -> {sorted(after)}")

# a new directory: the report and its marker; a second report there replaces the first's plots
rep = os.path.join(a.work, "rep")
r = run("report", dsmc_out, "--out", rep)
check(r.returncode == 0, f"report into a new directory failed: {r.stderr[-500:]}")
first = set(os.listdir(rep))
check(".grainbath-report" in first and "a2.png" in first, f"report directory holds {sorted(first)}")
with open(os.path.join(rep, "user.png"), "w") as f:
    f.write("added by the user")
r = run("report", edmd_out, "--out", rep)
check(r.returncode == 0, f"a second report into a report's directory failed: {r.stderr[-500:]}")
second = set(os.listdir(rep))
check("a2.png" not in second, "the first report's DSMC plots were left behind")
check("edmd_series.png" in second, f"the second report's plots are missing: {sorted(second)}")
check("user.png" in second, "a file the user added to the report directory was removed")

# a report from before the marker (its report.md) is still a report's directory
legacy = os.path.join(a.work, "legacy")
shutil.copytree(rep, legacy)
if os.path.exists(os.path.join(legacy, ".grainbath-report")):
    os.remove(os.path.join(legacy, ".grainbath-report"))
r = run("report", dsmc_out, "--out", legacy)
check(r.returncode == 0, f"report into an earlier report's directory without the marker failed: {r.stderr[-500:]}")
left = set(os.listdir(legacy))
check("edmd_series.png" not in left and "a2.png" in left and "user.png" in left,
      f"after replacing a report without marker: {sorted(left)}")

# a report that stopped half-way (a section failed under --strict, a crash) leaves plots but no
# report.md: its marker, kept up to date as each plot is saved, still names them
half = os.path.join(a.work, "half")
code = ("import sys; sys.path.insert(0, sys.argv[1]); import matplotlib; matplotlib.use('Agg'); "
        "import matplotlib.pyplot as plt; from grainbath_report.cli import _prepare_report_dir, _context; "
        "assert _prepare_report_dir(sys.argv[2]) is None; ctx = _context(sys.argv[2]); "
        "ctx.save(plt.figure(), 'stale_plot')")
python_dir = os.environ.get("GRAINBATH_PYTHON_DIR") or os.path.join(os.path.dirname(a.cases), "python")
r = subprocess.run([sys.executable, "-c", code, python_dir, half], capture_output=True, text=True)
check(r.returncode == 0 and os.path.isfile(os.path.join(half, "stale_plot.png")),
      f"could not make a half-written report: {r.stderr[-800:]}")
r = run("report", dsmc_out, "--out", half)
check(r.returncode == 0, f"report into a half-written report's directory failed: {r.stderr[-500:]}")
check(not os.path.exists(os.path.join(half, "stale_plot.png")), "the half-written report's plot was left behind")

if failures:
    print(f"{len(failures)} failure(s)")
    sys.exit(1)
print("ok: report --out replaces only a report's own files")
