#!/usr/bin/python3
"""cli_sweep_stats: the numbers `grainbath sweep` makes from its variants' summary.json
(mutation audit of 2026-12-06, docs/reviews/mutation-audit-sweep-summary.md).

1. The ensemble (a sweep over run.seed alone): a tiny seed sweep is run, its variants'
   summary.json are then replaced by summaries written here (one replaced by text that is no
   summary: a replica whose summary cannot be read), and `sweep --resume`, which runs nothing
   when every variant has its summary, gathers them again. Every number of ensemble.json and
   ensemble.md is worked out here from docs/OUTPUT.md, not from the code: the mean over the
   replicas with a finite value, the sample standard deviation over sqrt(R), R; which keys are
   merged (not performance.*, run.*, the errors `.stderr`/`_stderr` and their parts and flags,
   theory.homogeneous, nor a key with fewer than two finite values); the same number in every
   replica with a zero error; the runs' own errors combined as sqrt(sum s_i^2)/R over the
   replicas that give one (`key.stderr` for `key.mean`, `key_stderr` for `key_mean`, as
   rotation.Ttr_mean's rotation.Ttr_stderr, and for other keys); "mean over R replicas"
   counting the summaries read. sweep.tsv and sweep.md: every number at full precision, the
   headline columns at 6 digits, a column null in every variant and a theory column without its
   measured quantity left out of sweep.md.
2. --resume with a case file changed in five lines names three of each side and "2 more".
3. The variant expansion: values split at top-level commas only ("[0,0,0],[0.2,0,0]" is two
   values), the cartesian product with the last --set key varying fastest, directory names from
   the keys' last parts, no ensemble when another key is swept beside run.seed, and a value given
   twice refused for any key.

Needs no module beyond the standard library; tests/cli/CMakeLists.txt registers it only where
/usr/bin/python3 exists."""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys

ap = argparse.ArgumentParser()
ap.add_argument("--grainbath", required=True)
ap.add_argument("--work", required=True)
a = ap.parse_args()

failures = []


def check(ok, msg):
    if not ok:
        failures.append(msg)
        print("FAIL:", msg)


def grainbath(*args):
    return subprocess.run([a.grainbath, *args], capture_output=True, text=True, timeout=120)


CASE = """[run]
solver = "dsmc"
seed = 1
[grains]
density = 1.0
temperature = 1.0
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 300
dt = 0.01
t_end = 0.05
[sampling]
every = 0.05
steady_from = 0.0
"""

shutil.rmtree(a.work, ignore_errors=True)
os.makedirs(a.work)
case = os.path.join(a.work, "case")
os.makedirs(case)
with open(os.path.join(case, "case.toml"), "w") as f:
    f.write(CASE)
out = os.path.join(a.work, "ens")
sweep = ["sweep", case, "--out", out, "-j", "2", "-q", "--set", "run.seed=1,2,3,4", "--set", "run.threads=1"]
r = grainbath(*sweep)
if r.returncode != 0:
    print(f"FAIL: the seed sweep: exit {r.returncode}\n{r.stderr}")
    sys.exit(1)
variants = sorted(d for d in os.listdir(out) if d.startswith("variant-") and not d.endswith(".log"))
check(variants == ["variant-0_seed_1", "variant-1_seed_2", "variant-2_seed_3", "variant-3_seed_4"],
      f"the seed sweep's directories: {variants}")

# ------------------------------------------------------------ 1. the ensemble of hand-built summaries
NULL = None
# the replicas' summaries (variant-3: no summary); values chosen so that no two formulas agree
replicas = [
    {
        "run": {"version": "x \"quoted\", {name}", "seed": 1, "threads": 1},
        "temperature": {"mean": 1.0123456789012345, "stderr": 0.011, "stderr_plateau": True},
        "q": {"mean": 0.5, "stderr": 0.01, "stderr_plateau": False},
        "w": {"mean": 2.0, "stderr": 0.3},
        "rate": 1.25, "rate_stderr": 0.05,
        "prof": {"exponent": -0.8, "exponent_stderr": 0.02, "exponent_stderr_fit": 0.01, "exponent_stderr_modes": 0.017},
        "performance": {"steps_per_second": 1000.0},
        "theory": {"homogeneous": True, "Z": 0.1, "T": 0.9},
        "mode": {"decay_rate": NULL},
        "rot": {"Ttr_mean": 2.1, "Ttr_stderr": 0.05, "Ttr_stderr_plateau": True},
        "partial": 3.0,
        "single": 7.0,
        "flag": True,
        "count": 10,
    },
    {
        "run": {"version": "x \"quoted\", {name}", "seed": 2, "threads": 1},
        "temperature": {"mean": 0.98, "stderr": 0.012, "stderr_plateau": True},
        "q": {"mean": 0.75, "stderr": 0.04, "stderr_plateau": True},
        "w": {"mean": 2.5, "stderr": 0.1},
        "rate": 1.5, "rate_stderr": 0.07,
        "prof": {"exponent": -0.7, "exponent_stderr": 0.03, "exponent_stderr_fit": 0.02, "exponent_stderr_modes": 0.022},
        "performance": {"steps_per_second": 1100.0},
        "theory": {"homogeneous": True, "Z": 0.1, "T": 0.9},
        "mode": {"decay_rate": NULL},
        "rot": {"Ttr_mean": 2.4, "Ttr_stderr": 0.08, "Ttr_stderr_plateau": False},
        "partial": 4.5,
        "flag": False,
        "count": 11,
    },
    {
        "run": {"version": "x \"quoted\", {name}", "seed": 3, "threads": 1},
        "temperature": {"mean": 1.03, "stderr": 0.013, "stderr_plateau": False},
        "q": {"mean": 1.5, "stderr": 0.02, "stderr_plateau": True},
        "w": {"mean": 4.0, "stderr": NULL},
        "rate": 2.5, "rate_stderr": 0.11,
        "prof": {"exponent": -0.95, "exponent_stderr": 0.04, "exponent_stderr_fit": 0.03, "exponent_stderr_modes": 0.028},
        "performance": {"steps_per_second": 900.0},
        "theory": {"homogeneous": True, "Z": 0.1, "T": 0.9},
        "mode": {"decay_rate": NULL},
        "rot": {"Ttr_mean": 2.2, "Ttr_stderr": 0.06, "Ttr_stderr_plateau": True},
        "partial": NULL,
        "flag": True,
        "count": 13,
    },
]
for d, s in zip(variants, replicas):
    with open(os.path.join(out, d, "summary.json"), "w") as f:
        json.dump(s, f, indent=2)
with open(os.path.join(out, variants[3], "summary.json"), "w") as f:
    f.write("not a summary\n")  # a replica whose summary cannot be read


def flat(d, prefix=""):
    """dotted key -> value (numbers, booleans as 0/1, None), strings left out"""
    o = {}
    for k, v in d.items():
        key = prefix + k
        if isinstance(v, dict):
            o.update(flat(v, key + "."))
        elif isinstance(v, str):
            continue
        else:
            o[key] = None if v is None else float(v)
    return o


rows = [flat(s) for s in replicas]
keys = sorted(set().union(*rows))


def merged_here(k):
    parts = ("performance.", "run.")
    tails = (".stderr", "_stderr", "_plateau", "_stderr_fit", "_stderr_modes")
    return not k.startswith(parts) and not k.endswith(tails) and k != "theory.homogeneous"


expected = {}
for k in keys:
    if not merged_here(k):
        continue
    v = [r[k] for r in rows if r.get(k) is not None and math.isfinite(r[k])]
    if len(v) < 2:
        continue
    R = len(v)
    mean = math.fsum(v) / R
    se = math.sqrt(math.fsum((x - mean) ** 2 for x in v) / (R - 1) / R)
    if all(x == v[0] for x in v):
        mean, se = v[0], 0.0
    # docs/OUTPUT.md: `key.stderr` for a `key.mean`, `key_stderr` for a `key_mean`, else `key_stderr`
    err_key = k[:-5] + (".stderr" if k.endswith(".mean") else "_stderr") if k.endswith(("_mean", ".mean")) else k + "_stderr"
    own = [r[err_key] for r in rows if r.get(err_key) is not None and math.isfinite(r[err_key])]
    expected[k] = (mean, se, R, math.sqrt(math.fsum(s * s for s in own)) / len(own) if own else None)
# the keys this test is about (a guard against a mistake in the lists above)
assert set(expected) == {"temperature.mean", "q.mean", "w.mean", "rate", "prof.exponent", "theory.Z", "theory.T",
                         "partial", "flag", "count", "rot.Ttr_mean"}, sorted(expected)
assert expected["w.mean"][3] == math.sqrt(0.3 ** 2 + 0.1 ** 2) / 2  # two of three replicas give an error
assert expected["rot.Ttr_mean"][3] == math.sqrt(0.05 ** 2 + 0.08 ** 2 + 0.06 ** 2) / 3  # rot.Ttr_stderr

r = grainbath(*[x for x in sweep if x != "-q"], "--resume")  # not quiet: the resuming line
check(r.returncode == 0, f"sweep --resume over hand-built summaries: exit {r.returncode}\n{r.stderr}")
check("resuming: 4 of 4 variants finished earlier" in r.stderr, f"--resume ran variants again:\n{r.stderr}")
check("warning: " in r.stderr and "variant-3_seed_4" in r.stderr, f"no warning for the unreadable summary:\n{r.stderr}")
try:
    with open(os.path.join(out, "ensemble.json")) as f:
        ens = flat(json.load(f))
except (OSError, ValueError) as e:
    ens = {}
    check(False, f"ensemble.json: {e}")
got = sorted({k.rsplit(".", 1)[0] for k in ens})
check(got == sorted(expected), f"ensemble.json merges {got}, expected {sorted(expected)}")
for k, (mean, se, R, _own) in expected.items():
    m, s, n = ens.get(k + ".ensemble_mean"), ens.get(k + ".ensemble_stderr"), ens.get(k + ".replicas")
    check(m is not None and abs(m - mean) <= 1e-14 * max(1.0, abs(mean)), f"{k}: ensemble_mean {m}, expected {mean!r}")
    check(s is not None and abs(s - se) <= 1e-14 * max(1e-300, se) + (0 if se == 0 else 1e-16),
          f"{k}: ensemble_stderr {s}, expected {se!r}")
    check(n == R, f"{k}: replicas {n}, expected {R}")

with open(os.path.join(out, "ensemble.md")) as f:
    md = f.read()
check("| quantity | mean over 3 replicas |" in md, f"ensemble.md's header counts the summaries read (3):\n{md[:200]}")
md_rows = {}
for line in md.splitlines():
    cells = [c.strip() for c in line.split("|")]
    if len(cells) >= 6 and cells[1] not in ("quantity", "---"):
        md_rows[cells[1]] = cells[2:5]
check(sorted(md_rows) == sorted(expected), f"ensemble.md's rows {sorted(md_rows)}")
for k, (mean, se, R, own) in expected.items():
    if k not in md_rows:
        continue
    cm, cs, co = md_rows[k]
    check(cm == "%.10g" % mean and cs == "%.4g" % se, f"ensemble.md {k}: {cm}, {cs}; expected {'%.10g' % mean}, {'%.4g' % se}")
    check(co == ("" if own is None else "%.4g" % own), f"ensemble.md {k}: runs' own errors combined '{co}', expected "
                                                         f"{'' if own is None else '%.4g' % own}")

# sweep.tsv: every number at full precision (variant-3's row empty); sweep.md: the headline
# columns with a number in some variant, a theory column only beside its measured quantity
with open(os.path.join(out, "sweep.tsv")) as f:
    tsv = [line.rstrip("\n").split("\t") for line in f]
head = tsv[0]
check(head[:2] == ["variant", "run.seed"], f"sweep.tsv's first columns: {head[:2]}")
check(len(set(head)) == len(head), f"sweep.tsv names a column twice: {sorted(c for c in set(head) if head.count(c) > 1)}")
for i, row in enumerate(tsv[1:4]):
    for k, v in rows[i].items():
        cell = row[head.index(k)] if k in head else None
        want = "" if v is None else "nan" if math.isnan(v) else "%.17g" % v
        if v is None:
            want = "nan"  # null: read as NaN, printed as such
        check(cell == want, f"sweep.tsv {tsv[i + 1][0]} {k}: '{cell}', expected '{want}'")
with open(os.path.join(out, "sweep.md")) as f:
    smd = f.read().splitlines()
check(smd[0] == "| variant | run.seed | temperature.mean | temperature.stderr |",
      f"sweep.md's columns: {smd[0]} (mode.decay_rate is null everywhere, theory.Z has no pressure.Z)")
check(len(smd) > 2 and smd[2] == "| 0 | 1 | 1.01235 | 0.011 |", f"sweep.md's first row: {smd[2:3]}")

# ------------------------------------------------------------ 2. --resume names what changed
with open(os.path.join(case, "case.toml"), "w") as f:
    f.write(CASE.replace("density = 1.0", "density = 1.1").replace("temperature = 1.0", "temperature = 1.1")
            .replace("e = 0.9", "e = 0.8").replace("particles = 300", "particles = 301").replace("dt = 0.01", "dt = 0.005"))
r = grainbath(*sweep, "--resume")
check(r.returncode == 2, f"--resume with a changed case: exit {r.returncode}")
check("the sweep's lines not in this command: 'density = 1.0', 'temperature = 1.0', 'e = 0.9' and 2 more; "
      "this command's lines not in the sweep: 'density = 1.1', 'temperature = 1.1', 'e = 0.8' and 2 more" in r.stderr,
      f"--resume's refusal does not name the changed lines:\n{r.stderr}")
with open(os.path.join(case, "case.toml"), "w") as f:
    f.write(CASE)

# ------------------------------------------------------------ 3. the variants
out2 = os.path.join(a.work, "grid")
with open(os.path.join(case, "case.toml"), "w") as f:
    f.write(CASE + "[background]\nmass_ratio = 0.5\ndensity = 1.0\ntemperature = 1.0\nknudsen = 0.1\n")
r = grainbath("sweep", case, "--out", out2, "-j", "2", "-q", "--set", "run.seed=1,2", "--set",
              "background.velocity=[0,0,0], [0.2,0,0]", "--set", "run.threads=1")
check(r.returncode == 0, f"the sweep over seed and velocity: exit {r.returncode}\n{r.stderr}")
names = sorted(d for d in os.listdir(out2) if d.startswith("variant-") and not d.endswith(".log")) if os.path.isdir(out2) else []
check(names == ["variant-0_seed_1_velocity__0_0_0_", "variant-1_seed_1_velocity__0.2_0_0_",
                "variant-2_seed_2_velocity__0_0_0_", "variant-3_seed_2_velocity__0.2_0_0_"],
      f"the variants of run.seed=1,2 x velocity=[0,0,0],[0.2,0,0]: {names}")
check(not os.path.exists(os.path.join(out2, "ensemble.json")), "an ensemble of runs that differ in more than the seed")
if os.path.exists(os.path.join(out2, "sweep.tsv")):
    with open(os.path.join(out2, "sweep.tsv")) as f:
        t2 = [line.rstrip("\n").split("\t") for line in f]
    check([row[:3] for row in t2[1:]] == [[names[0], "1", "[0,0,0]"], [names[1], "1", "[0.2,0,0]"],
                                          [names[2], "2", "[0,0,0]"], [names[3], "2", "[0.2,0,0]"]] if len(names) == 4 else False,
          f"sweep.tsv's swept values: {[row[:3] for row in t2[1:]]}")
# a value given twice is refused for any key, not only run.seed, before anything runs
out3 = os.path.join(a.work, "twice")
r = grainbath("sweep", case, "--out", out3, "-q", "--set", "dsmc.dt=0.01, 0.01")
check(r.returncode == 2 and "the value 0.01 is given twice" in r.stderr and not os.path.exists(out3),
      f"dsmc.dt=0.01,0.01: exit {r.returncode}\n{r.stderr}")

if failures:
    print(f"{len(failures)} failure(s)")
    sys.exit(1)
print("ok")
