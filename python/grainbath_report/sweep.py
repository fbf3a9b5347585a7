"""Reports over several runs (a parameter sweep): key numbers against the swept parameter,
beside the theory each run computed for its own parameters.

`grainbath report DIR` makes a sweep report when DIR holds no run itself but has run output
directories (results.h5 + summary.json) below it, e.g. DIR/nu-0.1/, DIR/nu-0.2/ or
DIR/*/output/.  The swept parameter is found by comparing the runs' resolved parameters.
"""
import os

import numpy as np

from .axes import choose_x, identity_axes
from .common import UNITS, fmt_err, lower_bound, unchecked
from .data import ReportError, RunData
from .document import Section, fmt, fmt_pm
from .edmd import close_packing, packing_label, z_henderson, z_reference
from .plotting import subplots, theory_style

SKIP_DIRS = ("report",)


def discover(path, depth=3):
    """Output directories (holding results.h5 and summary.json) below path, sorted."""
    found = []
    for root, dirs, files in os.walk(path):
        rel = os.path.relpath(root, path)
        level = 0 if rel == "." else rel.count(os.sep) + 1
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and ".tmp-" not in d
                         and not d.endswith(".previous") and not d.startswith("."))
        if level >= depth:
            dirs[:] = []
        if "results.h5" in files and "summary.json" in files:
            found.append(root)
            dirs[:] = []
    return sorted(found)


# (summary key, error key, label, unit, [(theory key, style name, label)])
DSMC_QUANTITIES = [
    ("temperature.mean", "temperature.stderr", "steady temperature T#", "E", [
        ("theory.equilibrium.maxwellian.T", "maxwellian", "local-Maxwellian root"),
        ("theory.equilibrium.grad.T", "grad", "Grad root"),
        ("theory.equilibrium.sonine.T", "sonine", "Sonine root"),
        ("theory.expansion.first_order.T", None, "ε-expansion, 1st order"),
        ("theory.expansion.second_order_maxwellian.T", None, "ε-expansion, 2nd order (Maxwellian)"),
        ("theory.expansion.second_order_grad.T", None, "ε-expansion, 2nd order (Grad)")]),
    ("a2.mean", "a2.stderr", "Sonine coefficient a₂", "1", [
        ("theory.equilibrium.sonine.a2", "sonine", "Sonine closure"),
        ("theory.haff.a2_van_noije_ernst", "haff", "van Noije-Ernst"),
        ("theory.hcs.a2_sonine2", "hcs", "second Sonine"),
        ("theory.hcs.a2_linear_to_a6", None, "linear Sonine series to a₆")]),
    # a3 (docs/closures.md eq. H2): sampled by every DSMC run since 2026-12-06; theory only for
    # the cooling state
    ("a3.mean", "a3.stderr", "Sonine coefficient a₃", "1", [
        ("theory.hcs.a3_sonine2", "hcs", "second Sonine"),
        ("theory.hcs.a3_linear_to_a6", None, "linear Sonine series to a₆")]),
    ("mode.decay_rate", "mode.decay_rate_stderr", "density-mode decay rate Γ", "√(E/m)/λ", [
        ("theory.hydro.decay_rate", "hydro", "drift-diffusion (paper)"),
        ("theory.hydro.decay_rate_kinetic", None, "drift-diffusion (kinetic)"),
        ("theory.hydro.decay_rate_maxwellian_closure", "maxwellian", "local-Maxwellian closure"),
        ("theory.hydro.decay_rate_grad_closure", "grad", "Grad closure"),
        ("theory.hydro.decay_rate_sonine_closure", "sonine", "Sonine closure")]),
    ("profile.exponent", "profile.exponent_stderr", "profile exponent p (n ∝ T_B^−p)", "1", [
        ("theory.hydro.thermal_diffusion_exponent", "hydro", "drift-diffusion (paper)"),
        ("theory.hydro.thermal_diffusion_exponent_kinetic", None, "drift-diffusion (kinetic)")]),
]
EDMD_QUANTITIES = [
    ("pressure.Z", "pressure.Z_stderr", "compressibility factor Z", "1", [
        ("theory.Z", "eos", "elastic EOS"),
        # written where it predicts the run (homogeneous, undriven; = theory.Z for elastic grains)
        ("theory.Z_enskog", "sonine", "Enskog: (1+e)/2 × the EOS's collisional part")]),
    ("pressure.g_contact", None, "g(σ⁺) from Z", "1", [("theory.g_contact", "eos", "reference EOS")]),
    ("g_r.contact_fit", None, "g(σ⁺) from g(r)", "1", [("theory.g_contact", "eos", "reference EOS")]),
    ("collision.frequency_over_enskog", None, "collision frequency / Enskog", "1", []),
    ("loss.gamma_over_gamma_e", None, "loss rate γ / γ_e", "1", []),
    ("velocity.a2", None, "a₂", "1", []),
    ("haff.ratio", None, "Haff time, measured / theory", "1", []),
]
PARAM_LABELS = {
    "edmd.packing_fraction": "packing fraction ν (2D) or φ (3D)  [dimensionless]",
    "background.knudsen": "Knudsen number ε  [dimensionless]",
    "background.mass_ratio": "mass ratio α = m_B/(m+m_B)  [dimensionless]",
    "background.density": "background density n_B  [1/λ³]",
    "background.temperature": "background temperature T_B  [E]",
    "background.amplitude": "background profile amplitude",
    "grains.density": "grain density n  [1/λ³]",
    "grains.temperature": "initial grain temperature  [E]",
    "grains.amplitude": "initial mode amplitude  [dimensionless]",
    "grains.wavenumber_index": "mode index (k = 2π·index/L_x)",
    "restitution.e": "restitution coefficient e  [dimensionless]",
    "restitution.beta": "restitution β  [dimensionless]",
    "restitution.delta": "restitution exponent δ  [dimensionless]",
    "dsmc.dt": "time step Δt  [λ/√(E/m)]",
    "dsmc.particles": "simulated grains N",
    "dsmc.t_end": "end time  [λ/√(E/m)]",
    "edmd.particles": "grains N",
    "edmd.temperature": "initial temperature  [E]",
}
EXTRA_COLOURS = ["#CC79A7", "#56B4E9", "#D55E00", "#999999"]
EXTRA_STYLES = [(0, (5, 1, 1, 1)), (0, (1, 1)), (0, (3, 1, 1, 1, 1, 1)), "--"]


def distinct_theories(theories, runs):
    """The theories (index, entry) some run has, without one whose every value repeats an earlier
    one's (theory.Z_enskog of elastic grains is theory.Z: one curve, not two on top of each other)."""
    kept = []
    for i, t in enumerate(theories):
        vals = [r.num(t[0]) for r in runs]
        if all(v is None for v in vals):
            continue
        if any(all(v == r.num(k[0]) for v, r in zip(vals, runs)) for _, k in kept):
            continue
        kept.append((i, t))
    return kept


def swept_parameters(runs):
    """Parameters whose resolved values differ between runs (seed and threads excluded)."""
    keys = sorted(set().union(*(r.params.keys() for r in runs)))
    out = []
    for k in keys:
        if k in ("run.seed", "run.threads"):
            continue
        vals = [repr(r.params.get(k)) for r in runs]
        if len(set(vals)) > 1:
            out.append(k)
    return out


def ensemble_section(runs, quantities, paths):
    """Replicas (the runs differ only in seed): each quantity's mean over the R runs with the
    error from their scatter, std/sqrt(R), which holds whatever the correlations inside a run
    (the numbers of `grainbath sweep`'s ensemble.md), beside the runs' own errors combined,
    sqrt(sum stderr^2)/R, and each theory value's distance from the mean in units of the
    scatter error."""
    R = len(runs)
    s = Section(f"Ensemble of {R} replicas", "ensemble")
    rows = []
    for key, err_key, label, unit, theories in quantities:
        v = np.array([r.num(key) for r in runs if r.num(key) is not None], dtype=float)
        v = v[np.isfinite(v)]
        if len(v) < 2:
            continue
        mean, scatter = float(np.mean(v)), float(np.std(v, ddof=1) / np.sqrt(len(v)))
        own = [r.num(err_key) for r in runs if err_key and r.num(err_key) is not None]
        # the error of a mean of independent runs: sqrt(sum s_i^2)/R
        own_err = float(np.sqrt(np.sum(np.square(own))) / len(own)) if own else None
        th = []
        for _, (tkey, _style, tlabel) in distinct_theories(theories, runs):
            tv = [r.num(tkey) for r in runs if r.num(tkey) is not None]
            if tv:
                t = float(np.mean(tv))
                th.append(f"{tlabel} {fmt(t)}" + (f" ({(t - mean) / scatter:+.1f}σ)" if scatter > 0 else ""))
        # runs that flagged their error (no plateau): so is the combination
        low = any(lower_bound(r, err_key) for r in runs)
        unjudged = any(unchecked(r, err_key) for r in runs)
        rows.append([f"{label} [{unit}]", fmt_pm(mean, scatter),
                     fmt(own_err) + (" (no plateau)" if low else " (few samples: unchecked)" if unjudged else "")
                     if own_err is not None else "—",
                     "; ".join(th) or "—"])
    s.text(f"The {R} runs differ only in their seed: they are independent replicas. The mean of each quantity "
           "over them, with the standard error from their scatter (std/√R, honest whatever the correlations "
           "inside a run), beside the runs' own errors combined (√(Σs²)/R): where the scatter "
           "error is the larger, the single-run errors understate the uncertainty.")
    s.table(["quantity", f"mean over {R} ± scatter error", "runs' own errors combined", "theory (distance)"], rows,
            caption="Replica statistics (the same numbers as the sweep's ensemble.md, where `grainbath sweep` "
                    "wrote one).")
    return s


def sweep_axes(runs, base):
    """The swept keys (axes.py): the --set keys of a `grainbath sweep` directory `base` with
    several values (sweep.identity), else the parameters that differ between the runs."""
    axes = identity_axes(base) if base else None
    if not axes or not all(k in r.params for k in axes for r in runs):
        axes = swept_parameters(runs)
    return axes


def sigma_distance(run, key, err_key, tkey):
    """(simulation − theory)/stderr of one run, or (None, why) where no σ distance is shown: no
    error, or an error the run flagged (`<err_key>_plateau` false) or left unjudged (too few
    samples) — the single-run report's rule (common.lower_bound, common.unchecked)."""
    v, t = run.num(key), run.num(tkey)
    e = run.num(err_key) if err_key else None
    if v is None or t is None:
        return None, None
    if not e:
        return None, "no error"
    if lower_bound(run, err_key):
        return None, "no plateau"
    if unchecked(run, err_key):
        return None, "unchecked"
    # the elastic EOS predicts only a homogeneous, undriven gas of elastic grains, where the run
    # wrote theory.Z_enskog equal to it (inelastic grains: Enskog's row; heating, walls: none)
    if tkey == "theory.Z" and run.num("theory.Z_enskog") != t:
        return None, "reference only"
    return (v - t) / e, None


def build(paths, ctx, x=None, base=None):
    """Sections of a sweep report over the runs in `paths` (found below `base`); `x`: the swept key
    to plot against (`grainbath report DIR --x KEY`), default the rule of axes.choose_x."""
    runs = [RunData(p) for p in paths]
    solvers = sorted(set(r.solver for r in runs))
    varied = swept_parameters(runs)
    axes = sweep_axes(runs, base)
    try:
        x_key, group_keys = choose_x({k: [r.params.get(k) for r in runs] for k in axes}, x)
    except ValueError as e:
        for r in runs:
            r.close()
        raise ReportError(str(e))
    sections = []
    s = Section("Runs in this sweep", "runs")
    s.text(" ".join(UNITS.get(sv, "") for sv in solvers))
    s.text(f"{len(runs)} runs (solver{'s' if len(solvers) > 1 else ''} {', '.join(solvers)}). Parameters that differ "
           f"between them: {', '.join(f'`{k}`' for k in varied) or 'none (repeats with different seeds?)'}."
           + (f" Plotted against `{x_key}`" + (f", one series per value of {', '.join(f'`{k}`' for k in group_keys)}"
                                                if group_keys else "") +
              (" (chosen with --x)." if x else " (the swept key with the most values; `--x KEY` chooses another; "
               "docs/OUTPUT.md, \"Sweep directories\").") if x_key else ""))
    candidates = (DSMC_QUANTITIES if "dsmc" in solvers else []) + (EDMD_QUANTITIES if "edmd" in solvers else [])
    quantities = [q for q in candidates if any(r.num(q[0]) is not None for r in runs)]
    headers = ["run"] + [f"`{k}`" for k in varied] + [f"`{q[0]}`" for q in quantities]
    rows = []
    for r in runs:
        rows.append([os.path.relpath(r.out_dir, os.path.commonpath(paths)) if len(paths) > 1 else r.out_dir] +
                    [fmt(r.params.get(k)) if not isinstance(r.params.get(k), list) else str(r.params.get(k))
                     for k in varied] +
                    [fmt_err(r, r.num(q[0]), q[1]) for q in quantities])
    s.table(headers, rows, caption="Key numbers of every run (± std. error where the run gives one; \"no plateau\": "
                                   "the run's blocking reached none, the error is unreliable, see the runs' reports; \"few samples: "
                                   "unchecked\": the window was too short to test for a plateau).")
    have_reports = [r for r in runs if os.path.isfile(os.path.join(r.out_dir, "report", "report.html"))]
    s.text("Each run's own report: `grainbath report RUN_DIR`" +
           (f" (already made for {len(have_reports)} of the runs: RUN_DIR/report/report.html)." if have_reports
            else "."))
    sections.append(s)
    if not varied and len(runs) >= 2:
        sections.append(ensemble_section(runs, quantities, paths))
    if x_key is None:
        for r in runs:
            r.close()
        return sections

    groups = {}
    for r in runs:
        label = ", ".join(f"{k.split('.')[-1]} = {fmt(r.params.get(k))}" for k in group_keys)
        groups.setdefault(label, []).append(r)
    markers = ["o", "s", "D", "^", "v", "<", ">"]
    for qi, (key, err_key, label, unit, theories) in enumerate(quantities):
        # the theories this sweep has, and whether any run's error gives σ distances from them
        present = distinct_theories(theories, runs)
        residuals = bool(err_key and present)
        if residuals:
            fig, (ax, axr) = subplots(2, 1, figsize=(9.5, 6.4), sharex=True, gridspec_kw={"height_ratios": [3, 1.7]})
            axr.axhline(0.0, color="0.4", lw=0.8)  # the guides first: axr.lines[3:] are the distances
            for g in (-2.0, 2.0):
                axr.axhline(g, color="0.55", lw=0.9, ls="--")
        else:
            fig, ax = subplots(figsize=(9.5, 4.6))
            axr = None
        for gi, (glabel, grs) in enumerate(groups.items()):
            grs = sorted(grs, key=lambda r: r.params[x_key])
            xs = np.array([r.params[x_key] for r in grs], dtype=float)
            y = np.array([r.num(key) if r.num(key) is not None else np.nan for r in grs])
            e = np.array([(r.num(err_key) or 0.0) if err_key else 0.0 for r in grs])
            sim_label = "simulation" + (f" ({glabel})" if glabel else "")
            ax.errorbar(xs, y, yerr=e if np.any(e) else None, fmt=markers[gi % len(markers)], color="black", ms=5,
                        mfc="white" if gi % 2 else "black", capsize=3, label=sim_label, zorder=5)
            for ti, (tkey, style, tlabel) in present:
                ty = np.array([r.num(tkey) if r.num(tkey) is not None else np.nan for r in grs])
                if np.all(np.isnan(ty)):
                    continue
                st = theory_style(style) if style else dict(color=EXTRA_COLOURS[ti % len(EXTRA_COLOURS)],
                                                            ls=EXTRA_STYLES[ti % len(EXTRA_STYLES)], lw=1.6)
                st["alpha"] = 1.0 if gi == 0 else 0.55
                st["label"] = (tlabel + (" (each series)" if len(groups) > 1 else "")) if gi == 0 else None
                ax.plot(xs, ty, marker=".", **st)
                if axr is not None:
                    d = np.array([sigma_distance(r, key, err_key, tkey)[0] for r in grs], dtype=float)
                    if np.any(np.isfinite(d)):
                        axr.plot(xs, d, marker=markers[gi % len(markers)], ms=4.5, ls=st["ls"], lw=1.0,
                                 color=st["color"], alpha=st["alpha"], mfc="white" if gi % 2 else st["color"])
        if key == "pressure.Z" and x_key == "edmd.packing_fraction":
            dims = {int(r.param("edmd.dimensions", 3)) for r in runs}
            for D in sorted(dims):
                xs = np.linspace(0, min(0.98 * close_packing(D), 1.1 * max(r.params[x_key] for r in runs)), 300)
                name = "Kolafa-Rottner (Liu 2020)" if D == 2 else "Carnahan-Starling"
                ax.plot(xs, z_reference(D, xs), **theory_style("eos", label=f"elastic EOS, {name}"))
                if D == 2:
                    ax.plot(xs, z_henderson(xs), **theory_style("eos2", label="elastic EOS, Henderson"))
            xlabel = packing_label(min(dims)) + "  [dimensionless]"
        else:
            xlabel = PARAM_LABELS.get(x_key, f"{x_key}  (unit: docs/CASE_FILE.md)")
            if x_key.endswith("particles"):
                ax.set_xscale("log")
        (axr if axr is not None else ax).set_xlabel(xlabel)
        ax.set_ylabel(f"{label}  [{unit}]")
        ax.set_title(f"{label} against {x_key.split('.')[-1]}")
        # outside the axes, to the right: a legend never covers a point (and the report's
        # figures are saved with bbox_inches="tight", so it is not clipped either)
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=7.5)
        if axr is not None:
            axr.set_ylabel("(simulation − theory)/σ")
            lim = max([2.5] + [abs(v) * 1.15 for ln in axr.lines[3:] for v in ln.get_ydata() if np.isfinite(v)])
            axr.set_ylim(-lim, lim)
            if len(axr.lines) == 3:  # no run's error gives σ distances
                axr.text(0.5, 0.5, "no σ distances: every run's error is flagged (no plateau) or unchecked",
                         transform=axr.transAxes, ha="center", va="center", fontsize=8, color="0.3")
        path = ctx.save(fig, f"sweep_{key.replace('.', '_')}")
        sec = Section(f"{label} against `{x_key}`", f"sweep-{key.replace('.', '-')}")
        sec.figure(path, f"{label} from every run (black, ± std. error) beside the theory values each run computed "
                         f"for its own parameters (coloured), against the swept parameter `{x_key}`." +
                   (" Below: (simulation − theory)/σ for each theory (its colour and line style; σ the run's standard "
                    "error), with ±2σ guides; left out where the run's error is flagged (no plateau) or unchecked "
                    "(too few samples to test for a plateau)." if axr is not None else ""))
        if residuals:
            trows = []
            for r in sorted(runs, key=lambda r: (tuple(repr(r.params.get(k)) for k in group_keys), r.params[x_key])):
                if r.num(key) is None:
                    continue
                cells = [fmt(r.params.get(k)) for k in [x_key] + group_keys] + [fmt_err(r, r.num(key), err_key)]
                for _ti, (tkey, _style, _tlabel) in present:
                    t = r.num(tkey)
                    dist, why = sigma_distance(r, key, err_key, tkey)
                    cells.append("—" if t is None else f"{fmt(t)} ({dist:+.1f}σ)" if dist is not None
                                 else f"{fmt(t)} (σ: {why})")
                trows.append(cells)
            sec.table([f"`{k}`" for k in [x_key] + group_keys] + ["simulation"] + [t[1][2] for t in present], trows,
                      caption="Each theory's value and the simulation's distance from it, (simulation − theory)/σ; "
                              "\"σ: no plateau\" or \"σ: unchecked\": the run's error is flagged or unjudged, so no "
                              "distance is given (as in the single-run report).")
        sections.append(sec)
    for r in runs:
        r.close()
    return sections
