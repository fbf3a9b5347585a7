"""Sections for the homogeneous DSMC solver (solver = "dsmc", /timeseries, /histogram, /theory)."""
import math

import numpy as np

from .common import deviation, fmt_err, free_cooling, homogeneous_state, lower_bound
from .document import Section, fmt, fmt_pm
from .plotting import SIM, SIM_POINTS, plt, subplots, theory_style

CLOSURES = ("maxwellian", "grad", "sonine")
T_UNIT = "E"
TIME_LABEL = "time t  [λ/√(E/m)]"


def _is_dsmc(run):
    return run.solver == "dsmc" and run.has("timeseries/t", "timeseries/temperature")


def _particles(run):
    n = run.param("dsmc.particles")
    return int(n) if isinstance(n, (int, float)) else None


def _shade_window(ax, run, t):
    t0 = run.param("sampling.steady_from")
    if isinstance(t0, (int, float)) and t0 < t[-1]:
        ax.axvspan(t0, t[-1], color="0.85", alpha=0.5, lw=0, label="averaging window")


def _running(x, k):
    """Centred running mean over k samples ('valid' part only)."""
    return np.convolve(x, np.ones(k) / k, mode="valid")


def _transient_end(t, y, frac=0.02):
    """End of the initial transient of a theory curve, when it is short compared with the run
    (None otherwise): the first time after which |y - y_end| stays below frac * |y0 - y_end|."""
    change = abs(y[0] - y[-1])
    if len(t) < 10 or change == 0:
        return None
    outside = np.nonzero(np.abs(y - y[-1]) > frac * change)[0]
    t_rel = t[outside[-1] + 1] if len(outside) and outside[-1] + 1 < len(t) else t[-1]
    if t_rel > 0.2 * t[-1]:
        return None
    return min(t[-1], max(2.0 * t_rel, t[min(len(t) - 1, 8)]))


def _free_cooling(run):
    return run.has("theory/haff/temperature")


# ---------------------------------------------------------------------------------------
def temperature(run, ctx):
    """T(t) beside the closures' relaxation ODEs (or Haff's law for free cooling)."""
    if not _is_dsmc(run):
        return None
    t = run.arr("timeseries/t")
    T = run.arr("timeseries/temperature")
    N = _particles(run)
    s = Section("Temperature T(t): simulation and theory", "temperature")
    if _free_cooling(run) and homogeneous_state(run):  # (walls: Haff's law is no prediction)
        return _temperature_haff(run, ctx, s, t, T, N)
    have = [c for c in CLOSURES if run.has(f"theory/{c}/temperature")]
    th = {c: run.arr(f"theory/{c}/temperature") for c in have}
    ref = "sonine" if "sonine" in have else (have[0] if have else None)
    if ref is None:
        return _temperature_alone(run, ctx, s, t, T)
    zoom = _transient_end(t, th[ref])
    fig = plt.figure(figsize=(10.0, 6.4))
    gs = fig.add_gridspec(2, 2 if zoom else 1, height_ratios=[2.0, 1.2])
    axes = [fig.add_subplot(gs[0, 0])] + ([fig.add_subplot(gs[0, 1])] if zoom else [])
    for k, ax in enumerate(axes):
        if k == 0:
            _shade_window(ax, run, t)
        sel = slice(None) if k == 0 else t <= zoom
        ax.plot(t[sel], T[sel], **dict(SIM, marker="o" if k else None, ms=3, label="DSMC"))
        for c in have:
            ax.plot(t[sel], th[c][sel], **theory_style(c))
        ax.set_xlabel(TIME_LABEL)
        ax.set_ylabel(f"temperature T  [{T_UNIT}]")
        ax.set_title("Whole run" if zoom and k == 0 else ("Initial relaxation (zoom)" if k else
                                                                 "Grain temperature: DSMC vs moment closures"))
    axes[0].legend(loc="best")
    axr = fig.add_subplot(gs[1, :])
    if ref:
        d = T - th[ref]
        if N:
            noise = T * math.sqrt(2.0 / (3.0 * N))
            axr.fill_between(t, -noise, noise, color="0.85", lw=0, label="±1σ noise of one DSMC sample, T√(2/3N)")
        k = len(t) // 40
        axr.plot(t, d, color="0.55" if k >= 4 else "black", lw=0.8 if k >= 4 else 1.1, label=f"DSMC − {ref}")
        if k >= 4:
            axr.plot(_running(t, k), _running(d, k), color="black", lw=1.8,
                     label=f"DSMC − {ref}, running mean of {k} samples")
        for c in have:
            if c != ref:
                axr.plot(t, th[c] - th[ref], **theory_style(c, label=f"{c} − {ref}"))
        axr.axhline(0, **theory_style(ref, label=f"{ref} (reference)"))
    axr.set_xlabel(TIME_LABEL)
    axr.set_ylabel(f"T − T_{ref}  [{T_UNIT}]")
    axr.set_title(f"Difference from the {ref} closure")
    axr.legend(loc="upper right", ncol=2, fontsize=7.5)
    fig_path = ctx.save(fig, "temperature")
    s.figure(fig_path, "T(t) from DSMC (black) beside the relaxation ODEs of the moment closures, started from "
                       "the same initial state" + (" (right: the initial relaxation enlarged)" if zoom else "") +
                       f"; lower panel: everything minus the {ref} closure, with the DSMC sampling noise of a "
                       "single sample in grey. The grey band in the upper panel is the window averaged for the "
                       "steady values.")
    if not have:
        s.text("No closure relaxation curves in results.h5 (the closures do not apply to these parameters, "
               "or `sampling.relaxation_theory = false`).")
    rows = []
    for c in have:
        th = run.arr(f"theory/{c}/temperature")
        d = T - th
        rows.append([c, fmt(float(np.max(np.abs(d)))), fmt(float(t[np.argmax(np.abs(d))])),
                     fmt(float(np.sqrt(np.mean(d ** 2))))])
    if rows:
        s.table(["closure", "max |T_DSMC − T_closure|", "at t", "rms difference"], rows)
    return s


def _temperature_alone(run, ctx, s, t, T):
    """No relaxation curves (spatial run, or the closures do not apply): T(t) with the steady roots
    when the state is homogeneous (uniform background, no diffuse walls or open faces: then the
    homogeneous T# is the reference)."""
    fig, ax = subplots(figsize=(7.5, 4.2))
    _shade_window(ax, run, t)
    ax.plot(t, T, **dict(SIM, label="DSMC, whole domain"))
    uniform = homogeneous_state(run)
    shown = []
    if uniform:
        for c in CLOSURES:
            v = run.num(f"theory.equilibrium.{c}.T")
            if v is not None:
                ax.axhline(v, **theory_style(c, label=f"{theory_style(c)['label']}: steady T# = {v:.5g}"))
                shown.append(c)
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel(f"temperature T  [{T_UNIT}]")
    ax.set_title("Grain temperature" + (" beside the homogeneous steady roots" if shown else ""))
    ax.legend(loc="best", fontsize=8)
    s.figure(ctx.save(fig, "temperature"),
             "Grain temperature over the whole domain (black)" +
             (", beside the steady temperatures T# of the closures for a homogeneous gas in this (uniform) "
              "background; the grey band is the averaging window." if shown else
              "; no closure relaxation curves were written for this run (spatial run, or the closures do not "
              "apply to these parameters)." + ("" if uniform else
              " The background profile or the walls (diffuse or open faces) make the state inhomogeneous: "
              "the homogeneous T# describes at most a bulk far from them (profiles below).")))
    if shown:
        Tm, Te = run.num("temperature.mean"), run.num("temperature.stderr")
        s.table(["source", "T  [E]", "theory − DSMC"],
                [["DSMC, window mean (`temperature.mean`)", fmt_pm(Tm, Te), ""]] +
                [[f"{c} closure (`theory.equilibrium.{c}.T`)", fmt(run.num(f"theory.equilibrium.{c}.T")),
                  deviation(Tm, Te, run.num(f"theory.equilibrium.{c}.T"))] for c in shown])
    return s


def _temperature_haff(run, ctx, s, t, T, N):
    # /theory/haff/temperature: Haff's law with the cooling rate of the homogeneous cooling
    # state, ζ₀(1 + 3a₂/16), a₂ van Noije-Ernst; /theory/haff/temperature_no_a2: with the
    # Maxwellian rate ζ₀ (docs/OUTPUT.md)
    haff_a2 = run.arr("theory/haff/temperature")
    haff = run.arr("theory/haff/temperature_no_a2") if run.has("theory/haff/temperature_no_a2") else None
    zeta0 = run.num("theory.haff.zeta0")
    if haff is None and zeta0 is not None:  # results written before the Maxwellian curve was stored
        T0 = float(haff_a2[0])
        haff = T0 / (1.0 + 0.5 * zeta0 * math.sqrt(T0) * t) ** 2
    ref = haff if haff is not None else haff_a2
    # /theory/haff/temperature_sonine2 (since 2026-12-06): the second Sonine cooling rate
    # ζ₀ ζ/ζ₀ (docs/closures.md eq. H10), the one the DSMC's late cooling rate matches (docs/dsmc.md D4)
    haff_s2 = run.arr("theory/haff/temperature_sonine2") if run.has("theory/haff/temperature_sonine2") else None
    fig, (ax, axr) = subplots(2, 1, figsize=(7.0, 6.0), sharex=True, gridspec_kw=dict(height_ratios=[2.2, 1]))
    ax.plot(t, T, **SIM)
    if haff is not None:
        ax.plot(t, haff, **theory_style("haff", label="Haff's law, Maxwellian cooling rate ζ₀"))
    ax.plot(t, haff_a2, **theory_style("sonine", label="Haff's law, cooling rate ζ₀(1 + 3a₂/16), a₂ van Noije-Ernst"))
    if haff_s2 is not None:
        ax.plot(t, haff_s2, **theory_style("hcs", label="Haff's law, second Sonine cooling rate (a₂, a₃)"))
    ax.set_yscale("log")
    ax.set_ylabel(f"temperature T  [{T_UNIT}]  (log scale)")
    ax.set_title("Free cooling: DSMC vs Haff's law")
    ax.legend(loc="best")
    axr.plot(t, T / ref, **SIM)
    if haff is not None:
        axr.plot(t, haff_a2 / haff, **theory_style("sonine", label="with a₂ correction"))
        if haff_s2 is not None:
            axr.plot(t, haff_s2 / haff, **theory_style("hcs", label="second Sonine"))
    axr.axhline(1, **theory_style("haff" if haff is not None else "sonine", lw=1.2))
    axr.set_xlabel(TIME_LABEL)
    axr.set_ylabel("T / T_Haff (Maxwellian)" if haff is not None else "T / T_Haff (with a₂)")
    s.figure(ctx.save(fig, "temperature"),
             "Free cooling: T(t) from DSMC (black) beside Haff's law T₀/(1 + ζ√T₀ t/2)² with the Maxwellian "
             "cooling rate ζ = ζ₀ = 4n(1 − e²)/(3√(πm)) (dashed) and with the homogeneous cooling state's rate "
             "ζ = ζ₀(1 + 3a₂/16), a₂ of van Noije and Ernst (dotted)"
             + (", and with the second Sonine rate ζ₀(1 + 3a₂/16 + a₃/64 + …) (dash-dotted; docs/closures.md "
                "eq. H10), which the measured late cooling rate matches (docs/dsmc.md D4)" if haff_s2 is not None else "")
             + "; lower panel: ratio to "
             + ("the Maxwellian Haff's law." if haff is not None else "Haff's law with a₂."))
    rows = [["T(t_end), DSMC", fmt(float(T[-1])), ""]]
    for label, key, curve in [("Haff, Maxwellian cooling rate", "theory.haff.temperature_at_t_end_no_a2", haff),
                              ("Haff with the van Noije-Ernst a₂", "theory.haff.temperature_at_t_end", haff_a2),
                              ("Haff with the second Sonine cooling rate", "theory.haff.temperature_at_t_end_sonine2",
                               haff_s2)]:
        v = run.num(key)
        if v is not None:
            rows.append([f"T(t_end), {label} (`{key}`)", fmt(v), deviation(float(T[-1]), None, v)])
        elif curve is not None:
            rows.append([f"T(t_end), {label}", fmt(float(curve[-1])), deviation(float(T[-1]), None, float(curve[-1]))])
    s.table(["quantity", "value", "theory − DSMC"], rows)
    return s


# ---------------------------------------------------------------------------------------
def velocity(run, ctx):
    """Mean velocity u(t) beside the closures (momentum relaxation towards u_B)."""
    if not _is_dsmc(run) or not run.has("timeseries/velocity"):
        return None
    t = run.arr("timeseries/t")
    u = run.arr("timeseries/velocity").reshape(len(t), 3)
    uB = run.vec3("background.velocity")
    have = [c for c in CLOSURES if run.has(f"theory/{c}/velocity")]
    th = {c: run.arr(f"theory/{c}/velocity").reshape(len(t), 3) for c in have}
    T = run.arr("timeseries/temperature")
    N = _particles(run)
    s = Section("Mean velocity u(t): simulation and theory", "velocity")
    dev = np.linalg.norm(u - uB, axis=1)
    floor = np.sqrt(3.0 * T / (run.param("grains.mass", 1.0) * N)) if N else np.zeros_like(t)
    moving = any(np.max(np.abs(th[c] - uB)) > 0 for c in have) or dev[0] > 10 * floor[0]
    if not moving:
        s.text(f"The grains start at the background velocity u_B = {list(uB)} and theory keeps them there; "
               f"DSMC's |u − u_B| stays at the statistical floor √(3T/(mN)) ≈ {fmt(float(np.mean(floor)), 3)} "
               f"(measured rms {fmt(float(np.sqrt(np.mean(dev ** 2))), 3)}). No plot.")
        s.table(["quantity", "value  [√(E/m)]"], [["|u − u_B| at t_end, DSMC (`velocity.final`)",
                                                   fmt(run.num("velocity.final"))]])
        return s
    fig, (ax, axl) = subplots(1, 2, figsize=(10.0, 4.2))
    comp_style = [dict(), dict(alpha=0.6), dict(alpha=0.35)]
    for d, name in enumerate("xyz"):
        ax.plot(t, u[:, d], color="black", lw=1.2, ls="-", label=f"DSMC u_{name}", **comp_style[d])
    for c in have:
        for d in range(3):
            if np.max(np.abs(th[c][:, d] - uB[d])) > 0 or d == 0:
                ax.plot(t, th[c][:, d], **theory_style(c, label=f"{theory_style(c)['label']}, u_{'xyz'[d]}"))
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("mean velocity u_i  [√(E/m)]")
    ax.set_title("Components")
    ax.legend(loc="best", fontsize=7)
    axl.semilogy(t, np.maximum(dev, 1e-300), **SIM)
    for c in have:
        axl.semilogy(t, np.maximum(np.linalg.norm(th[c] - uB, axis=1), 1e-300), **theory_style(c))
    if N:
        axl.semilogy(t, floor, color="0.5", lw=1, ls="-", label="noise floor √(3T/(mN))")
    rate = run.num("theory.rates.momentum")
    if rate and dev[0] > 10 * floor[0]:
        axl.semilogy(t, dev[0] * np.exp(-rate * t), color="#CC79A7", ls=(0, (1, 1)), lw=1.2,
                     label=f"|u(0) − u_B| e^(−λt), λ = {rate:.4g}")
    axl.set_xlabel(TIME_LABEL)
    axl.set_ylabel("|u − u_B|  [√(E/m)]  (log scale)")
    axl.set_title("Distance from the background velocity")
    top = max(float(np.max(dev)), 1e-12)
    axl.set_ylim(max(top * 1e-6, 1e-12 if not N else float(np.min(floor)) * 0.1), top * 3)
    axl.legend(loc="best", fontsize=7)
    s.figure(ctx.save(fig, "velocity"),
             "Mean grain velocity. Left: components from DSMC (black, x solid dark) beside the closures; "
             "right: |u − u_B| on a log scale with the closures, the linear momentum relaxation rate "
             "(`theory.rates.momentum`) and the statistical floor √(3T/(mN)) below which DSMC is noise.")
    rows = [["|u − u_B| at t_end, DSMC (`velocity.final`)", fmt(run.num("velocity.final"))]]
    for c in have:
        rows.append([f"|u − u_B| at t_end, {c}", fmt(float(np.linalg.norm(th[c][-1] - uB)))])
    if rate:
        rows.append(["momentum relaxation rate λ (`theory.rates.momentum`)", fmt(rate)])
    s.table(["quantity", "value  [√(E/m)]"], rows)
    return s


# ---------------------------------------------------------------------------------------
def _plot_sampled(ax, run, t, series, key):
    """A sampled DSMC series (a2, a3) on ax: the averaging window shaded, the samples (with a
    running mean of len/40 samples once that is >= 4) and the window mean `KEY.mean` ± its
    `KEY.stderr` as a dashed line from `sampling.steady_from`. Returns (mean, stderr)."""
    _shade_window(ax, run, t)
    k = len(t) // 40
    if k >= 4:
        ax.plot(t, series, color="0.6", lw=0.8, label="DSMC")
        ax.plot(_running(t, k), _running(series, k), color="black", lw=2.0, label=f"DSMC, running mean of {k} samples")
    else:
        ax.plot(t, series, **dict(SIM, label="DSMC"))
    m, e = run.num(f"{key}.mean"), run.num(f"{key}.stderr")
    t0 = run.param("sampling.steady_from")
    if m is not None and isinstance(t0, (int, float)):
        ax.hlines(m, t0, t[-1], color="black", lw=1.2, ls="--",
                  label=f"DSMC window mean {fmt_err(run, m, f'{key}.stderr', 4)}")
    return m, e


def sonine_a2(run, ctx):
    """a2(t) beside the Sonine closure (or van Noije-Ernst for free cooling)."""
    if not _is_dsmc(run) or not run.has("timeseries/a2"):
        return None
    t = run.arr("timeseries/t")
    a2 = run.arr("timeseries/a2")
    N = _particles(run)
    s = Section("Non-Gaussianity: Sonine coefficient a₂(t)", "a2")
    fig, ax = subplots(figsize=(7.0, 4.2))
    m, e = _plot_sampled(ax, run, t, a2, "a2")
    homogeneous = homogeneous_state(run)  # else the homogeneous a2 is no prediction for the domain
    if run.has("theory/sonine/a2") and homogeneous:
        ax.plot(t, run.arr("theory/sonine/a2"), **theory_style("sonine"))
    vne = run.num("theory.haff.a2_van_noije_ernst") if homogeneous else None
    if vne is not None:
        ax.axhline(vne, **theory_style("haff", label=f"van Noije-Ernst a₂ = {vne:.4g}"))
    hcs2 = run.num("theory.hcs.a2_sonine2") if homogeneous else None
    if hcs2 is not None:
        ax.axhline(hcs2, **theory_style("hcs", label=f"second Sonine a₂ = {hcs2:.4g}"))
    a2eq = run.num("theory.equilibrium.sonine.a2") if homogeneous else None
    if a2eq is not None and not run.has("theory/sonine/a2"):
        ax.axhline(a2eq, **theory_style("sonine", label=f"Sonine closure, steady a₂ = {a2eq:.4g}"))
    ax.axhline(0, color="black", lw=0.6)
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("a₂ = 3⟨c⁴⟩/(5⟨c²⟩²) − 1  [dimensionless]")
    ax.set_title("Second Sonine coefficient")
    ax.legend(loc="best")
    s.figure(ctx.save(fig, "a2"),
             f"a₂(t) measured in DSMC (black; one sample has noise ≈ √(8/15N)"
             f"{' = ' + fmt(math.sqrt(8 / (15 * N)), 2) if N else ''})" +
             (" beside the Sonine closure's a₂(t) and its steady value (or the van Noije-Ernst value of the "
              "homogeneous cooling state)." if homogeneous else
              "; the state is inhomogeneous (background profile or walls), so no homogeneous theory is drawn."))
    low = lower_bound(run, "a2.stderr")  # the run's error is unreliable: no σ distances from it
    rows = [["DSMC, window mean (`a2.mean`)", fmt_err(run, m, "a2.stderr"), ""]]
    if a2eq is not None:
        rows.append(["Sonine closure (`theory.equilibrium.sonine.a2`)", fmt(a2eq), deviation(m, None if low else e, a2eq)])
    if vne is not None:
        rows.append(["van Noije-Ernst (`theory.haff.a2_van_noije_ernst`)", fmt(vne), deviation(m, None if low else e, vne)])
    if hcs2 is not None:
        rows.append(["second Sonine, cooling state (`theory.hcs.a2_sonine2`; docs/closures.md Sec. H)", fmt(hcs2),
                     deviation(m, None if low else e, hcs2)])
    s.table(["source", "a₂", "theory − DSMC"], rows,
            caption=("Block averaging of a₂ reached no plateau (summary `a2.stderr_plateau` = false): a₂ is "
                     "correlated over a good part of the window (then its error is a lower bound; in free cooling "
                     "the scatter of replicas was 1.9 times it) or drifts through it (a transient: see "
                     "`sampling.steady_from`). Independent replicas (`grainbath sweep CASE --set "
                     "run.seed=1,2,...`) give the error."
                     if low else None))
    _sonine_a3(run, ctx, s, t, N, homogeneous)
    return s


def _sonine_a3(run, ctx, s, t, N, homogeneous):
    """a3(t), the third Sonine coefficient 1 + 3a₂ − ⟨c⁶⟩/(105 (T/m)³) (docs/closures.md eq. H2),
    beside the second Sonine a3 of the cooling state (runs written since 2026-12-06)."""
    if not run.has("timeseries/a3"):
        return
    a3 = run.arr("timeseries/a3")
    fig, ax = subplots(figsize=(7.0, 3.6))
    m, e = _plot_sampled(ax, run, t, a3, "a3")
    hcs3 = run.num("theory.hcs.a3_sonine2") if homogeneous else None
    if hcs3 is not None:
        ax.axhline(hcs3, **theory_style("hcs", label=f"second Sonine a₃ = {hcs3:.4g}"))
    ax.axhline(0, color="black", lw=0.6)
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("a₃ = 1 + 3a₂ − ⟨c⁶⟩/(105⟨c²⟩³/27)")
    ax.set_title("Third Sonine coefficient")
    ax.legend(loc="best")
    s.figure(ctx.save(fig, "a3"),
             f"a₃(t) measured in DSMC (one sample has noise ≈ √(16/35N)"
             f"{' = ' + fmt(math.sqrt(16 / (35 * N)), 2) if N else ''}, a Maxwellian's a₃ being 0)" +
             (" beside the second Sonine a₃ of the homogeneous cooling state." if hcs3 is not None else "."))
    if m is None:
        return
    low = lower_bound(run, "a3.stderr")
    rows = [["DSMC, window mean (`a3.mean`)", fmt_err(run, m, "a3.stderr"), ""]]
    if hcs3 is not None:
        rows.append(["second Sonine, cooling state (`theory.hcs.a3_sonine2`; docs/closures.md Sec. H)", fmt(hcs3),
                     deviation(m, None if low else e, hcs3)])
    s.table(["source", "a₃", "theory − DSMC"], rows,
            caption=("Block averaging of a₃ reached no plateau (`a3.stderr_plateau` = false): take the error "
                     "from independent replicas." if low else None))


# ---------------------------------------------------------------------------------------
STEADY_ROWS = [
    ("DSMC (window mean ± 1σ)", "temperature.mean", None),
    ("root, local-Maxwellian closure", "theory.equilibrium.maxwellian.T", "maxwellian"),
    ("root, Grad closure", "theory.equilibrium.grad.T", "grad"),
    ("root, Sonine closure", "theory.equilibrium.sonine.T", "sonine"),
    ("ε-expansion, 1st order", "theory.expansion.first_order.T", "exp1"),
    ("ε-expansion, 2nd order (Maxwellian)", "theory.expansion.second_order_maxwellian.T", "exp2m"),
    ("ε-expansion, 2nd order (Grad)", "theory.expansion.second_order_grad.T", "exp2g"),
]


def steady_temperature(run, ctx):
    """Steady T# from DSMC beside the closures' roots and the ε-expansions."""
    if not _is_dsmc(run) or run.num("theory.equilibrium.maxwellian.T") is None:
        return None
    if not homogeneous_state(run):  # imposed profile or walls: the homogeneous T# does not describe the domain
        return None
    Tm, Te = run.num("temperature.mean"), run.num("temperature.stderr")
    if Tm is None:
        return None
    s = Section("Steady temperature T#: DSMC beside the roots and expansions", "steady")
    rows, pts = [], []
    for label, key, kind in STEADY_ROWS:
        v = run.num(key)
        if v is None:
            continue
        pts.append((label, v, kind))
        rows.append([label, f"`{key}`", fmt_pm(Tm, Te) if kind is None else fmt(v),
                     "" if kind is None else deviation(Tm, Te, v)])
    fig, ax = subplots(figsize=(7.5, 0.5 * len(pts) + 2.0))
    y = np.arange(len(pts))[::-1]
    colours = {"maxwellian": "#0072B2", "grad": "#E69F00", "sonine": "#009E73",
               "exp1": "#CC79A7", "exp2m": "#56B4E9", "exp2g": "#D55E00"}
    markers = {"maxwellian": "s", "grad": "D", "sonine": "^", "exp1": "v", "exp2m": "<", "exp2g": ">"}
    for yi, (label, v, kind) in zip(y, pts):
        if kind is None:
            if Te:
                ax.axvspan(Tm - 2 * Te, Tm + 2 * Te, color="0.88", lw=0, label="DSMC ± 2σ")
                ax.axvspan(Tm - Te, Tm + Te, color="0.7", lw=0, label="DSMC ± 1σ")
            ax.errorbar([Tm], [yi], xerr=[Te] if Te else None, fmt="o", color="black", ms=6, capsize=4)
        else:
            ax.plot([v], [yi], marker=markers[kind], color=colours[kind], ms=8, ls="none")
            ax.annotate(f"{v:.5g} ({(v - Tm) / Te:+.1f}σ)" if Te else f"{v:.5g}", (v, yi),
                        textcoords="offset points", xytext=(0, 8), ha="center", fontsize=7.5, color=colours[kind])
    vals = [p[1] for p in pts] + ([Tm - 2 * Te, Tm + 2 * Te] if Te else [])
    lo, hi = min(vals), max(vals)
    pad = 0.2 * (hi - lo) if hi > lo else 1e-3 * abs(hi)
    ax.set_xlim(lo - pad, hi + pad)
    ax.set_ylim(-0.7, len(pts) - 0.3)
    ax.set_yticks(y)
    ax.set_yticklabels([p[0] for p in pts])
    ax.set_xlabel(f"steady temperature T#  [{T_UNIT}]")
    ax.set_title("Steady temperature: DSMC (black) vs theory (coloured)")
    if Te:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize=8)
    ax.ticklabel_format(axis="x", useOffset=False)
    s.figure(ctx.save(fig, "steady_temperature"),
             "Steady grain temperature T#: DSMC window mean with 1σ and 2σ bands (std. error from block "
             "averaging) beside the roots of the three closures and the ε-expansions (ε = Knudsen number).")
    s.table(["source", "summary.json key", "T#  [E]", "theory − DSMC (abs., in σ, rel.)"], rows)
    s.text("The DSMC value also carries an O(Δt²) splitting error and an O(1/N) finite-particle bias that the "
           "standard error does not include; a systematic offset of a few σ between DSMC and a closure is "
           "the closure's truncation error only if it persists as Δt → 0 and N → ∞.")
    return s


# ---------------------------------------------------------------------------------------
def _gauss(z):
    return np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)


def _maxwell_speed(z):
    return math.sqrt(2.0 / math.pi) * z * z * np.exp(-0.5 * z * z)


def distribution(run, ctx):
    """f(v) (components and speed) against the Maxwellian and the Sonine-corrected Maxwellian."""
    if not _is_dsmc(run) or not run.has("histogram/component_edges", "histogram/components"):
        return None
    edges = run.arr("histogram/component_edges")
    h = run.arr("histogram/components")
    z = 0.5 * (edges[1:] + edges[:-1])
    w = edges[1] - edges[0]
    a2 = run.num("a2.final")
    N = _particles(run)
    s = Section("Velocity distribution f(v) against the Maxwellian", "distribution")
    zz = np.linspace(edges[0], edges[-1], 600)
    S2c = lambda x: (x ** 4 - 6 * x ** 2 + 3) / 8.0  # 1D marginal of the 3D Sonine polynomial, x = c_i/sqrt(T/m)
    fig, (ax, axl) = subplots(1, 2, figsize=(10.5, 4.3))
    for d, name in enumerate("xyz"):
        for a in (ax, axl):
            a.plot(z, h[d], marker="o", ms=2.8, ls="none", color="black", alpha=[1.0, 0.55, 0.3][d],
                   label=f"DSMC, c_{name}")
    for a in (ax, axl):
        a.plot(zz, _gauss(zz), **theory_style("maxwell_dist"))
        if a2 is not None:
            a.plot(zz, _gauss(zz) * (1 + a2 * S2c(zz)), **theory_style("sonine_dist"))
        a.set_xlabel("velocity component c_i / √(T/m)  [dimensionless]")
    ax.set_ylabel("probability density  [per unit c_i/√(T/m)]")
    ax.set_title("Linear scale")
    axl.set_yscale("log")
    axl.set_ylim(max(1e-7, 0.3 / (N * w) if N else 1e-7), 1.0)
    axl.set_title("Log scale: the tails")
    ax.legend(loc="upper left", fontsize=7)
    s.figure(ctx.save(fig, "distribution_components"),
             "Distribution of each velocity component about the mean, at the end of the run, in units of the "
             "thermal speed √(T/m) (black points, x darkest) beside the unit Maxwellian (dashed) and the "
             "Maxwellian with the first Sonine correction using the measured a₂ (dotted).")
    # relative deviation, components pooled, with Poisson errors
    if N and np.any(_gauss(z) * N * w * 3 >= 20):
        hm = h.mean(axis=0)
        counts = hm * N * w * 3
        g = _gauss(z)
        ok = g * N * w * 3 >= 20
        fig, ax = subplots(figsize=(7.0, 4.0))
        ax.errorbar(z[ok], hm[ok] / g[ok] - 1, yerr=np.sqrt(np.maximum(counts[ok], 1)) / (g[ok] * N * w * 3),
                    fmt="o", ms=3, color="black", capsize=0, lw=0.8, label="DSMC (x, y, z pooled) ± Poisson error")
        zr = zz[(zz >= z[ok].min()) & (zz <= z[ok].max())]
        if a2 is not None:
            ax.plot(zr, a2 * S2c(zr), **theory_style("sonine_dist", label=f"a₂ S₂ with measured a₂ = {a2:.3g}"))
        a2th = run.num("theory.equilibrium.sonine.a2") or run.num("theory.haff.a2_van_noije_ernst")
        if a2th is not None:
            ax.plot(zr, a2th * S2c(zr), color="#D55E00", ls="--", lw=1.4, label=f"a₂ S₂ with theory a₂ = {a2th:.3g}")
        ax.axhline(0, **theory_style("maxwell_dist", lw=1.2))
        ax.set_xlabel("velocity component c_i / √(T/m)  [dimensionless]")
        ax.set_ylabel("f / f_Maxwell − 1  [dimensionless]")
        ax.set_title("Departure from the Maxwellian (bins with ≥ 20 expected grains)")
        ax.legend(loc="best", fontsize=8)
        s.figure(ctx.save(fig, "distribution_deviation"),
                 "Relative departure of the component distribution from the Maxwellian, with Poisson error bars, "
                 "beside the first Sonine correction a₂ (c⁴ − 6c² + 3)/8 (c = c_i/√(T/m)).")
    if run.has("histogram/speed_edges", "histogram/speed"):
        se = run.arr("histogram/speed_edges")
        hs = run.arr("histogram/speed")
        zs = 0.5 * (se[1:] + se[:-1])
        zz = np.linspace(0, se[-1], 400)
        S2 = lambda x: x ** 4 / 8 - 5 * x ** 2 / 4 + 15.0 / 8  # 3D Sonine polynomial in x = |c|/sqrt(T/m)
        fig, ax = subplots(figsize=(7.0, 4.0))
        ax.plot(zs, hs, **SIM_POINTS)
        ax.plot(zz, _maxwell_speed(zz), **theory_style("maxwell_dist", label="Maxwell speed distribution"))
        if a2 is not None:
            ax.plot(zz, _maxwell_speed(zz) * (1 + a2 * S2(zz)), **theory_style("sonine_dist"))
        ax.set_xlabel("speed |c| / √(T/m)  [dimensionless]")
        ax.set_ylabel("probability density  [per unit |c|/√(T/m)]")
        ax.set_title("Speed distribution")
        ax.legend(loc="best")
        s.figure(ctx.save(fig, "distribution_speed"),
                 "Distribution of the peculiar speed |v − u|/√(T/m) at the end of the run beside the Maxwell "
                 "speed distribution √(2/π) c² e^(−c²/2).")
    Th = run.arr("histogram/temperature")
    s.text(f"Histograms taken at t = t_end with T = {fmt(float(np.ravel(Th)[0])) if Th is not None else 'n/a'} E; "
           f"measured a₂ at t_end (`a2.final`) = {fmt(a2)}.")
    return s


# ---------------------------------------------------------------------------------------
ROUGH_MODELS = ("A", "B", "C", "D", "E")
ROUGH_COLOURS = {"A": "#E69F00", "B": "#56B4E9", "C": "#009E73", "D": "#CC79A7", "E": "#D55E00"}


def rough(run, ctx):
    """Rough grains (Walton's rule): Ttr(t) and Trot(t) beside the mean-field models A-E of
    docs/rough.md (integrated from the first sample by the run, /theory/rough_model_X), and the
    ratio R = Trot/Ttr over the averaging window."""
    if not _is_dsmc(run) or not run.has("timeseries/rotational_temperature"):
        return None
    t = run.arr("timeseries/t")
    Ttr = run.arr("timeseries/temperature")
    Trot = run.arr("timeseries/rotational_temperature")
    models = [m for m in ROUGH_MODELS if run.has(f"theory/rough_model_{m}/Ttr", f"theory/rough_model_{m}/Trot")]
    s = Section("Rough grains: translational and rotational temperature", "rough")
    fig, (ax, axr) = subplots(2, 1, figsize=(7.5, 6.0), sharex=True, gridspec_kw=dict(height_ratios=[2, 1]))
    _shade_window(axr, run, t)
    ax.plot(t, Ttr, **dict(SIM, label="DSMC: Ttr"))
    ax.plot(t, Trot, color="0.45", lw=2.0, label="DSMC: Trot")
    for m in models:
        col = ROUGH_COLOURS[m]
        ax.plot(t, run.arr(f"theory/rough_model_{m}/Ttr"), color=col, lw=1.2, ls="--", label=f"model {m}: Ttr")
        ax.plot(t, run.arr(f"theory/rough_model_{m}/Trot"), color=col, lw=1.2, ls=":", label=f"model {m}: Trot")
    ax.set_ylabel(f"temperature  [{T_UNIT}]")
    ax.set_title("Rough grains: DSMC beside the mean-field models A–E" if models else "Rough grains")
    ax.legend(loc="best", fontsize=7, ncol=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        R = np.where(Ttr > 0, Trot / Ttr, np.nan)
    axr.plot(t, R, **dict(SIM, label="DSMC: R = Trot/Ttr"))
    for m in models:
        with np.errstate(divide="ignore", invalid="ignore"):
            Rm = run.arr(f"theory/rough_model_{m}/Trot") / run.arr(f"theory/rough_model_{m}/Ttr")
        axr.plot(t, Rm, color=ROUGH_COLOURS[m], lw=1.2, ls="--", label=f"model {m}")
    axr.set_xlabel(TIME_LABEL)
    axr.set_ylabel("R = Trot/Ttr  [1]")
    axr.legend(loc="best", fontsize=7, ncol=3)
    s.figure(ctx.save(fig, "rough"),
             "Translational (black) and rotational (grey) temperature of the grains, with the mean-field models "
             "A–E (docs/rough.md, R3–R14) integrated from the first sample (dashed: Ttr, dotted: Trot); lower "
             "panel: their ratio R." + ("" if models else " " + "This run wrote no model curves (the models have no "
                                           "background medium: they are written for free cooling only)."))
    Rm, Re = run.num("rotation.R"), run.num("rotation.R_stderr")
    rows = [["DSMC, window mean (`rotation.R`)", fmt_pm(Rm, Re) if Rm is not None else "n/a", ""],
            ["DSMC at t_end (`rotation.R_final`)", fmt(run.num("rotation.R_final")), ""]]
    for m in models:
        tr = run.num(f"theory.rough.rough_model_{m}.Ttr_at_t_end")
        rot = run.num(f"theory.rough.rough_model_{m}.Trot_at_t_end")
        if tr and rot is not None:
            rows.append([f"model {m} at t_end (Trot/Ttr)", fmt(rot / tr), deviation(run.num("rotation.R_final"), None,
                                                                                 rot / tr)])
    s.table(["source", "R = Trot/Ttr", "model − DSMC, both at t_end"], rows)
    Tf, Trf = run.num("temperature.final"), run.num("rotation.Trot_final")
    if models and Tf is not None and Trf is not None:
        s.table(["model", "Ttr(t_end)  [E]", "theory − DSMC", "Trot(t_end)  [E]", "theory − DSMC"],
                [[f"model {m}", fmt(run.num(f"theory.rough.rough_model_{m}.Ttr_at_t_end")),
                  deviation(Tf, None, run.num(f"theory.rough.rough_model_{m}.Ttr_at_t_end")),
                  fmt(run.num(f"theory.rough.rough_model_{m}.Trot_at_t_end")),
                  deviation(Trf, None, run.num(f"theory.rough.rough_model_{m}.Trot_at_t_end"))] for m in models],
                caption="At the end of the run (DSMC: `temperature.final`, `rotation.Trot_final`; one sample, no "
                        "error bar: compare the curves above for the noise).")
    return s


# ---------------------------------------------------------------------------------------
def energy(run, ctx):
    """Energy budget: ΔKE = bath input − inelastic loss (cumulative, per grain)."""
    if not _is_dsmc(run) or not run.has("timeseries/kinetic_energy_per_grain"):
        return None
    t = run.arr("timeseries/t")
    ke = run.arr("timeseries/kinetic_energy_per_grain")  # translational only
    # rough grains (homogeneous runs only): the loss counts the spin energy too and collisions
    # move energy between translation and spin, so the budget is of both: (3/2) Trot per grain
    # (3 rotational degrees of freedom). Before 2026-12-05 the plot left the spin out, and its
    # residual reached 0.15 in rough free cooling though the run's budget closed to 1e-15.
    Trot = run.arr("timeseries/rotational_temperature")
    rough = Trot is not None and len(Trot) == len(ke)
    if rough:
        ke = ke + 1.5 * Trot
    z = np.zeros_like(t)
    terms = []  # (label, signed cumulative series, colour, style)
    for path, label, sign, col, ls in [
            ("bath_energy_input_per_grain", "cumulative bath input", 1, "#E69F00", "--"),
            ("wall_energy_input_per_grain", "cumulative wall input", 1, "#CC79A7", "--"),
            ("inelastic_loss_per_grain", "− cumulative inelastic loss", -1, "#0072B2", "-."),
            ("outflow_energy_per_grain", "− energy carried out by leaving grains", -1, "#56B4E9", "-.")]:
        a = run.arr(f"timeseries/{path}")
        if a is not None and np.any(a):
            terms.append((label, sign * a, col, ls))
    s = Section("Energy budget", "energy")
    fig, (ax, axr) = subplots(2, 1, figsize=(7.0, 5.6), sharex=True, gridspec_kw=dict(height_ratios=[2, 1]))
    ax.plot(t, ke - ke[0], **dict(SIM, label=("ΔE(t), translational + rotational, DSMC" if rough
                                             else "ΔKE(t) = KE(t) − KE(0), DSMC")))
    for label, a, col, ls in terms:
        ax.plot(t, a, color=col, lw=1.4, ls=ls, label=label)
    total = sum((a for _, a, _, _ in terms), z)
    ax.plot(t, total, color="#D55E00", lw=2.2, ls=":", label="sum of the inputs and losses")
    ax.set_ylabel("energy per grain  [E]")
    ax.set_title("Energy bookkeeping (the red dotted line must lie on the black one)")
    ax.legend(loc="best")
    scale = np.maximum.reduce([np.abs(a) for _, a, _, _ in terms] + [np.full_like(t, abs(ke[0]) or 1.0)])
    residual = (ke - ke[0] - total) / scale
    axr.plot(t, residual, color="black", lw=1.0)
    axr.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    axr.set_xlabel(TIME_LABEL)
    axr.set_ylabel("rel. residual  [1]")
    s.figure(ctx.save(fig, "energy"),
             "Cumulative energy exchanged per grain: the change of the kinetic energy equals what the bath (and "
             "walls) gave minus what inelastic grain collisions (and grains leaving) removed, exactly up to "
             "round-off; lower panel: the residual relative to the largest term.")
    rows = [[k, f"`{key}`", fmt(run.num(key))] for k, key in [
        ("bath input per grain", "energy.bath_input_per_grain"),
        ("wall input per grain", "energy.wall_input_per_grain"),
        ("inelastic loss per grain", "energy.inelastic_loss_per_grain"),
        ("relative residual of the budget", "energy.budget_relative_residual")] if run.num(key) is not None]
    rows.append(["largest relative residual of the plotted budget" + (" (spin energy included)" if rough else ""),
                 "(this plot)", fmt(float(np.max(np.abs(residual))))])
    s.table(["quantity", "key", "value"], rows)
    return s


# ---------------------------------------------------------------------------------------
def pressure(run, ctx):
    """Diagonal pressure tensor / (nT) and heat flux: anisotropy during relaxation."""
    if not _is_dsmc(run) or not run.has("timeseries/pressure_tensor"):
        return None
    t = run.arr("timeseries/t")
    P = run.arr("timeseries/pressure_tensor").reshape(len(t), 6)
    T = run.arr("timeseries/temperature")
    n = run.param("grains.density", 1.0)
    s = Section("Pressure tensor and heat flux", "pressure")
    fig, (ax, axq) = subplots(1, 2, figsize=(10.5, 4.0))
    names = ["xx", "yy", "zz", "xy", "xz", "yz"]
    styles = ["-", "--", ":", "-", "--", ":"]
    for k in range(6):
        ax.plot(t, P[:, k] / (n * T) - (k < 3), color="black" if k < 3 else "#0072B2", ls=styles[k], lw=1.2,
                label=f"P_{names[k]}/(nT)" + (" − 1" if k < 3 else ""))
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("P_ij / (n T) − δ_ij  [dimensionless]")
    ax.set_title("Pressure tensor: departure from isotropy")
    ax.legend(loc="best", fontsize=7, ncol=2)
    if run.has("timeseries/heat_flux"):
        q = run.arr("timeseries/heat_flux").reshape(len(t), 3)
        m = run.param("grains.mass", 1.0)
        scale = n * T * np.sqrt(T / m)
        for d in range(3):
            axq.plot(t, q[:, d] / scale, color="black", ls=styles[d], lw=1.2, label=f"q_{'xyz'[d]}/(nT√(T/m))")
        axq.axhline(0, color="0.5", lw=0.8)
        axq.set_xlabel(TIME_LABEL)
        axq.set_ylabel("q_i / (n T √(T/m))  [dimensionless]")
        # zero in a homogeneous steady state; a homogeneous cooling gas has none either
        # (isotropy), but it is not in equilibrium
        axq.set_title("Heat flux (zero in a homogeneous gas)" if free_cooling(run) else "Heat flux (zero in equilibrium)")
        axq.legend(loc="best", fontsize=7)
    s.figure(ctx.save(fig, "pressure"),
             "Kinetic pressure tensor over nT minus the identity (left: diagonal in black, off-diagonal in blue) and reduced "
             "heat flux (right). " +
             ("Both are isotropic/zero in a homogeneous gas, cooling or not (this run cools freely: no steady "
              "state); deviations show noise or inhomogeneity." if free_cooling(run) else
              "Both are isotropic/zero in a homogeneous steady state; deviations during relaxation show the "
              "anisotropy that the closures carry or neglect."))
    return s
