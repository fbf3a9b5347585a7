"""The x axis of a sweep's plots: one rule for `grainbath report DIR` (python/grainbath_report/
sweep.py) and the sweep's own sweep.png (scripts/plot_sweep.py), stated in docs/OUTPUT.md
("Sweep directories"). Standard library only: plot_sweep.py imports it without numpy or h5py.

The rule: the swept keys are the `--set` keys given several values (sweep.identity), or, for a
folder of runs that no `grainbath sweep` made, the parameters whose values differ between the
runs. Of the swept keys whose values are all numbers, the x axis is the one with the most
distinct values; on a tie the first in PREFERRED, then in alphabetical order. Every other swept
key makes one series per value. `--x KEY` chooses the x axis instead.
"""
import os

# The DSMC window errors that the plateau test judges (src/dsmc/output.cpp); the CLI's run table
# marks the same ones (src/cli/commands.cpp, print_table).
PLATEAU_JUDGED = ("temperature.stderr", "a2.stderr", "rotation.R_stderr")
# the EDMD's (since 2026-12-06 its runs say so too: a note, "(few samples: unchecked)" in the table)
EDMD_PLATEAU_JUDGED = ("temperature.stderr", "pressure.Z_stderr", "rotation.R_stderr")


def error_verdict(solver, err_key, err, plateau):
    """The rule for an error (the single-run report's, common.lower_bound and common.unchecked):
    "no plateau" when the run flagged it (`<err_key>_plateau` false), "unchecked" for a DSMC or
    EDMD window error without the flag (too few samples to judge, or a run from before 2026-12-05),
    else None. `plateau`: True, False or None (absent). No σ distance is given from a flagged or
    unchecked error."""
    if not err_key:
        return None
    if plateau is False:
        return "no plateau"
    if solver == "dsmc" and err_key in PLATEAU_JUDGED and err is not None and plateau is None:
        return "unchecked"
    if solver == "edmd" and err_key in EDMD_PLATEAU_JUDGED and err is not None and plateau is None:
        return "unchecked"
    return None

# tie-break among axes with as many values (the usual x axes of the shipped cases first)
PREFERRED = ["edmd.packing_fraction", "background.knudsen", "restitution.e", "restitution.beta",
             "restitution.delta", "background.mass_ratio", "domain.length", "grains.wavenumber_index"]


def split_values(s):
    """"a,b,[1,2],c" split at top-level commas, spaces trimmed (as src/cli/sweep.cpp does)."""
    out, cur, depth, quoted = [], "", 0, False
    for ch in s:
        if ch == '"':
            quoted = not quoted
        if not quoted and ch in "[{":
            depth += 1
        if not quoted and ch in "]}":
            depth -= 1
        if ch == "," and depth == 0 and not quoted:
            out.append(cur.strip())
            cur = ""
        else:
            cur += ch
    out.append(cur.strip())
    return out


def identity_axes(sweep_dir):
    """The swept keys of a `grainbath sweep` directory in `--set` order (the keys given several
    values, read from sweep.identity), or None when there is no sweep.identity."""
    try:
        with open(os.path.join(sweep_dir, "sweep.identity"), encoding="utf-8") as f:
            text = f.read()
    except OSError:
        return None
    at = text.rfind("\n--set:\n")
    if at < 0:
        return None
    keys = []
    for line in text[at + len("\n--set:\n"):].splitlines():
        if line.startswith("variant ") or "=" not in line:
            break
        key, values = line.split("=", 1)
        if len(split_values(values)) > 1:
            keys.append(key.strip())
    return keys


def _number(v):
    if isinstance(v, bool):
        return False
    if isinstance(v, (int, float)):
        return True
    try:
        float(v)
        return True
    except (TypeError, ValueError):
        return False


def choose_x(values, requested=None):
    """values: {swept key: [its value in each run]} (numbers, or the strings of sweep.tsv).
    Returns (x key or None, the other swept keys); raises ValueError naming the swept keys when
    `requested` is not one of them or not numeric."""
    keys = list(values)
    numeric = [k for k in keys if values[k] and all(_number(v) for v in values[k])]
    if requested is not None:
        if requested not in values:
            raise ValueError(f"--x {requested}: not a swept key of this sweep; the swept keys are "
                             + (", ".join(keys) if keys else "none"))
        if requested not in numeric:
            raise ValueError(f"--x {requested}: its values are not all numbers; the numeric swept keys are "
                             + (", ".join(numeric) if numeric else "none"))
        x = requested
    elif numeric:
        def rank(k):
            return (-len({float(v) for v in values[k]}),
                    PREFERRED.index(k) if k in PREFERRED else len(PREFERRED), k)
        x = min(numeric, key=rank)
    else:
        x = None
    return x, [k for k in keys if k != x]
