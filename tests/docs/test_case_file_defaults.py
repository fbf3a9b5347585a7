#!/usr/bin/env python3
"""docs/CASE_FILE.md's defaults are the ones the solvers use.

Every table row of docs/CASE_FILE.md names keys and a default. This test runs small cases of
both solvers that leave those keys unset, reads the resolved parameters the run recorded
(results.h5 /parameters: every key with its default applied, docs/OUTPUT.md) and compares each
with the documented default, evaluated where the document gives a rule ("10 dt", "t_end/2",
"TB", "1/2 in 2D, 2/5 in 3D"). A default changed in the code and not in the document (or the
reverse) fails here. Rows whose default is not a value (required keys, "wall direction,
else x") are listed as not compared.

Usage: test_case_file_defaults.py --grainbath BIN --doc docs/CASE_FILE.md --work DIR
Exit 77 (skipped) when /usr/bin/python3 lacks h5py.
"""
import argparse
import math
import os
import re
import shutil
import subprocess
import sys

try:
    import h5py
except ImportError:
    print("h5py missing: skipped")
    sys.exit(77)


def parse_doc(path):
    """(solver, 'section.key') -> default cell text, from the tables of docs/CASE_FILE.md."""
    rows = {}
    solver, section = "dsmc", None
    for line in open(path, encoding="utf-8"):
        if line.startswith("## EDMD"):
            solver = "edmd"
        m = re.match(r"#+ \[(\w+)\]", line)
        if m:
            section = m.group(1)
            continue
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
        if len(cells) < 2:
            continue
        keys = re.findall(r"`([\w.]+)`", cells[0])
        if not keys:
            continue
        defaults = [cells[1]] if len(keys) == 1 else [d.strip() for d in cells[1].split(",")]
        if len(defaults) != len(keys):
            defaults = [cells[1]] * len(keys)
        for key, default in zip(keys, defaults):
            dotted = key if "." in key else f"{section}.{key}"
            rows[(solver, dotted)] = default
    return rows


def toml_value(text):
    """A parameter's TOML text as Python: float, str, bool or list."""
    t = text.strip()
    if t in ("true", "false"):
        return t == "true"
    if t.startswith('"'):
        return t.strip('"')
    if t.startswith("["):
        inner = t[1:-1].strip()
        return [toml_value(x) for x in inner.split(",")] if inner else []
    return float(t)


def expected(default, params, dims):
    """The documented default as a value, or None when the cell states no value."""
    d = default.replace("`", "").strip()
    num = r"[-+]?\d+(?:\.\d*)?(?:e[-+]?\d+)?"
    rules = {
        "10 dt": lambda: 10 * params["dsmc.dt"],
        "t_end/2": lambda: 0.5 * params["dsmc.t_end"],
        "t_end": lambda: params["dsmc.t_end"],
        "TB": lambda: params["background.temperature"],
        "1/2 in 2D, 2/5 in 3D": lambda: 0.5 if dims == 2 else 0.4,
        "∞ (no sliding)": lambda: math.inf,
        "(required for constant; 0.7 for bizon)": lambda: 0.7 if params.get("restitution.law") == "bizon" else None,
        '10⁻⁶ for laws "constant", "power", "walton"; else 0':
            lambda: 1e-6 if params.get("restitution.law") in ("constant", "power", "walton") else 0.0,
        "driving_speed": lambda: params.get("walls.driving_speed"),
        "restitution": lambda: params.get("walls.restitution"),
        '"x" ("y" if axis = x)': lambda: "y" if params.get("heating.axis") == "x" else "x",
        'wall direction, else "x"': lambda: (params.get("walls.directions") or ["x"])[0],
        "[10,…]": lambda: [10.0] * dims,
        "[1, 1(, 1)]": lambda: [1.0] * dims,
    }
    if d in rules:
        return rules[d]()
    if not d or "required" in d:
        return None
    if d in ("true", "false"):
        return d == "true"
    m = re.fullmatch(r'"(\w+)"', d)
    if m:
        return m.group(1)
    m = re.fullmatch(rf"({num})(?: \((?:automatic|off)\))?", d)
    if m:
        return float(m.group(1))
    if d.startswith("[") and d.endswith("]"):
        inner = d[1:-1].strip()
        if not inner:
            return []
        items = [x.strip() for x in inner.split(",")]
        if all(re.fullmatch(num, x) for x in items):
            return [float(x) for x in items]
        if all(re.fullmatch(r'"\w+"', x) for x in items):
            return [x.strip('"') for x in items]
    return None


def same(a, b):
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isinf(a) and math.isinf(b)) or abs(a - b) <= 1e-12 * max(abs(a), abs(b))
    return a == b


# Small runs that leave the documented keys unset: (name, solver, dimensions, case text).
RUNS = [
    ("dsmc-defaults", "dsmc", 3, '[run]\nsolver = "dsmc"\n'),
    ("dsmc-medium", "dsmc", 3, '[run]\nsolver = "dsmc"\n[background]\ndensity = 1.0\n'
     '[dsmc]\nparticles = 2000\nt_end = 0.2\n'),
    ("dsmc-power", "dsmc", 3, '[run]\nsolver = "dsmc"\n[restitution]\nlaw = "power"\n'
     '[dsmc]\nparticles = 2000\nt_end = 0.2\n'),
    ("dsmc-bizon", "dsmc", 3, '[run]\nsolver = "dsmc"\n[restitution]\nlaw = "bizon"\n'
     '[dsmc]\nparticles = 2000\nt_end = 0.2\n'),
    ("dsmc-walton", "dsmc", 3, '[run]\nsolver = "dsmc"\n[restitution]\nlaw = "walton"\ne = 0.9\nbeta0 = 0.5\n'
     '[dsmc]\nparticles = 2000\nt_end = 0.2\n'),
    ("dsmc-mode", "dsmc", 1, '[run]\nsolver = "dsmc"\n[grains]\nprofile = "mode"\n[domain]\ndimensions = 1\n'
     '[dsmc]\nparticles = 2000\nt_end = 0.2\n'),
    ("dsmc-sine", "dsmc", 1, '[run]\nsolver = "dsmc"\n[background]\ndensity = 1.0\nprofile = "isobaric_sine"\n'
     '[domain]\ndimensions = 1\nboundaries = ["diffuse"]\n[dsmc]\nparticles = 2000\nt_end = 0.2\n'),
    ("edmd-defaults", "edmd", 3, '[run]\nsolver = "edmd"\n[edmd]\npacking_fraction = 0.1\n'),
    ("edmd-walls", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 100\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "constant"\ne = 0.9\n'
     '[walls]\ndirections = ["x"]\n[profiles]\n'),
    ("edmd-boltzmann", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 100\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "constant"\ne = 0.9\n'
     '[heating]\nmodel = "boltzmann"\n'),
    ("edmd-shear", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 400\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "constant"\ne = 0.9\n'
     '[heating]\nmodel = "air_table"\nacceleration = 1.0\nprofile = "shear"\n[transport]\n'),
    # the defaults that are rules of other keys, each where it gives another value than the
    # plain default (mutation audit of the EDMD reader): the power law's contact time, the
    # per-wall keys after the both-walls keys, the slab axis after a wall in y, the biased
    # component after axis = "x"
    ("edmd-power", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 100\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "power"\nbeta = 0.05\n'),
    ("edmd-driven-walls", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 100\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "constant"\ne = 0.9\n'
     '[walls]\ndirections = ["y"]\nrestitution = 0.9\ndriving_speed = 0.5\n[profiles]\n'),
    ("edmd-shear-x", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 400\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "constant"\ne = 0.9\n'
     '[heating]\nmodel = "air_table"\nacceleration = 1.0\nprofile = "shear"\naxis = "x"\n'),
    ("edmd-walton", "edmd", 2, '[run]\nsolver = "edmd"\n[edmd]\ndimensions = 2\nparticles = 100\n'
     'packing_fraction = 0.2\nequilibrate = 1\ncollisions = 2\n[restitution]\nlaw = "walton"\ne = 0.9\nbeta0 = 0.5\n'),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--grainbath", required=True)
    ap.add_argument("--doc", required=True)
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    rows = parse_doc(a.doc)
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    compared, failures, uncompared = set(), [], set()
    for name, solver, dims, text in RUNS:
        case = os.path.join(a.work, name)
        os.makedirs(case)
        with open(os.path.join(case, "case.toml"), "w") as f:
            f.write(text)
        out = os.path.join(a.work, name + "-out")
        r = subprocess.run([a.grainbath, "run", case, "--out", out, "-q", "--set", "run.threads=1"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            failures.append(f"{name}: the run failed ({r.returncode}):\n{r.stderr}")
            continue
        with h5py.File(os.path.join(out, "results.h5"), "r") as h:
            params = {k: toml_value(v.decode() if isinstance(v, bytes) else str(v))
                      for k, v in h["parameters"].attrs.items()}
        given = set()
        sec = None
        for line in text.splitlines():
            m = re.match(r"\[(\w+)\]", line)
            if m:
                sec = m.group(1)
            elif "=" in line:
                given.add(f"{sec}.{line.split('=')[0].strip()}")
        for (doc_solver, key), default in rows.items():
            if key in given:
                continue
            if key not in params and key != "restitution.mu":
                continue
            want = expected(default, params, dims)
            if want is None:
                uncompared.add(f"{key} ({default})")
                continue
            if key not in params:
                if not (key == "restitution.mu" and params.get("restitution.law") == "walton"):
                    continue  # a key this run does not read
                got = math.inf  # mu's default, infinity, is recorded as the key's absence
            else:
                got = params[key]
            if isinstance(want, float) and isinstance(got, list):
                want = [want]
            if not same(want, got):
                failures.append(f"{name}: {key}: docs/CASE_FILE.md says default {default!r} = {want!r}, "
                                f"the run used {got!r}")
            compared.add(key)
    print(f"compared {len(compared)} documented defaults: {', '.join(sorted(compared))}")
    print(f"not values, not compared: {', '.join(sorted(uncompared))}")
    for f in failures:
        print("FAIL:", f)
    # the rows this test exists for: if the parser stops finding them, it compares nothing
    must = {"dsmc.dt", "dsmc.t_end", "dsmc.particles", "dsmc.collision_group", "dsmc.rebalance_every",
            "sampling.every", "sampling.steady_from", "sampling.histogram_range", "sampling.histogram_bins",
            "sampling.field_batches", "sampling.mode_fit_to", "domain.length", "domain.cells",
            "domain.wall_temperature", "grains.amplitude", "background.amplitude", "restitution.q",
            "restitution.mu", "restitution.beta", "restitution.delta", "restitution.crossover",
            "grains.rotational_temperature", "edmd.particles", "edmd.dimensions", "edmd.equilibrate",
            "edmd.collisions", "edmd.aspect", "sampling.interval", "sampling.gr_max", "sampling.gr_bin",
            "walls.restitution", "profiles.slabs", "heating.temperature", "heating.bias", "transport.slabs",
            "transport.fit_inner", "edmd.rotational_temperature", "edmd.contact_time", "profiles.axis",
            "walls.restitution_low", "walls.driving_speed_high", "restitution.e"}
    missing = must - compared
    if missing:
        print("FAIL: documented defaults not compared (the table or the runs changed):", ", ".join(sorted(missing)))
    return 1 if failures or missing else 0


if __name__ == "__main__":
    sys.exit(main())
