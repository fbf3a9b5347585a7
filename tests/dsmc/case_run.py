"""Shared by the long DSMC validation scripts (hot_walls_bulk.py, grains_per_cell.py): one
`grainbath run` of a case directory with --set overrides, stopping the test on failure."""
import os
import subprocess
import sys


def run_case(exe, case, work, out, *sets):
    """Runs CASE into WORK/OUT with each `section.key=value` of SETS; returns the output path."""
    cmd = [exe, "run", case, "--out", os.path.join(work, out), "-q"]
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"FAIL: {' '.join(cmd)} exited with {r.returncode}:\n{r.stderr[-2000:]}")
    return os.path.join(work, out)
