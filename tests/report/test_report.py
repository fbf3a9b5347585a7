#!/usr/bin/python3
"""report_smoke: run tiny versions of the shipped DSMC cases, run `grainbath report` on each,
and check report.md, report.html and the PNGs: every PNG referenced exists and is a real
image, report.html embeds each of them, and report.md quotes the key numbers of
summary.json in the report's number format.  Exit 77 (ctest SKIP) only when /usr/bin/python3
lacks numpy, matplotlib or h5py."""
import argparse
import json
import os
import re
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

# (case, overrides, sections the report must have, summary keys report.md must quote)
CASES = [
    ("relaxation", ["dsmc.particles=3000", "dsmc.t_end=0.6", "dsmc.dt=0.004", "sampling.every=0.02",
                    "sampling.steady_from=0.3"],
     ["overview", "temperature", "velocity", "steady", "a2", "distribution", "energy", "appendix"],
     ["temperature.mean", "temperature.stderr", "temperature.final", "a2.mean", "a2.final", "velocity.final",
      "theory.equilibrium.maxwellian.T", "theory.equilibrium.grad.T", "theory.equilibrium.sonine.T",
      "theory.equilibrium.sonine.a2", "theory.expansion.first_order.T", "theory.rates.momentum"]),
    ("equilibrium", ["dsmc.particles=2000", "dsmc.t_end=3", "dsmc.dt=0.02", "sampling.steady_from=1"],
     ["overview", "temperature", "steady", "a2", "distribution", "appendix"],
     ["temperature.mean", "temperature.stderr", "a2.mean", "theory.equilibrium.sonine.T",
      "theory.expansion.second_order_grad.T"]),
    ("free-cooling", ["dsmc.particles=3000", "dsmc.t_end=3", "dsmc.dt=0.02", "sampling.steady_from=1"],
     ["overview", "temperature", "a2", "distribution", "appendix"],
     ["temperature.final", "a2.mean", "theory.haff.temperature_at_t_end", "theory.haff.temperature_at_t_end_no_a2",
      "theory.haff.a2_van_noije_ernst", "theory.hcs.a2_sonine2"]),
    ("hot-walls", ["dsmc.particles=4000", "dsmc.t_end=1", "sampling.steady_from=0.5", "sampling.field_batches=2"],
     ["overview", "temperature", "a2", "distribution", "energy", "profiles", "appendix"],
     ["temperature.mean", "temperature.stderr", "a2.mean", "energy.wall_input_per_grain"]),
    ("@rough", [], ["overview", "temperature", "rough", "energy", "appendix"],
     ["temperature.final", "rotation.R", "theory.rough.rough_model_A.Ttr_at_t_end",
      "theory.rough.rough_model_E.Trot_at_t_end"]),
    ("@mode", [],  # spatial DSMC: a decaying density mode (case written below)
     ["overview", "temperature", "mode", "profiles", "appendix"],
     ["mode.decay_rate", "mode.decay_rate_stderr", "theory.hydro.decay_rate", "theory.hydro.decay_rate_kinetic"]),
]

EDMD_CASE = """[run]
solver = "edmd"
seed = 9
[edmd]
dimensions = 2
particles = 256
packing_fraction = 0.3
equilibrate = 5
collisions = 20
[restitution]
law = "constant"
e = 0.9
[heating]
model = "white_noise"
kick = 0.05
[sampling]
trajectory_interval = 10
"""
EDMD_SECTIONS = ["overview", "eos", "edmd-series", "gr", "velocity-correlations", "edmd-distribution",
                 "normal-speed", "snapshot", "appendix"]
EDMD_KEYS = ["pressure.Z", "pressure.Z_stderr", "theory.Z", "pressure.g_contact", "g_r.contact_fit"]

MODE_CASE = """[run]
solver = "dsmc"
seed = 5
[domain]
dimensions = 1
length = [2.0]
cells = [16]
[grains]
temperature = 1.0
profile = "mode"
amplitude = 0.3
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.1
[restitution]
law = "power"
beta = 0.2
delta = 0.2
[dsmc]
particles = 6000
dt = 0.01
t_end = 1.5
[sampling]
every = 0.05
steady_from = 0.5
mode_fit_from = 0.2
"""

# rough grains in free cooling (Walton's rule): the energy budget must include the spin
# energy, (3/2) Trot per grain (before 2026-12-05 the plotted residual reached 0.15)
ROUGH_CASE = """[run]
solver = "dsmc"
seed = 3
[grains]
temperature = 1.0
rotational_temperature = 0.0
[restitution]
law = "walton"
e = 0.8
beta0 = 0.4
mu = 0.5
[dsmc]
particles = 3000
dt = 0.01
t_end = 2.0
[sampling]
every = 0.05
steady_from = 1.0
"""
WRITTEN_CASES = {"mode": MODE_CASE, "rough": ROUGH_CASE}

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print(f"FAIL: {what}")


def fmt(x):
    # the report's number format (python/grainbath_report/document.py: fmt)
    return str(x) if isinstance(x, int) else f"{x:.6g}"


def get(summary, key):
    node = summary
    for part in key.split("."):
        node = node[part]
    return node


def get_opt(summary, key):
    try:
        return get(summary, key)
    except (KeyError, TypeError):
        return None


def check_edmd_series(grainbath, out, env):
    """EDMD's time series: /timeseries/t and the rest under /timeseries (DSMC's layout), the
    former /series/<name> (/series/time for t) soft links to them reading the same data; and
    the report still plots results.h5 of older builds, which have /series only."""
    import h5py
    import numpy as np
    path = os.path.join(out, "results.h5")
    with h5py.File(path, "r") as h:
        check(isinstance(h.get("timeseries/t"), h5py.Dataset), "edmd: /timeseries/t missing")
        names = list(h["timeseries"]) if "timeseries" in h else []
        check("timeseries" in h and "units" in h["timeseries"].attrs, "edmd: /timeseries lacks its units attribute")
        check({"t", "temperature", "Z", "loss_rate", "collision_frequency"} <= set(names),
              f"edmd: /timeseries has {names}")
        for n in names:
            old = "series/" + ("time" if n == "t" else n)
            link = h.get(old, getlink=True)
            check(isinstance(link, h5py.SoftLink) and link.path == f"/timeseries/{n}",
                  f"edmd: /{old} is not a soft link to /timeseries/{n} ({link!r})")
            check(old in h and np.array_equal(h[old][()], h[f"timeseries/{n}"][()]),
                  f"edmd: /{old} does not read /timeseries/{n}")
    if not names:
        return
    # an older build's layout: the datasets under /series, time axis "time", no /timeseries
    legacy = out + "-series-layout"
    shutil.rmtree(legacy, ignore_errors=True)
    shutil.copytree(out, legacy, ignore=shutil.ignore_patterns("report"))
    with h5py.File(os.path.join(legacy, "results.h5"), "r+") as h:
        del h["series"]
        h.create_group("series")
        for n in list(h["timeseries"]):
            h.move(f"timeseries/{n}", "series/" + ("time" if n == "t" else n))
        del h["timeseries"]
    r = subprocess.run([grainbath, "report", legacy], capture_output=True, text=True, env=env)
    md_path = os.path.join(legacy, "report", "report.md")
    check(r.returncode == 0 and os.path.isfile(md_path) and '<a id="edmd-series"></a>' in open(md_path).read(),
          f"edmd: no time-series section for the former /series layout ({r.returncode}): {r.stderr.strip()[-500:]}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--grainbath", required=True)
    ap.add_argument("--cases", required=True)
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    env = dict(os.environ, GRAINBATH_REPORT_STRICT="1")

    cases = list(CASES)
    # EDMD, once the CLI runs it (`grainbath check` rejects solver = "edmd" before that)
    edmd_dir = os.path.join(a.work, "edmd-case")
    os.makedirs(edmd_dir)
    with open(os.path.join(edmd_dir, "case.toml"), "w") as f:
        f.write(EDMD_CASE)
    r = subprocess.run([a.grainbath, "check", edmd_dir], capture_output=True, text=True)
    if r.returncode == 0:
        cases.append(("@edmd", [], EDMD_SECTIONS, EDMD_KEYS))
    else:
        print(f"note: this grainbath does not run solver = \"edmd\" yet ({r.stderr.strip().splitlines()[0] if r.stderr.strip() else r.returncode}); EDMD part skipped")

    for case, sets, sections, keys in cases:
        case_dir = os.path.join(a.cases, case)
        if case.startswith("@"):  # a case written here
            case = case[1:]
            case_dir = os.path.join(a.work, case + "-case")
            if not os.path.isdir(case_dir):
                os.makedirs(case_dir)
                with open(os.path.join(case_dir, "case.toml"), "w") as f:
                    f.write(WRITTEN_CASES[case])
        out = os.path.join(a.work, case)
        cmd = [a.grainbath, "run", case_dir, "--out", out, "-q", "--set", "run.threads=1"]
        for s in sets:
            cmd += ["--set", s]
        r = subprocess.run(cmd, capture_output=True, text=True)
        check(r.returncode == 0, f"{case}: grainbath run failed ({r.returncode}): {r.stderr.strip()[-500:]}")
        if r.returncode:
            continue
        r = subprocess.run([a.grainbath, "report", out], capture_output=True, text=True, env=env)
        check(r.returncode == 0, f"{case}: grainbath report failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
        rep = os.path.join(out, "report")
        md_path, html_path = os.path.join(rep, "report.md"), os.path.join(rep, "report.html")
        check(os.path.isfile(md_path) and os.path.isfile(html_path), f"{case}: report.md / report.html missing")
        if failures:
            continue
        md = open(md_path).read()
        html = open(html_path).read()
        pngs = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", md)
        check(len(pngs) >= 3, f"{case}: only {len(pngs)} plots in report.md")
        for p in pngs:
            path = os.path.join(rep, p)
            ok = os.path.isfile(path) and os.path.getsize(path) > 5000
            check(ok, f"{case}: {p} missing or suspiciously small")
            if ok:
                with open(path, "rb") as f:
                    check(f.read(8) == b"\x89PNG\r\n\x1a\n", f"{case}: {p} is not a PNG")
        check(html.count('src="data:image/png;base64,') == len(pngs),
              f"{case}: report.html embeds {html.count('data:image/png;base64,')} images, report.md has {len(pngs)}")
        check("src=\"http" not in html and "<script" not in html, f"{case}: report.html is not self-contained")
        for sec in sections:
            check(f'<a id="{sec}"></a>' in md, f"{case}: section '{sec}' missing from report.md")
        summary = json.load(open(os.path.join(out, "summary.json")))
        for k in keys:
            v = get(summary, k)
            check(fmt(v) in md, f"{case}: report.md does not quote {k} = {fmt(v)}")
        # every leaf of summary.json appears in the appendix table, with its key
        def leaves(prefix, node):
            if isinstance(node, dict):
                for kk, vv in node.items():
                    yield from leaves(f"{prefix}.{kk}" if prefix else kk, vv)
            else:
                yield prefix, node
        for k, v in leaves("", summary):
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                check(f"| `{k}` | {fmt(v)} |" in md, f"{case}: appendix lacks {k} = {fmt(v)}")
        # the window errors are marked as the CLI's run table marks them: flagged (no plateau) or,
        # without a flag, too few samples to judge (DSMC only)
        for ek in ("temperature.stderr", "a2.stderr"):
            if summary.get("solver") != "dsmc" or get_opt(summary, ek) is None:
                continue
            flag = get_opt(summary, ek + "_plateau")
            if flag is False:
                check("(no plateau)" in md, f"{case}: {ek} flagged (no plateau) but report.md does not say so")
            elif flag is None:
                check("(few samples: unchecked)" in md,
                      f"{case}: {ek} has no plateau flag but report.md does not mark it unchecked")
        if "energy" in sections:  # the plotted budget closes (rough grains: with the spin energy)
            m = re.search(r"\| largest relative residual of the plotted budget[^|]*\| \(this plot\) \| ([^ |]+) \|", md)
            check(m is not None and abs(float(m.group(1))) < 1e-9,
                  f"{case}: the plotted energy budget does not close: {m.group(1) if m else 'no residual row'}")
        if case == "free-cooling":  # review 2, A3 and B10
            haff = summary["theory"]["haff"]
            check(haff["temperature_at_t_end"] != haff["temperature_at_t_end_no_a2"],
                  f"{case}: Haff's law with and without a2 coincide")
            check("Haff's law, Maxwellian cooling rate" in md and "Haff's law with the van Noije-Ernst a₂" in md,
                  f"{case}: report.md does not name both Haff laws")
            check("steady temperature T (window mean)" not in md and "homogeneous steady state" not in md,
                  f"{case}: report.md calls the cooling gas steady")
        if case == "hot-walls":  # diffuse walls: the homogeneous T#, a2 are no prediction for the box
            check('<a id="steady"></a>' not in md and "at a glance" not in md and
                  "closure (`theory.equilibrium.sonine.T`)" not in md and
                  "Sonine closure (`theory.equilibrium.sonine.a2`)" not in md,
                  f"{case}: report.md compares the walled box with the homogeneous theory")
        if case_dir == edmd_dir:  # the trajectory's layout as the report checks it against H5MD 1.1
            check("The snapshot layout conforms to H5MD 1.1" in md, f"{case}: H5MD layout problems (see report.md)")
            check_edmd_series(a.grainbath, out, env)
            check("/series/time  -> /timeseries/t" in md, f"{case}: the appendix does not list the /series links")
            # heated inelastic grains: the elastic EOS is a reference, with no distance in σ
            # (run-table audit 2026-12-06, docs/reviews/run-table-audit.md)
            eos = [ln for ln in md.splitlines() if "elastic EOS (a reference, not this run's theory)" in ln]
            check(len(eos) == 1 and " σ" not in eos[0], f"{case}: the glance compares Z with the elastic EOS in σ: {eos}")
        if os.path.isfile(os.path.join(out, "fields.xdmf")):
            check("fields.xdmf checked:" in md and "fields.xdmf problems" not in md,
                  f"{case}: fields.xdmf does not match results.h5 (see report.md)")
        print(f"ok: {case}: {len(pngs)} plots, {len(keys)} key numbers checked")

    # a sweep: runs below one directory differing in one parameter -> one report against it
    sweep = os.path.join(a.work, "sweep")
    for eps in ("0.1", "0.3"):
        r = subprocess.run([a.grainbath, "run", os.path.join(a.cases, "equilibrium"), "--out",
                            os.path.join(sweep, f"eps-{eps}"), "-q", "--set", "run.threads=1", "--set",
                            f"background.knudsen={eps}", "--set", "dsmc.particles=2000", "--set", "dsmc.t_end=2",
                            "--set", "dsmc.dt=0.02", "--set", "sampling.steady_from=0.5"], capture_output=True, text=True)
        check(r.returncode == 0, f"sweep run eps={eps} failed: {r.stderr.strip()[-500:]}")
    r = subprocess.run([a.grainbath, "report", sweep], capture_output=True, text=True, env=env)
    check(r.returncode == 0, f"sweep report failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
    md_path = os.path.join(sweep, "report", "report.md")
    if os.path.isfile(md_path):
        md = open(md_path).read()
        check('<a id="sweep-temperature-mean"></a>' in md and "`background.knudsen`" in md,
              "sweep report lacks T# against background.knudsen")
        # 75 samples in each window: too few to test for a plateau, so unjudged and marked
        s01 = json.load(open(os.path.join(sweep, "eps-0.1", "summary.json")))
        check("stderr_plateau" not in s01["temperature"] and "(few samples: unchecked)" in md,
              "sweep report does not mark the short windows' errors unchecked")
        for eps in ("0.1", "0.3"):
            t = json.load(open(os.path.join(sweep, f"eps-{eps}", "summary.json")))["temperature"]["mean"]
            check(fmt(t) in md, f"sweep report does not quote T# = {fmt(t)} of eps = {eps}")
        pngs = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", md)
        check(pngs and all(os.path.isfile(os.path.join(sweep, "report", p)) for p in pngs), "sweep plots missing")
        print(f"ok: sweep: {len(pngs)} plots")
    else:
        check(False, "sweep report.md missing")

    # replicas: a seed sweep (run.threads given once: a setting, not an axis) -> ensemble.json
    # and, in the folder's report, the replica statistics with the scatter error
    ens = os.path.join(a.work, "ensemble")
    r = subprocess.run([a.grainbath, "sweep", os.path.join(a.cases, "equilibrium"), "--out", ens, "-j", "1",
                        "--set", "run.seed=1,2,3", "--set", "run.threads=1", "--set", "dsmc.particles=2000",
                        "--set", "dsmc.t_end=2", "--set", "dsmc.dt=0.02", "--set", "sampling.steady_from=0.5"],
                       capture_output=True, text=True)
    check(r.returncode == 0 and os.path.isfile(os.path.join(ens, "ensemble.json")),
          f"seed sweep without ensemble.json ({r.returncode}): {r.stderr.strip()[-500:]}")
    r = subprocess.run([a.grainbath, "report", ens], capture_output=True, text=True, env=env)
    md_path = os.path.join(ens, "report", "report.md")
    if r.returncode == 0 and os.path.isfile(md_path):
        md = open(md_path).read()
        ts = [json.load(open(os.path.join(ens, d, "summary.json")))["temperature"]["mean"]
              for d in sorted(os.listdir(ens)) if d.startswith("variant-") and not d.endswith(".log")]
        mean = sum(ts) / len(ts)
        check("## Ensemble of 3 replicas" in md and fmt(mean) in md,
              f"ensemble report lacks the replica mean T# = {fmt(mean)}")
        print("ok: ensemble report")
    else:
        check(False, f"ensemble report failed ({r.returncode}): {r.stderr.strip()[-1000:]}")

    # a directory without results: non-zero exit, one clear line on stderr
    empty = os.path.join(a.work, "empty")
    os.makedirs(empty)
    r = subprocess.run([a.grainbath, "report", empty], capture_output=True, text=True)
    check(r.returncode != 0, "report on an empty directory exited 0")
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    check(len(lines) == 1 and "results.h5" in lines[0], f"report on an empty directory: stderr {r.stderr!r}")

    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    print("report_smoke: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
