"""Sections for the event-driven MD solver (solver = "edmd": /timeseries, /observables, H5MD snapshots).

Reference formulas mirror src/edmd/theory.hpp (units: σ = 1, m = 1, k_B = 1)."""
import math

import numpy as np

from .common import deviation
from .document import Section, fmt, fmt_pm
from .plotting import SIM, SIM_POINTS, plt, subplots, theory_style

TIME_LABEL = "time t  [σ√(m/E)]"


def _is_edmd(run):
    return run.solver == "edmd"


def _dims(run):
    d = run.param("edmd.dimensions", 3)
    return int(d) if isinstance(d, (int, float)) else 3


def _series(run):
    """Group and time-axis name of the time series: /timeseries/t (DSMC's layout, written since
    /series was renamed), else /series/time of results.h5 written by older builds. None when
    neither is there."""
    for group, time in (("timeseries", "t"), ("series", "time")):
        if run.has(f"{group}/{time}", f"{group}/temperature"):
            return group, time
    return None


def _packing(run):
    v = run.param("edmd.packing_fraction")
    return float(v) if isinstance(v, (int, float)) else None


# ---- reference equations of state (src/edmd/theory.hpp) ----------------------------------
def z_henderson(nu):
    return (1 + nu ** 2 / 8) / (1 - nu) ** 2


def z_disk_kr(nu):
    return (1 + nu ** 2 / 8 + nu ** 3 / 18 - 4 * nu ** 4 / 21) / (1 - nu) ** 2


def z_carnahan_starling(phi):
    return (1 + phi + phi ** 2 - phi ** 3) / (1 - phi) ** 3


def z_reference(dims, packing):
    return z_disk_kr(packing) if dims == 2 else z_carnahan_starling(packing)


def close_packing(dims):
    return math.pi / (2 * math.sqrt(3)) if dims == 2 else math.pi / (3 * math.sqrt(2))


def packing_label(dims):
    return "packing fraction ν = nπσ²/4" if dims == 2 else "packing fraction φ = nπσ³/6"


# ---------------------------------------------------------------------------------------
def equation_of_state(run, ctx):
    """Z = PV/(NT) beside the hard-disk / hard-sphere equation of state."""
    if not _is_edmd(run) or run.num("pressure.Z") is None or _packing(run) is None:
        return None
    D, nu = _dims(run), _packing(run)
    Z, Ze = run.num("pressure.Z"), run.num("pressure.Z_stderr")
    e = run.num("restitution.mean_e")
    s = Section("Equation of state: Z against the packing fraction", "eos")
    x = np.linspace(0.0, min(0.99 * close_packing(D), max(0.55 if D == 2 else 0.5, 1.15 * nu)), 300)
    fig, (ax, axr) = subplots(1, 2, figsize=(10.5, 4.3))
    name = "Kolafa-Rottner (Liu 2020)" if D == 2 else "Carnahan-Starling"
    ax.plot(x, z_reference(D, x), **theory_style("eos", label=f"elastic EOS: {name}"))
    if D == 2:
        ax.plot(x, z_henderson(x), **theory_style("eos2", label="elastic EOS: Henderson"))
    if e is not None and e < 1 - 1e-12:
        ax.plot(x, 1 + 0.5 * (1 + e) * (z_reference(D, x) - 1), **theory_style(
            "sonine", label=f"inelastic: 1 + (1+⟨e⟩)/2 (Z_EOS − 1), ⟨e⟩ = {e:.3g}"))
    ax.errorbar([nu], [Z], yerr=[Ze] if Ze else None, fmt="o", color="black", ms=6, capsize=4,
                label=f"EDMD: Z = {fmt_pm(Z, Ze, 5)}")
    ax.set_xlabel(packing_label(D) + "  [dimensionless]")
    ax.set_ylabel("compressibility factor Z = P/(nT)  [dimensionless]")
    ax.set_title(f"{'Hard disks' if D == 2 else 'Hard spheres'}: Z(packing)")
    ax.legend(loc="upper left", fontsize=8)
    # zoom: the measured point relative to the references
    inelastic = e is not None and e < 1 - 1e-12
    Zref = z_reference(D, nu)
    entries = [("EDMD", Z, "black"), (f"EOS: {name}", Zref, "#0072B2")]
    if D == 2:
        entries.append(("EOS: Henderson", z_henderson(nu), "#E69F00"))
    if inelastic:
        entries.append(("inelastic EOS", 1 + 0.5 * (1 + e) * (Zref - 1), "#009E73"))
    yy = np.arange(len(entries))[::-1]
    lab = [en[0] for en in entries]
    for yi, (l, v, c) in zip(yy, entries):
        if l == "EDMD":
            axr.errorbar([v], [yi], xerr=[Ze] if Ze else None, fmt="o", color=c, ms=6, capsize=4)
        else:
            axr.plot([v], [yi], "s", color=c, ms=7)
            if Ze:
                axr.annotate(f"{(v - Z) / Ze:+.1f}σ", (v, yi), textcoords="offset points", xytext=(0, 7),
                             ha="center", fontsize=8, color=c)
    vals = [en[1] for en in entries] + ([Z - Ze, Z + Ze] if Ze else [])
    pad = 0.2 * (max(vals) - min(vals)) or 0.01
    axr.set_xlim(min(vals) - pad, max(vals) + pad)
    axr.set_yticks(yy)
    axr.set_yticklabels(lab)
    axr.set_ylim(-0.7, len(entries) - 0.3)
    axr.set_xlabel("Z  [dimensionless]")
    axr.set_title(f"At {('ν' if D == 2 else 'φ')} = {nu:.4g}")
    axr.ticklabel_format(axis="x", useOffset=False)
    s.figure(ctx.save(fig, "edmd_eos"),
             "Compressibility factor from the collisional virial (black, ± std. error) beside the elastic "
             "equation of state and, for inelastic grains, its (1+⟨e⟩)/2 rescaling of the collisional part. "
             "Right: the same numbers enlarged, with the distance of each reference from EDMD in σ.")
    rows = [["Z, EDMD (`pressure.Z`)", fmt_pm(Z, Ze), ""],
            ["Z, reference EOS (`theory.Z`)", fmt(run.num("theory.Z")), deviation(Z, Ze, run.num("theory.Z"))]]
    if run.num("theory.Z_henderson") is not None:
        rows.append(["Z, Henderson (`theory.Z_henderson`)", fmt(run.num("theory.Z_henderson")),
                     deviation(Z, Ze, run.num("theory.Z_henderson"))])
    Zk = run.num("theory.Z_enskog")  # written where Enskog predicts the run: homogeneous, undriven
    if Zk is not None and Zk != run.num("theory.Z"):
        rows.append(["Z, Enskog: EOS's collisional part × (1+e)/2, collision-weighted e (`theory.Z_enskog`)", fmt(Zk),
                     deviation(Z, Ze, Zk)])
    elif e is not None and e < 1 - 1e-12 and run.num("theory.Z") is not None:
        Zi = 1 + 0.5 * (1 + e) * (run.num("theory.Z") - 1)
        rows.append(["Z, EOS with collisional part × (1+⟨e⟩)/2 (reference: heated or walled grains)", fmt(Zi),
                     deviation(Z, Ze, Zi)])
    for label, key in [("g(σ) from Z (`pressure.g_contact`)", "pressure.g_contact"),
                       ("g(σ) from the EOS (`theory.g_contact`)", "theory.g_contact"),
                       ("g(σ) from the collision rate (`collision.g_contact_from_rate`)", "collision.g_contact_from_rate"),
                       ("g(σ⁺) of g(r) from the collisions, approaching + receding pairs (`g_r.contact_from_collisions`)",
                        "g_r.contact_from_collisions"),
                       ("collision frequency / Enskog (`collision.frequency_over_enskog`)", "collision.frequency_over_enskog"),
                       ("mean restitution ⟨e⟩ (`restitution.mean_e`)", "restitution.mean_e"),
                       ("loss rate γ / γ_e (`loss.gamma_over_gamma_e`)", "loss.gamma_over_gamma_e")]:
        if run.num(key) is not None:
            rows.append([label, fmt(run.num(key)), ""])
    # the pressure on the walls (runs with walls, 2026-12-06): the walls' momentum per unit time and
    # area; in a square or cube walled in every direction it is P L/(L - σ) (docs/edmd.md
    # "Pressure on the walls"), with walls in fewer directions the bulk's normal pressure
    P, Pw = run.num("pressure.P"), run.num("pressure.wall")
    if Pw is not None:
        if P is not None:
            rows.append(["pressure n T Z, n = N/V of the whole box (`pressure.P`)  [E/σ^D]", fmt(P), ""])
        rows.append(["pressure on the walls, their momentum per time and area (`pressure.wall`)  [E/σ^D]", fmt(Pw), ""])
    s.table(["quantity", "value", "theory − EDMD"], rows)
    if Pw is not None:
        s.text("`pressure.wall` needs no volume: it is the pressure of the confined gas. In a square or cube of "
               "side L walled in every direction it equals `pressure.P` · L/(L − σ), the centres filling L − σ "
               "(the virial theorem of the closed box, docs/edmd.md \"Pressure on the walls\").")
    s.text("Z is one point per run. To trace the curve, run the case at several packing fractions into "
           "directories below one folder (`--set edmd.packing_fraction=0.3 --out sweep/nu-0.3`, ...) and "
           "`grainbath report sweep`.")
    return s


# ---------------------------------------------------------------------------------------
def temperature(run, ctx):
    """T(t), Z(t) and the collision frequency; Haff's law for free cooling."""
    layout = _series(run) if _is_edmd(run) else None
    if layout is None:
        return None
    group, time = layout
    t = run.arr(f"{group}/{time}")
    T = run.arr(f"{group}/temperature")
    s = Section("EDMD time series: temperature, pressure, collision rate", "edmd-series")
    haff_t0 = run.num("haff.t0_theory")
    panels = 2 if run.has(f"{group}/Z") else 1
    n = min(len(t), len(T))
    t, T = t[:n], T[:n]
    if haff_t0:
        fig = plt.figure(figsize=(5.4 * panels, 6.0))
        gs = fig.add_gridspec(2, panels, height_ratios=[2, 1])
        ax = fig.add_subplot(gs[0, 0])
        axh = fig.add_subplot(gs[1, 0], sharex=ax)
        axes = [ax] + ([fig.add_subplot(gs[:, 1])] if panels > 1 else [])
    else:
        fig, axes = subplots(1, panels, figsize=(5.2 * panels, 4.2))
        axes = np.atleast_1d(axes)
        ax = axes[0]
    ax.plot(t, T, **SIM)
    if haff_t0:
        T0 = run.num("temperature.initial") or T[0]
        haff = T0 / (1 + t / haff_t0) ** 2
        curves = [("haff", haff_t0, f"Haff, t₀ = {haff_t0:.4g} (with a₂ correction)")]
        t0n = run.num("haff.t0_theory_no_a2")
        if t0n:
            curves.append(("maxwellian", t0n, f"Haff, t₀ = {t0n:.4g} (Maxwellian)"))
        t0m = run.num("haff.t0_measured")
        if t0m:
            curves.append(("fit", t0m, f"fit of T₀/(1+t/t₀)², t₀ = {t0m:.4g}"))
        for style, t0, lab in curves:
            ax.plot(t, T0 / (1 + t / t0) ** 2, **theory_style(style, label=lab))
            axh.plot(t, (T0 / (1 + t / t0) ** 2) / haff, **theory_style(style, label=lab))
        axh.plot(t, T / haff, **SIM)
        ax.set_yscale("log")
        axh.set_xlabel(TIME_LABEL)
        axh.set_ylabel("T / T_Haff (with a₂)  [1]")
        plt.setp(ax.get_xticklabels(), visible=False)
    else:
        Tm, Te = run.num("temperature.mean"), run.num("temperature.stderr")
        if Tm is not None:
            ax.axhline(Tm, color="black", ls="--", lw=1, label=f"mean {fmt_pm(Tm, Te, 4)}")
        Tth = run.num("theory.medium_steady_temperature")
        if Tth is not None:
            ax.axhline(Tth, **theory_style("sonine", label=f"steady T in the medium (theory) = {Tth:.4g}"))
    if not haff_t0:
        ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("temperature T  [E]" + ("  (log scale)" if haff_t0 else ""))
    ax.set_title("Temperature")
    ax.legend(loc="best", fontsize=8)
    if panels > 1:
        Zs = run.arr(f"{group}/Z")
        axz = axes[1]
        # per-interval series have one value fewer than the sample times: plot at interval midpoints
        tz = 0.5 * (t[:-1] + t[1:]) if len(Zs) == len(t) - 1 else t[:len(Zs)]
        axz.plot(tz, Zs[:len(tz)], **dict(SIM, lw=0.9, label="Z per sampling interval"))
        Zm = run.num("pressure.Z")
        if Zm is not None:
            axz.axhline(Zm, color="black", ls="--", lw=1.2, label=f"EDMD Z = {fmt_pm(Zm, run.num('pressure.Z_stderr'), 4)}")
        Zt = run.num("theory.Z")
        if Zt is not None:
            axz.axhline(Zt, **theory_style("eos", label=f"elastic EOS Z = {Zt:.4g}"))
            e = run.num("restitution.mean_e")
            if e is not None and e < 1 - 1e-12:
                Zi = 1 + 0.5 * (1 + e) * (Zt - 1)
                axz.axhline(Zi, **theory_style("sonine", label=f"1 + (1+⟨e⟩)/2 (Z_EOS − 1) = {Zi:.4g}"))
        axz.set_xlabel(TIME_LABEL)
        axz.set_ylabel("Z = P/(nT)  [dimensionless]")
        axz.set_title("Compressibility factor")
        axz.legend(loc="best", fontsize=8)
    s.figure(ctx.save(fig, "edmd_series"),
             "EDMD time series over the measured part of the run (after equilibration): temperature "
             + ("on a log scale beside Haff's law" if haff_t0 else "with its mean") +
             (", and the compressibility factor of each sampling interval beside the run's Z and the EOS."
              if panels > 1 else "."))
    if haff_t0:
        rows = [[k, f"`{key}`", fmt(run.num(key))] for k, key in [
            ("t₀ fitted to T^(−1/2) linear in t", "haff.t0_measured"), ("t₀, theory with a₂", "haff.t0_theory"),
            ("t₀, theory without a₂", "haff.t0_theory_no_a2"), ("measured / theory", "haff.ratio"),
            ("a₂ van Noije-Ernst", "haff.a2_van_noije_ernst"), ("final temperature", "haff.final_temperature")]
            if run.num(key) is not None]
        s.table(["quantity", "key", "value"], rows)
    return s


# ---------------------------------------------------------------------------------------
def pair_correlation(run, ctx):
    """g(r) with the contact values from the EOS, the virial and the fit."""
    if not _is_edmd(run) or not run.has("observables/gr/r", "observables/gr/g"):
        return None
    r, g = run.arr("observables/gr/r"), run.arr("observables/gr/g")
    s = Section("Radial distribution function g(r)", "gr")
    wide = r[-1] > 8.0
    # panels: near contact, a zoom on [σ, 1.1σ] (the contact estimates differ by a few per
    # cent, less than a marker at full scale), and the whole range when it is long
    near = (r >= 1.0) & (r <= 1.1) & np.isfinite(g)
    zoom = near.sum() >= 2
    ratios = [1.3] + ([0.7] if zoom else []) + ([1.0] if wide else [])
    fig, axes = subplots(1, len(ratios), figsize=(4.0 + 4.2 * sum(ratios) / 1.3, 4.3),
                         gridspec_kw=dict(width_ratios=ratios) if len(ratios) > 1 else None)
    axes = np.atleast_1d(axes)
    ax = axes[0]
    if wide:
        axw = axes[-1]
        axw.plot(r, g, **SIM)
        axw.axhline(1, color="0.5", lw=0.8)
        axw.set_xlabel("distance r  [σ]")
        axw.set_ylabel("g(r)  [dimensionless]")
        axw.set_title("Whole range")
    ax.plot(r, g, **dict(SIM, label="EDMD g(r)"))
    ax.axhline(1, color="0.5", lw=0.8, label="ideal gas, g = 1")
    marks = [("theory.g_contact", "o", "#0072B2", "g(σ⁺) from the EOS"),
             ("pressure.g_contact", "s", "#E69F00", "g(σ⁺) from the measured Z"),
             ("pressure.g_contact_weighted_e", "^", "#009E73", "g(σ⁺) from Z, collision-weighted (1+e)"),
             ("g_r.contact_fit", "D", "#D55E00", "g(σ⁺) from a quadratic fit of g(r) near contact"),
             ("g_r.contact_from_collisions", "v", "#CC79A7", "g(σ⁺) from the collisions (approaching + receding)")]
    shown = []
    for key, mk, col, lab in marks:
        v = run.num(key)
        if v is not None and np.isfinite(v):
            ax.plot([1.0], [v], marker=mk, color=col, ms=8, ls="none", mfc="none", mew=1.8, label=f"{lab}: {v:.4g}")
            shown.append((v, mk, col))
    ax.set_xlabel("distance r  [σ]")
    ax.set_ylabel("g(r)  [dimensionless]")
    ax.set_xlim(0.8, min(r[-1], 6.0))
    ax.set_title("Pair correlation near contact" if wide else "Pair correlation")
    ax.legend(loc="upper right", fontsize=8)
    if zoom:
        axz = axes[1]
        axz.plot(r[near], g[near], color="black", marker="o", ms=3, lw=1.0)
        for v, mk, col in shown:
            axz.plot([1.0], [v], marker=mk, color=col, ms=8, ls="none", mfc="none", mew=1.8)
        vals = np.concatenate([g[near], [v for v, _, _ in shown]])
        lo, hi = vals.min(), vals.max()
        pad = 0.1 * (hi - lo) if hi > lo else 0.05 * max(hi, 1.0)
        axz.set_xlim(0.99, 1.1)
        axz.set_ylim(lo - pad, hi + pad)
        axz.set_xlabel("distance r  [σ]")
        axz.set_title("Zoom: [σ, 1.1σ] (bin centres)")
    s.figure(ctx.save(fig, "edmd_gr"),
             "Radial distribution function (black) with the estimates of its contact value g(σ⁺): from the "
             "equation of state, from the virial pressure of the run (also collision-weighted by (1+e)), from a "
             "quadratic fit of g(r) over [σ, 1.1σ], and from the collisions' normal speeds; the second panel "
             "zooms on that window.")
    return s


# ---------------------------------------------------------------------------------------
def velocity_correlations(run, ctx):
    """Bizon's parallel / perpendicular velocity correlations vs separation."""
    base = "observables/velocity_correlation"
    if not _is_edmd(run) or not run.has(f"{base}/r", f"{base}/parallel"):
        return None
    r = run.arr(f"{base}/r")
    par = run.arr(f"{base}/parallel")
    perp = run.arr(f"{base}/perpendicular") if run.has(f"{base}/perpendicular") else None
    s = Section("Velocity correlations vs separation", "velocity-correlations")
    fig, ax = subplots(figsize=(7.5, 4.3))
    ok = np.isfinite(par) & (r >= 1.0)  # no pairs closer than σ
    ax.plot(r[ok], par[ok], color="black", marker="o", ms=3, lw=1.1, label="parallel ⟨v₁∥ v₂∥⟩/T")
    if perp is not None:
        okp = np.isfinite(perp) & (r >= 1.0)
        ax.plot(r[okp], perp[okp], color="black", marker="s", ms=3, mfc="white", lw=1.1, ls="--",
                label="perpendicular ⟨v₁⊥·v₂⊥⟩/((D−1)T)")
    ax.axhline(0, **theory_style("maxwell_dist", lw=1.4, label="molecular chaos / elastic equilibrium: 0"))
    ax.set_xlabel("separation r  [σ]")
    ax.set_ylabel("velocity correlation  [dimensionless]")
    ax.set_title("Pair velocity correlations (Bizon et al. eqs. 25-26)")
    ax.legend(loc="best", fontsize=8)
    s.figure(ctx.save(fig, "edmd_velocity_correlations"),
             "Correlation of the velocities of two grains at distance r, resolved along and across the line "
             "joining them, normalised by T. Elastic hard spheres in equilibrium have none; inelastic collisions "
             "build up positive correlations, mostly parallel, near contact.")
    return s


# ---------------------------------------------------------------------------------------
def velocity_distribution(run, ctx):
    base = "observables/velocity_distribution"
    if not _is_edmd(run) or not run.has(f"{base}/v_over_sqrtT"):
        return None
    z = run.arr(f"{base}/v_over_sqrtT")
    comps = [c for c in "xyz" if run.has(f"{base}/{c}")]
    if not comps:
        return None
    a2 = run.num("velocity.a2")
    s = Section("EDMD velocity distribution", "edmd-distribution")
    fig, (ax, axl) = subplots(1, 2, figsize=(10.5, 4.2))
    zz = np.linspace(z[0], z[-1], 500)
    gauss = np.exp(-zz ** 2 / 2) / math.sqrt(2 * math.pi)
    for k, c in enumerate(comps):
        h = run.arr(f"{base}/{c}")
        for a in (ax, axl):
            a.plot(z, h, marker="o", ms=2.8, ls="none", color="black", alpha=[1, 0.55, 0.3][k], label=f"EDMD, v_{c}")
    for a in (ax, axl):
        a.plot(zz, gauss, **theory_style("maxwell_dist"))
        if a2 is not None:
            a.plot(zz, gauss * (1 + a2 * (zz ** 4 - 6 * zz ** 2 + 3) / 8), **theory_style("sonine_dist"))
        a.set_xlabel("velocity component v_i / √(T/m)  [dimensionless]")
    ax.set_ylabel("probability density  [per unit v_i/√(T/m)]")
    axl.set_yscale("log")
    axl.set_ylim(1e-6, 1)
    ax.legend(loc="upper left", fontsize=7)
    ax.set_title("Linear scale")
    axl.set_title("Log scale: the tails")
    s.figure(ctx.save(fig, "edmd_distribution"),
             "Velocity-component distribution accumulated over the measured snapshots, in units of √(T/m) "
             "(black) beside the Maxwellian and its first Sonine correction with the measured a₂ "
             f"(`velocity.a2` = {fmt(a2)}).")
    return s


# ---------------------------------------------------------------------------------------
def normal_speed(run, ctx):
    base = "observables/normal_speed"
    if not _is_edmd(run) or not run.has(f"{base}/vn_over_sqrtT", f"{base}/density"):
        return None
    x, d = run.arr(f"{base}/vn_over_sqrtT"), run.arr(f"{base}/density")
    if not np.any(d > 0):
        return None
    s = Section("Normal relative speed at collision", "normal-speed")
    fig, ax = subplots(figsize=(7.0, 4.2))
    ax.plot(x, d, **SIM_POINTS)
    nz = np.nonzero(d > 0)[0]
    hi = max(6.0, 1.1 * float(x[nz[-1]])) if len(nz) else float(x[-1])
    xx = np.linspace(0, hi, 400)
    ax.plot(xx, xx / 2 * np.exp(-xx ** 2 / 4), **theory_style("maxwell_dist", label="molecular chaos: (x/2) e^(−x²/4)"))
    ax.set_xlabel("normal relative speed at contact v_n / √(T/m)  [dimensionless]")
    ax.set_xlim(0, hi)
    ax.set_ylabel("probability density  [per unit v_n/√(T/m)]")
    ax.set_title("Collision-weighted normal speed (Bizon et al. Fig. 10)")
    ax.legend(loc="best")
    s.figure(ctx.save(fig, "edmd_normal_speed"),
             "Distribution of the normal component of the relative velocity at collisions (black) beside the "
             "molecular-chaos prediction for a Maxwellian gas, P_c(v_n) = v_n/(2T) e^(−v_n²/(4T)).")
    rows = [[k, f"`{key}`", fmt(run.num(key))] for k, key in [
        ("⟨v_n⟩_c / √(πT) (1 under molecular chaos)", "collision.vn_over_sqrt_piT"),
        ("⟨v_n²⟩_c / (4T) (1 under molecular chaos)", "collision.vn2_over_4T")] if run.num(key) is not None]
    if rows:
        s.table(["quantity", "key", "value"], rows)
    return s


# ---------------------------------------------------------------------------------------
def check_h5md(run):
    """Departures of the snapshot layout from H5MD 1.1 (h5md group and particles/all box and
    position element), as a list of one-line problems (empty: conforming)."""
    f, p = run.h5, []
    if "h5md" not in f:
        return ["no /h5md group"]
    h = f["h5md"]
    v = np.asarray(h.attrs.get("version", []))
    if not (v.dtype.kind in "iu" and v.shape == (2,)):
        p.append(f"/h5md attribute version must be an integer array [major, minor], found {v.tolist()!r}")
    for grp, keys in (("author", ("name",)), ("creator", ("name", "version"))):
        if grp not in h:
            p.append(f"/h5md/{grp} group missing (attributes {', '.join(keys)})")
        else:
            p += [f"/h5md/{grp} lacks attribute {k}" for k in keys if k not in h[grp].attrs]
    box = f.get("particles/all/box")
    if box is None:
        p.append("/particles/all/box missing")
    else:
        dim = np.asarray(box.attrs.get("dimension", -1))
        if dim.dtype.kind not in "iu":
            p.append(f"box attribute dimension must be an integer, found {dim.dtype} {dim.tolist()}")
        b = np.asarray(box.attrs.get("boundary", []))
        D = int(dim) if dim.size == 1 else 0
        vals = [x.decode() if isinstance(x, bytes) else str(x) for x in np.atleast_1d(b).tolist()]
        if len(vals) != D or any(x not in ("periodic", "none") for x in vals):
            p.append(f"box attribute boundary must be {D} strings 'periodic' or 'none', found {vals}")
        if "edges" not in box:
            p.append("box/edges missing")
    pos = f.get("particles/all/position")
    if pos is not None:
        p += [f"position/{k} missing" for k in ("value", "step", "time") if k not in pos]
        if "step" in pos and pos["step"].dtype.kind not in "iu":
            p.append("position/step must be integer")
    return p


def snapshot(run, ctx):
    """Last H5MD frame: the grains in the box (2D) or a slab of it (3D)."""
    p = "particles/all/position/value"
    if not _is_edmd(run) or p not in run.h5:
        return None
    ds = run.h5[p]
    if ds.ndim != 3 or ds.shape[0] == 0:
        return None
    x = np.asarray(ds[-1], dtype=float)
    D = x.shape[1]
    edges = run.arr("particles/all/box/edges")
    L = edges if edges is not None and len(edges) >= D else x.max(axis=0)
    tframe = run.arr("particles/all/position/time")
    s = Section("Configuration snapshot (H5MD)", "snapshot")
    fig, ax = subplots(figsize=(6.0, 6.0))
    if D == 3:
        zc = 0.5 * L[2]
        sel = np.abs(x[:, 2] - zc) < 0.5
        pts, title = x[sel], f"slab |z − L/2| < σ/2 ({sel.sum()} spheres)"
    else:
        pts, title = x, f"{len(x)} disks"
    from matplotlib.collections import EllipseCollection
    kw = dict(units="xy", offsets=pts[:, :2], facecolors="#56B4E9", edgecolors="black", linewidths=0.3)
    try:
        coll = EllipseCollection(np.ones(len(pts)), np.ones(len(pts)), np.zeros(len(pts)),
                                 offset_transform=ax.transData, **kw)
    except TypeError:  # matplotlib < 3.6
        coll = EllipseCollection(np.ones(len(pts)), np.ones(len(pts)), np.zeros(len(pts)),
                                 transOffset=ax.transData, **kw)
    ax.add_collection(coll)
    ax.set_xlim(0, L[0])
    ax.set_ylim(0, L[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x  [σ]")
    ax.set_ylabel("y  [σ]")
    ax.grid(False)
    tt = f" at t = {tframe[-1]:.4g}" if tframe is not None and len(tframe) else ""
    ax.set_title(f"Last frame{tt}: {title}")
    s.figure(ctx.save(fig, "edmd_snapshot"),
             "Positions in the last stored frame of /particles/all/position (H5MD); grains drawn to scale "
             "(diameter σ). Clusters and voids show inelastic clustering.")
    s.text(f"{ds.shape[0]} frames of {ds.shape[1]} grains in results.h5 (H5MD layout: "
           "`/particles/all/position/{value,time,step}`, `/particles/all/box`).")
    problems = check_h5md(run)
    if problems:
        s.text("**H5MD conformance** (H5MD 1.1 readers may reject the file):\n\n" +
               "\n".join(f"- {x}" for x in problems))
    else:
        s.text("The snapshot layout conforms to H5MD 1.1 (h5md, author, creator, box, position element).")
    return s
