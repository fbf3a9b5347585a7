"""Sections for spatially resolved DSMC output: density-mode decay (/mode) and time-averaged
cell fields (/fields, with fields.xdmf for ParaView).  Layout: docs/OUTPUT.md, "Spatial DSMC"."""
import math
import os
import re
import xml.etree.ElementTree as ET

import numpy as np

from .common import has_walls
from .document import Section, fmt, fmt_pm
from .plotting import SIM, plt, subplots, theory_style

TIME_LABEL = "time t  [λ/√(E/m)]"

# theory.hydro.* decay-rate keys -> (label, style)
RATE_THEORY = [
    ("theory.hydro.decay_rate", "drift-diffusion limit, paper coefficients", dict(color="#CC79A7", ls="--", lw=1.8)),
    ("theory.hydro.decay_rate_kinetic", "drift-diffusion limit, kinetic (Sonine) coefficients",
     dict(color="#D55E00", ls=(0, (5, 1, 1, 1)), lw=1.6)),
    ("theory.hydro.decay_rate_maxwellian_closure", "local-Maxwellian closure (finite ε)", dict(color="#0072B2", ls="--", lw=1.6)),
    ("theory.hydro.decay_rate_grad_closure", "Grad closure (finite ε)", dict(color="#E69F00", ls="-.", lw=1.6)),
    ("theory.hydro.decay_rate_sonine_closure", "Sonine closure (finite ε)", dict(color="#009E73", ls=":", lw=2.0)),
]


def _rate_theories(run):
    out = [(key, label, style, run.num(key)) for key, label, style in RATE_THEORY if run.num(key) is not None]
    known = {k for k, *_ in RATE_THEORY}
    for key, v in run.flat_summary():  # any other theory.*decay_rate* a solver adds
        if re.match(r"theory\..*decay_rate", key) and key not in known and isinstance(v, (int, float)) \
                and not key.endswith(("stderr", "_ratio")):
            out.append((key, key[len("theory."):], dict(color="0.4", ls=":", lw=1.4), float(v)))
    return out


def density_mode(run, ctx):
    """Amplitude of the imposed density mode vs time: fit and the hydrodynamic decay rates."""
    if not run.has("mode/t", "mode/amplitude"):
        return None
    t, A = run.arr("mode/t"), run.arr("mode/amplitude")
    k = run.arr("mode/wavenumber")
    k = float(np.ravel(k)[0]) if k is not None else None
    rate = run.num("mode.decay_rate")
    rate_e = run.num("mode.decay_rate_stderr")
    icpt = run.arr("mode/fit_intercept")
    icpt = float(np.ravel(icpt)[0]) if icpt is not None else None
    win = run.arr("mode/fit_window")
    N = run.param("dsmc.particles")
    theories = _rate_theories(run)
    s = Section("Density-mode decay: fit and hydrodynamic theory", "mode")
    fig = plt.figure(figsize=(11.5, 6.6))
    gs = fig.add_gridspec(2, 2, width_ratios=[1.5, 1], height_ratios=[1.6, 1])
    ax, axc, axr = fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[1, 0]), fig.add_subplot(gs[:, 1])
    if win is not None and len(win) == 2:
        ax.axvspan(max(win[0], t[0]), min(win[1], t[-1]), color="0.88", lw=0, label="fit window")
    pos = A > 0
    ax.semilogy(t[pos], A[pos], **dict(SIM, label="DSMC amplitude"))
    if isinstance(N, (int, float)) and N > 0:
        ax.axhline(math.sqrt(2 / N), color="0.55", lw=1, ls=":", label="noise of one sample √(2/N)")
    if rate is not None and icpt is not None:
        ax.semilogy(t, np.exp(icpt - rate * t), **theory_style("fit", label=f"fit: Γ = {fmt_pm(rate, rate_e, 4)}"))
    base = icpt if icpt is not None else math.log(A[0])
    for key, label, style, g in theories:
        ax.semilogy(t, np.exp(base - g * t), **dict(style, label=f"{label}: Γ = {g:.4g}"))
    lo = float(np.min(A[pos])) * 0.5
    if isinstance(N, (int, float)) and N > 0:
        lo = min(lo, 0.5 * math.sqrt(2 / N))
    ax.set_ylim(max(lo * 0.04, 1e-9), float(np.max(A)) * 2)  # room for the legend below the data
    ax.set_ylabel("mode amplitude A(t) = δn_k / n̄  (log scale)")
    ax.set_title(f"Density mode k = {k:.4g} λ⁻¹" if k else "Density mode")
    ax.legend(loc="lower left", fontsize=7)
    # compensated: divide by the fit, so that each theory is a straight line of slope Γ_fit − Γ
    if rate is not None and icpt is not None:
        fitc = np.exp(icpt - rate * t)
        if win is not None and len(win) == 2:
            axc.axvspan(max(win[0], t[0]), min(win[1], t[-1]), color="0.88", lw=0)
        axc.plot(t[pos], A[pos] / fitc[pos], **dict(SIM, label="DSMC / fit"))
        if isinstance(N, (int, float)) and N > 0:
            noise = math.sqrt(2 / N)
            axc.fill_between(t, 1 - noise / fitc, 1 + noise / fitc, color="0.85", lw=0, alpha=0.6,
                             label="± noise of one sample")
        for key, label, style, g in theories:
            axc.plot(t, np.exp(-(g - rate) * t), **dict(style, label=label))
        axc.axhline(1, **theory_style("fit", label="fit"))
        lo_c = min(0.8, float(np.min(A[pos] / fitc[pos])))
        axc.set_ylim(max(lo_c, 0.5), min(max(1.2, float(np.max(A[pos] / fitc[pos]))), 2.0))
        axc.set_ylabel("amplitude / fit  [1]")
    axc.set_xlabel(TIME_LABEL)
    # rates side by side
    entries = ([("DSMC fit", rate, "black")] if rate is not None else []) + \
              [(lab, g, st["color"]) for _, lab, st, g in theories]
    yy = np.arange(len(entries))[::-1]
    for yi, (lab, g, col) in zip(yy, entries):
        if lab == "DSMC fit":
            axr.errorbar([g], [yi], xerr=[rate_e] if rate_e else None, fmt="o", color=col, ms=6, capsize=4)
        else:
            axr.plot([g], [yi], "s", color=col, ms=7)
            if rate is not None and rate_e:
                axr.annotate(f"{(g - rate) / rate_e:+.1f}σ", (g, yi), textcoords="offset points", xytext=(0, 7),
                             ha="center", fontsize=8, color=col)
    xs = [g for _, g, _ in entries] + ([rate - rate_e, rate + rate_e] if rate is not None and rate_e else [])
    if xs:
        pad = 0.15 * (max(xs) - min(xs)) or 0.05 * abs(max(xs)) or 0.1
        axr.set_xlim(min(xs) - pad, max(xs) + pad)
    axr.set_yticks(yy)
    axr.set_yticklabels([e[0].replace(", ", ",\n", 1) for e in entries], fontsize=7.5)
    axr.set_ylim(-0.7, len(entries) - 0.3)
    axr.set_xlabel("decay rate Γ  [√(E/m)/λ]")
    axr.set_title("Decay rates")
    s.figure(ctx.save(fig, "mode_decay"),
             "Amplitude of the imposed density mode (black, log scale) with the exponential fit over the grey "
             "window and the decay rates of the hydrodynamic theories, drawn through the fit's intercept so "
             "that the slopes compare; lower left: everything divided by the fit, so a theory with the wrong "
             "rate drifts away from 1; right: the rates side by side (distance from the fit in σ).")
    rows = [["DSMC fit (`mode.decay_rate`)", fmt_pm(rate, rate_e), ""]]
    for key, label, _, g in theories:
        rows.append([f"{label} (`{key}`)", fmt(g), f"{100 * (g - rate) / rate:+.3g} %" if rate else ""])
    s.table(["source", "Γ", "theory − DSMC (rel.)"], rows)
    extra = [(lab, key) for lab, key in [("wavenumber k", "theory.hydro.k"), ("fit points", "mode.fit_points"),
                                         ("initial amplitude", "mode.initial_amplitude")] if run.num(key) is not None]
    if extra:
        s.table(["quantity", "value"], [[f"{lab} (`{key}`)", fmt(run.num(key))] for lab, key in extra])
    return s


def check_xdmf(run):
    """(attributes checked, [problems]) for OUT/fields.xdmf against results.h5: every HDF DataItem
    must name an existing dataset of the stated shape, and cell data must match the topology."""
    path = os.path.join(run.out_dir, "fields.xdmf")
    if not os.path.isfile(path):
        return 0, []
    problems, checked = [], 0
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        return 0, [f"fields.xdmf is not well-formed XML: {e}"]
    topo = root.find(".//Topology")
    cells = None
    if topo is None:
        problems.append("no Topology element")
    else:
        nodes = [int(v) for v in topo.get("Dimensions", "").split()]
        cells = [n - 1 for n in nodes]
    for att in root.iter("Attribute"):
        item = att.find("DataItem")
        name = att.get("Name")
        if item is None or item.get("Format") != "HDF":
            continue
        checked += 1
        ref = (item.text or "").strip()
        fname, _, dset = ref.partition(":")
        dims = [int(v) for v in item.get("Dimensions", "").split()]
        if os.path.basename(fname) != "results.h5":
            problems.append(f"{name}: points to {fname}, not results.h5")
            continue
        if dset.lstrip("/") not in run.h5:
            problems.append(f"{name}: {dset} missing from results.h5")
            continue
        shape = list(run.h5[dset.lstrip("/")].shape)
        if shape != dims:
            problems.append(f"{name}: Dimensions {dims} but {dset} has shape {shape}")
        if att.get("Center") == "Cell" and cells and dims[:3] != cells:
            problems.append(f"{name}: cell data {dims[:3]} but the topology has {cells} cells")
    return checked, problems


def _field(run, name):
    a = run.arr(f"fields/{name}")
    if a is None:
        return None
    # [z][y][x](...) -> average over z and y: profile along x
    return a.reshape(a.shape[0], a.shape[1], a.shape[2], -1).mean(axis=(0, 1)).squeeze()


def profiles(run, ctx):
    """Time-averaged n(x), T(x) (and the background's T_B(x)) against n ∝ T_B^(−p)."""
    if not run.has("fields/x", "fields/density"):
        return None
    x = run.arr("fields/x")
    n = _field(run, "density")
    ne = _field(run, "density_stderr")
    T = _field(run, "temperature")
    Te = _field(run, "temperature_stderr")
    TB = _field(run, "background_temperature")
    ny_nz = run.h5["fields/density"].shape[:2]
    s = Section("Profiles n(x), T(x) against theory", "profiles")
    fig, (ax, axT) = subplots(2, 1, figsize=(7.5, 6.4), sharex=True)
    ax.errorbar(x, n, yerr=ne, fmt="o", ms=3, color="black", capsize=0, lw=0.8, label="DSMC n(x) ± std. error")
    p_keys = [("theory.hydro.thermal_diffusion_exponent", "paper", RATE_THEORY[0][2]),
              ("theory.hydro.thermal_diffusion_exponent_kinetic", "kinetic", RATE_THEORY[1][2])]
    if TB is not None and np.all(TB > 0):
        for key, lab, st in p_keys:
            p = run.num(key)
            if p is None:
                continue
            shape = TB ** (-p)
            ax.plot(x, shape * np.mean(n) / np.mean(shape),
                    **dict(st, label=f"drift-diffusion: n ∝ T_B^(−p), p = {p:.4g} ({lab} coefficients)"))
        pe, pe_e = run.num("profile.exponent"), run.num("profile.exponent_stderr")
        if pe is not None:
            shape = TB ** (-pe)
            ax.plot(x, shape * np.mean(n) / np.mean(shape),
                    **theory_style("fit", label=f"fit to DSMC: p = {fmt_pm(pe, pe_e, 4)}"))
    ax.set_ylabel("grain density n  [1/λ³]")
    ax.set_title("Time-averaged profiles" + (f" (averaged over {ny_nz[1]}×{ny_nz[0]} cells across)"
                                             if ny_nz[0] * ny_nz[1] > 1 else ""))
    ax.legend(loc="best", fontsize=8)
    if T is not None:
        axT.errorbar(x, T, yerr=Te, fmt="o", ms=3, color="black", capsize=0, lw=0.8, label="DSMC grain T(x)")
    if TB is not None:
        axT.plot(x, TB, color="#E69F00", lw=1.6, ls="-.", label="background T_B(x) (imposed)")
    axT.set_xlabel("position x  [λ]")
    axT.set_ylabel("temperature  [E]")
    axT.legend(loc="best", fontsize=8)
    s.figure(ctx.save(fig, "profiles"),
             "Cell averages over the steady window (black, ± batch standard errors): grain density against the "
             "drift-diffusion prediction n ∝ T_B^(−p) (normalised to the same mean density), and the grain "
             "temperature beside the imposed background temperature." +
             ("" if not has_walls(run) else " The drift-diffusion limit has no walls: the diffuse walls or open "
              "faces of this box make the layers next to them, where it does not apply."))
    rows = [[f"`{key}`", fmt(run.num(key))] for key in
            ["profile.exponent", "profile.exponent_stderr", "theory.hydro.thermal_diffusion_exponent",
             "theory.hydro.thermal_diffusion_exponent_kinetic", "theory.hydro.diffusion_coefficient",
             "theory.hydro.diffusion_coefficient_kinetic"] if run.num(key) is not None]
    if rows:
        s.table(["key", "value"], rows)
    # has the profile had time to form? diffusion time of the imposed mode, 1/(D k^2)
    Dc = run.num("theory.hydro.diffusion_coefficient")
    Lx = run.param("domain.length")
    idx = run.param("background.wavenumber_index", 1)
    t0 = run.param("sampling.steady_from")
    if Dc and isinstance(Lx, list) and Lx and isinstance(t0, (int, float)) and \
            run.param("background.profile", "uniform") != "uniform":
        kx = 2 * math.pi * idx / float(Lx[0])
        tau = 1.0 / (Dc * kx * kx)
        note = (f"Diffusion time of the imposed profile 1/(D k²) = {fmt(tau, 3)} (D = `theory.hydro.diffusion_coefficient`, "
                f"k = 2π·{idx}/L_x); the averaging starts at t = {fmt(t0, 3)}")
        if t0 < 3 * tau:
            s.text(f"**Warning:** {note}, less than 3 diffusion times: the density profile is probably still "
                   f"forming and cannot be compared with the steady drift-diffusion prediction. Run longer "
                   f"(`dsmc.t_end`, `sampling.steady_from` ≳ {fmt(3 * tau, 2)}).")
        else:
            s.text(note + ".")
    window = run.attr("fields", "window")
    if window:
        s.text(f"Fields: {window}.")
    if os.path.isfile(os.path.join(run.out_dir, "fields.xdmf")):
        s.text(f"The full 3D fields open in ParaView: `paraview {os.path.join(run.out_dir, 'fields.xdmf')}` "
               "(XDMF pointing into results.h5:/fields; cell data).")
        checked, problems = check_xdmf(run)
        if problems:
            s.text("**fields.xdmf problems** (ParaView may refuse the file):\n\n" +
                   "\n".join(f"- {p}" for p in problems))
        else:
            s.text(f"fields.xdmf checked: {checked} attributes, each pointing at a dataset of results.h5 with the "
                   f"stated shape, consistent with the mesh.")
    return s


def shear(run, ctx):
    """Background profile "shear" (u_B,x varying with y): grain u_x(y) and T(y) beside u_B,x(y)."""
    if run.param("background.profile") != "shear" or not run.has("fields/y", "fields/velocity"):
        return None
    y = run.arr("fields/y")
    u = run.arr("fields/velocity")                 # (nz, ny, nx, 3)
    ux = u[..., 0].mean(axis=(0, 2))
    T = run.arr("fields/temperature")
    Ty = T.mean(axis=(0, 2)) if T is not None else None
    A = run.param("background.amplitude", 0.0)
    idx = run.param("background.wavenumber_index", 1)
    L = run.param("domain.length")
    s = Section("Shear profile u_x(y)", "shear")
    fig, (ax, axT) = subplots(2, 1, figsize=(7.5, 6.0), sharex=True)
    ax.plot(y, ux, **dict(SIM, marker="o", ms=3, label="DSMC grain u_x(y)"))
    if isinstance(L, list) and len(L) > 1 and isinstance(A, (int, float)):
        yy = np.linspace(0, float(L[1]), 300)
        ax.plot(yy, A * np.sin(2 * math.pi * idx * yy / float(L[1])),
                **theory_style("maxwell_dist", label="background u_B,x(y) (imposed)"))
    ax.set_ylabel("u_x  [√(E/m)]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("Grains dragged by a sheared background")
    if Ty is not None:
        Te = run.arr("fields/temperature_stderr")
        err = None
        if Te is not None:
            cnt = Te.shape[0] * Te.shape[2]
            err = np.sqrt(np.nansum(Te ** 2, axis=(0, 2))) / cnt
        axT.errorbar(y, Ty, yerr=err, fmt="o-", ms=3, color="black", lw=1.0, capsize=0,
                     label="DSMC grain T(y) ± std. error")
        for c in ("maxwellian", "grad", "sonine"):
            v = run.num(f"theory.equilibrium.{c}.T")
            if v is not None:
                axT.axhline(v, **theory_style(c, label=f"homogeneous T#, {c}"))
        axT.legend(loc="best", fontsize=8)
    axT.set_xlabel("position y  [λ]")
    axT.set_ylabel("temperature  [E]")
    s.figure(ctx.save(fig, "shear"),
             "Time-averaged grain velocity along x and grain temperature across the shear (averaged over x and "
             "z), beside the imposed background velocity and the homogeneous steady temperatures.")
    return s


def maps(run, ctx):
    """2D/3D runs: colour maps of the time-averaged density and temperature (averaged over z)."""
    if not run.has("fields/y", "fields/density"):
        return None
    x, y = run.arr("fields/x"), run.arr("fields/y")
    n = run.arr("fields/density").mean(axis=0)
    T = run.arr("fields/temperature")
    fig, axes = subplots(1, 2 if T is not None else 1, figsize=(11.0, 4.4))
    axes = np.atleast_1d(axes)
    dx, dy = (x[1] - x[0]) if len(x) > 1 else 1.0, (y[1] - y[0]) if len(y) > 1 else 1.0
    ext = [x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2]
    for ax, data, lab, cmap in [(axes[0], n, "grain density n  [1/λ³]", "viridis")] + \
            ([(axes[1], T.mean(axis=0), "grain temperature T  [E]", "inferno")] if T is not None else []):
        im = ax.imshow(data, origin="lower", extent=ext, aspect="auto", cmap=cmap)
        fig.colorbar(im, ax=ax, label=lab)
        ax.set_xlabel("x  [λ]")
        ax.set_ylabel("y  [λ]")
        ax.grid(False)
        ax.set_title(lab.split("  ")[0] + (" (averaged over z)" if run.has("fields/z") else ""))
    s = Section("Field maps", "maps")
    s.figure(ctx.save(fig, "field_maps"),
             "Time-averaged cell fields (simulation only). The full fields, with velocity and heat flux, open in "
             "ParaView from fields.xdmf.")
    return s
