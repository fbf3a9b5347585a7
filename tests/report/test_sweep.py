#!/usr/bin/python3
"""report_sweep: a 3x2 sweep of a homogeneous DSMC case over background.mass_ratio and
background.knudsen (review 4), then its sweep.png (scripts/plot_sweep.py) and `grainbath
report`:

1. both plot against the same key, by the rule of docs/OUTPUT.md (the numeric swept key with
   the most values: mass_ratio), and `--x KEY` chooses another in both; a KEY that is no
   swept key is refused with exit 2 and one line naming the swept keys;
2. no legend covers a plotted point, and every legend lies within the saved image;
3. under each plot, (simulation − theory)/σ for each theory, with ±2σ guides; the report's
   tables give the σ values, none where the run's error is flagged (no plateau) or unchecked;
4. scripts/*.py without their arguments print a usage line and exit 2 (no traceback);
5. sweep.md of the homogeneous sweep has no theory.hydro.* column.

Exit 77 (ctest SKIP) only when /usr/bin/python3 lacks numpy, matplotlib or h5py."""
import argparse
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys

try:
    import numpy as np
    import matplotlib
    import h5py  # noqa: F401
except ImportError as e:
    print(f"SKIP: {sys.executable} lacks {e.name} (install python3-matplotlib python3-h5py)")
    sys.exit(77)
matplotlib.use("Agg")
import matplotlib.image  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python"))

# homogeneous DSMC in a medium; 200 samples in the window: the plateau test judges the errors
CASE = """[run]
solver = "dsmc"
seed = 4
[grains]
density = 1.0
temperature = 0.97
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
particles = 600
dt = 0.02
t_end = 6.0
[sampling]
every = 0.02
steady_from = 1.0
"""

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print(f"FAIL: {what}")


def load_plot_sweep():
    spec = importlib.util.spec_from_file_location("plot_sweep", os.path.join(ROOT, "scripts", "plot_sweep.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def check_legends(fig, image, what, dpi=110):
    """No legend over a data point of any axes; every legend inside the saved image `image`
    (written at `dpi`, with bbox_inches="tight": the image spans fig.get_tightbbox, padded)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    tight = fig.get_tightbbox(renderer)  # inches
    height_px, width_px = matplotlib.image.imread(image).shape[:2]
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    check(legends, f"{what}: no legend")
    for leg in legends:
        box = leg.get_window_extent(renderer)
        for ax in fig.axes:
            for line in ax.lines:
                if line.get_transform() != ax.transData:
                    continue  # a guide in axes coordinates (axhline)
                xy = np.asarray(line.get_xydata(), dtype=float)
                xy = xy[np.all(np.isfinite(xy), axis=1)]
                if not len(xy):
                    continue
                px = ax.transData.transform(xy)
                inside = ((px[:, 0] >= box.x0) & (px[:, 0] <= box.x1) & (px[:, 1] >= box.y0) & (px[:, 1] <= box.y1))
                check(not inside.any(), f"{what}: the legend covers {int(inside.sum())} point(s) of "
                                        f"'{line.get_label()}'")
        inch = box.transformed(fig.dpi_scale_trans.inverted())
        # the saved image: the tight box (and a 0.1 in pad); the legend within it
        check(inch.x0 >= tight.x0 - 1e-6 and inch.x1 <= tight.x1 + 1e-6 and inch.y0 >= tight.y0 - 1e-6
              and inch.y1 <= tight.y1 + 1e-6, f"{what}: the legend is outside the figure's tight box")
        check(width_px / dpi >= tight.width - 0.05 and height_px / dpi >= tight.height - 0.05,
              f"{what}: the saved image ({width_px}x{height_px} px) is smaller than the figure's content "
              f"({tight.width:.2f}x{tight.height:.2f} in): something is clipped")


def _get(summary, key):
    node = summary
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


class CaptureContext:
    """The report's plotting context, keeping each figure (saved as the real one saves it)."""

    def __init__(self, report_dir):
        from grainbath_report.plotting import Context
        os.makedirs(report_dir, exist_ok=True)
        self.ctx = Context(report_dir)
        self.figures = {}
        self.saved = self.ctx.saved

    def save(self, fig, name):
        path = self.ctx.save(fig, name)
        self.figures[name] = (fig, path)
        return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--grainbath", required=True)
    ap.add_argument("--cases", required=True)
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    env = dict(os.environ, GRAINBATH_REPORT_STRICT="1")
    case = os.path.join(a.work, "case")
    os.makedirs(case)
    with open(os.path.join(case, "case.toml"), "w") as f:
        f.write(CASE)

    # 4. the scripts' usage (before anything slow)
    for script in ("plot_sweep.py", "seed_scatter.py", "hcs_a2_a3.py", "free_cooling_dt_scan.py",
                   "bench-edmd-table.py"):
        r = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", script)], capture_output=True, text=True)
        check(r.returncode == 2 and r.stderr.startswith("usage:") and "Traceback" not in r.stderr,
              f"{script} without arguments: exit {r.returncode}, stderr {r.stderr[-300:]!r}")
    r = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "hcs_sonine_series.py"), "x"],
                       capture_output=True, text=True)
    check(r.returncode == 2 and "Traceback" not in r.stderr, f"hcs_sonine_series.py x: exit {r.returncode}")

    sweep = os.path.join(a.work, "sweep")
    r = subprocess.run([a.grainbath, "sweep", case, "--out", sweep, "-j", "2", "-q",
                        "--set", "background.mass_ratio=0.3,0.5,0.7", "--set", "background.knudsen=0.05,0.1"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        print(f"FAIL: the sweep failed ({r.returncode}): {r.stderr[-1000:]}")
        return 1
    variants = sorted(d for d in os.listdir(sweep) if d.startswith("variant-") and not d.endswith(".log"))
    check(len(variants) == 6, f"{len(variants)} variants, expected 6")

    # 5. sweep.md: no column of the hydrodynamic limit in a homogeneous sweep
    md = open(os.path.join(sweep, "sweep.md")).read()
    head = md.splitlines()[0]
    check("temperature.mean" in head and "theory.equilibrium.sonine.T" in head and "theory.hydro" not in head,
          f"sweep.md header: {head}")

    # 1. + 2. + 3. sweep.png
    plot_sweep = load_plot_sweep()
    for x, expected in ((None, "background.mass_ratio"), ("background.knudsen", "background.knudsen")):
        fig = plot_sweep.make_figure(sweep, x)
        png = os.path.join(a.work, f"sweep-{expected}.png")
        plot_sweep.save_figure(fig, png)
        xlabels = [ax.get_xlabel() for ax in fig.axes if ax.get_xlabel()]
        check(xlabels and all(l == expected for l in xlabels), f"sweep.png (--x {x}): x axis {xlabels}, expected {expected}")
        check_legends(fig, png, f"sweep.png (--x {x})")
        # the σ panel under T#: guides at 0 and ±2
        guides = sorted(l.get_ydata()[0] for l in fig.axes[1].lines[:3])
        check(guides == [-2.0, 0.0, 2.0], f"sweep.png: σ guides at {guides}")
    r = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "plot_sweep.py"), sweep, "--x", "dsmc.dt"],
                       capture_output=True, text=True)
    check(r.returncode == 2 and "not a swept key" in r.stderr and "background.mass_ratio" in r.stderr
          and "Traceback" not in r.stderr, f"plot_sweep.py --x dsmc.dt: exit {r.returncode}, {r.stderr!r}")
    r = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "plot_sweep.py"), sweep], capture_output=True,
                       text=True)
    check(r.returncode == 0 and os.path.isfile(os.path.join(sweep, "sweep.png")), f"plot_sweep.py: {r.stderr!r}")

    # 1. the report: the same x axis, --x, a refused --x
    r = subprocess.run([a.grainbath, "report", sweep], capture_output=True, text=True, env=env)
    check(r.returncode == 0, f"report failed ({r.returncode}): {r.stderr[-2000:]}")
    rmd = open(os.path.join(sweep, "report", "report.md")).read()
    check("Plotted against `background.mass_ratio`, one series per value of `background.knudsen`" in rmd,
          "the report is not plotted against background.mass_ratio")
    r = subprocess.run([a.grainbath, "report", sweep, "--x", "background.knudsen", "--out",
                        os.path.join(a.work, "report-knudsen")], capture_output=True, text=True, env=env)
    check(r.returncode == 0, f"report --x failed ({r.returncode}): {r.stderr[-2000:]}")
    kmd = open(os.path.join(a.work, "report-knudsen", "report.md")).read()
    check("Plotted against `background.knudsen`, one series per value of `background.mass_ratio`" in kmd,
          "report --x background.knudsen is not plotted against it")
    before = sorted(os.listdir(a.work))
    r = subprocess.run([a.grainbath, "report", sweep, "--x", "dsmc.dt", "--out", os.path.join(a.work, "refused")],
                       capture_output=True, text=True, env=env)
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    check(r.returncode == 2 and len(lines) == 1 and "--x dsmc.dt: not a swept key" in lines[0]
          and "background.mass_ratio, background.knudsen" in lines[0] and sorted(os.listdir(a.work)) == before,
          f"report --x dsmc.dt: exit {r.returncode}, stderr {r.stderr!r}")
    r = subprocess.run([a.grainbath, "report", "--help"], capture_output=True, text=True)
    check("--x" in r.stdout, "grainbath report --help does not list --x")

    # 3. σ: one run's error flagged (no plateau), another's unjudged, the others' judged good
    # (set so in a copy: whether short runs reach a plateau is chance); only the four get σ
    flagged = os.path.join(a.work, "flagged")
    shutil.copytree(sweep, flagged, ignore=shutil.ignore_patterns("report"))
    sums = {}
    plateau = {}
    for i, v in enumerate(variants):
        p = os.path.join(flagged, v, "summary.json")
        s = json.load(open(p))
        check(s["temperature"].get("stderr_plateau") is not None, f"{v}: temperature.stderr unjudged")
        s["temperature"]["stderr_plateau"] = [False, None, True][min(i, 2)]
        if i == 1:
            del s["temperature"]["stderr_plateau"]
        plateau[v] = ["0", "", "1"][min(i, 2)]
        json.dump(s, open(p, "w"))
        sums[v] = s
    tsv = os.path.join(flagged, "sweep.tsv")
    lines = open(tsv).read().splitlines()
    col = lines[0].split("\t").index("temperature.stderr_plateau")
    for j in range(1, len(lines)):
        cells = lines[j].split("\t")
        cells[col] = plateau[cells[0]]
        lines[j] = "\t".join(cells)
    open(tsv, "w").write("\n".join(lines) + "\n")
    fig = plot_sweep.make_figure(flagged)
    n = sum(int(np.isfinite(np.asarray(l.get_ydata(), dtype=float)).sum()) for l in fig.axes[1].lines[3:])
    check(n == 4 * 4, f"sweep.png: {n} σ points under T#, expected 4 runs x 4 theories (2 runs' errors not usable)")
    from grainbath_report import sweep as sweep_mod
    from grainbath_report.document import write_markdown
    cctx = CaptureContext(os.path.join(a.work, "flagged-report"))
    sections = sweep_mod.build([os.path.join(flagged, v) for v in variants], cctx, base=flagged)
    write_markdown(os.path.join(a.work, "flagged-report", "report.md"), "t", "", sections)
    fmd = open(os.path.join(a.work, "flagged-report", "report.md")).read()
    for name, (fig, path) in cctx.figures.items():
        check_legends(fig, path, f"report {name}")
    fig, _ = cctx.figures["sweep_temperature_mean"]
    check(len(fig.axes) == 2, f"report T# plot: {len(fig.axes)} axes, expected the plot and its σ panel")
    axr = fig.axes[1]
    n = sum(int(np.isfinite(np.asarray(l.get_ydata(), dtype=float)).sum()) for l in axr.lines[3:])
    # the theories of T# the report compares (sweep.DSMC_QUANTITIES), all in every run here
    nt = sum(1 for t in sweep_mod.DSMC_QUANTITIES[0][4] if all(_get(sums[v], t[0]) is not None for v in variants))
    check(nt == 6, f"{nt} theories of T# in the summaries, expected 6")
    check(n == 4 * nt, f"report T# σ panel: {n} points, expected 4 runs x {nt} theories (2 runs' errors not usable)")
    tsec = fmd[fmd.index('<a id="sweep-temperature-mean"></a>'):]
    tsec = tsec[:tsec.find('<a id="', 10)]
    check(tsec.count("(σ: no plateau)") == nt and tsec.count("(σ: unchecked)") == nt,
          "report T# table: the flagged and the unjudged run's σ are not withheld")
    check(len(re.findall(r"\([+-][0-9.]+σ\)", tsec)) == 4 * nt, f"report T# table: not {4 * nt} σ distances")
    from grainbath_report.document import fmt
    s = sums[variants[2]]
    d = (s["temperature"]["mean"] - s["theory"]["equilibrium"]["sonine"]["T"]) / s["temperature"]["stderr"]
    check(f"{fmt(s['theory']['equilibrium']['sonine']['T'])} ({d:+.1f}σ)" in tsec,
          f"report T# table lacks the Sonine root's distance {d:+.1f}σ of {variants[2]}")

    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    print("report_sweep: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
