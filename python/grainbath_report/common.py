"""Sections every solver shares: overview / key numbers, and the appendix (all summary values,
the case file, the layout of results.h5)."""
import h5py
import numpy as np

from .axes import PLATEAU_JUDGED, error_verdict  # noqa: F401 (PLATEAU_JUDGED: kept importable here)
from .document import Section, fmt, fmt_pm

UNITS = {
    "dsmc": ("Units (scaled, Bisi-Spiga): lengths in grain-grain mean free paths λ (both collision "
             "cross-sections 1: λ = 1/(nσ) at n = 1; the measured mean free path of a Maxwellian gas, "
             "`resolution.mean_free_path`, is λ/√2), grain mass m, "
             "temperatures in energy units E (k_B = 1), velocities in √(E/m), time in λ/√(E/m)."),
    "edmd": ("Units: lengths in grain diameters σ, grain mass m = 1, temperatures in energy units E "
             "(k_B = 1), time in σ√(m/E)."),
}


def has_walls(run):
    """Diffuse walls or open faces: they exchange energy or grains (layers next to them)."""
    faces = run.param("domain.boundaries", [])
    return bool(set(faces if isinstance(faces, list) else [faces]) & {"diffuse", "open"})


def homogeneous_state(run):
    """True unless the run imposes a spatial background profile, or has faces that exchange
    energy or grains (diffuse walls, open faces): then the homogeneous steady-state theory
    does not describe the domain as a whole (at most its bulk, cases/hot-walls/analyse.py).
    Periodic and specular faces keep a state without drift homogeneous (a drift against a
    specular face does not: such a box is still compared)."""
    if run.param("background.profile", "uniform") != "uniform":
        return False
    return not has_walls(run)


def free_cooling(run):
    """True for a gas that only cools: DSMC with no background medium (no [background]
    density, no background file) and no diffuse (heat-exchanging) walls; EDMD with
    `sampling.free_cooling`. Its temperature has no steady value and its fluxes need not
    vanish, so window means and "equilibrium" wording do not apply."""
    if run.solver == "edmd":
        return bool(run.param("sampling.free_cooling", False))
    if run.solver != "dsmc":
        return False
    if run.param("background.density", 0.0) or run.param("background.profile", "uniform") == "file":
        return False
    walls = run.param("domain.boundaries", [])
    return "diffuse" not in (walls if isinstance(walls, list) else [walls])


def lower_bound(run, err_key):
    """True when the run flagged `err_key`: its blocking reached no plateau (summary
    `<err_key>_plateau` false, written since 2026-12-05; older runs: never flagged). The error
    is then unreliable: a lower bound if the series is correlated over a good part of the
    window, and the mean itself no steady value if the series drifts through it."""
    return _verdict(run, err_key) == "no plateau"


def unchecked(run, err_key):
    """True for a DSMC window error that carries no `<err_key>_plateau` flag: its window held too
    few samples (≤ 90) for the plateau test to tell anything (the run's log says so once), or the
    run predates the test (2026-12-05). The error is then the blocking's estimate, unjudged."""
    return _verdict(run, err_key) == "unchecked"


def _verdict(run, err_key):
    # the rule lives in axes.py, shared with scripts/plot_sweep.py (sweep.png)
    if not err_key:
        return None
    return error_verdict(run.solver, err_key, run.num(err_key), run.get(err_key + "_plateau"))


def error_mark(run, err_key):
    """The mark after an error, as the CLI's run table prints it: " (no plateau)" for a flagged
    (unreliable) error, " (few samples: unchecked)" for an unjudged one, else ""."""
    if lower_bound(run, err_key):
        return " (no plateau)"
    return " (few samples: unchecked)" if unchecked(run, err_key) else ""


def fmt_err(run, mean, err_key, digits=6):
    """mean ± error, marked as the CLI marks it (error_mark)."""
    e = run.num(err_key) if err_key else None
    text = fmt_pm(mean, e, digits)
    return text + error_mark(run, err_key) if e is not None else text


def deviation(sim, err, theory):
    """'Δ = …, … σ, … %' of theory relative to the simulation."""
    if sim is None or theory is None:
        return "n/a"
    d = theory - sim
    parts = [f"{d:+.3g}"]
    if err:
        parts.append(f"{d / err:+.1f} σ")
    if sim != 0:
        parts.append(f"{100 * d / abs(sim):+.3g} %")
    return ", ".join(parts)


GLANCE = [
    # (quantity, simulation key, error key, [(theory label, theory key)])
    ("steady temperature T#", "temperature.mean", "temperature.stderr",
     [("Sonine closure root", "theory.equilibrium.sonine.T"), ("Grad closure root", "theory.equilibrium.grad.T"),
      ("local-Maxwellian closure root", "theory.equilibrium.maxwellian.T"),
      ("ε-expansion, 1st order", "theory.expansion.first_order.T")]),
    ("a₂ (steady)", "a2.mean", "a2.stderr", [("Sonine closure", "theory.equilibrium.sonine.a2"),
                                              ("van Noije-Ernst (cooling state)", "theory.haff.a2_van_noije_ernst"),
                                              ("second Sonine (cooling state)", "theory.hcs.a2_sonine2")]),
    ("T(t_end), free cooling", "temperature.final", None,
     [("Haff's law, Maxwellian cooling rate", "theory.haff.temperature_at_t_end_no_a2"),
      ("Haff's law with the van Noije-Ernst a₂", "theory.haff.temperature_at_t_end")]),
    ("density-mode decay rate", "mode.decay_rate", "mode.decay_rate_stderr",
     [("Sonine closure", "theory.hydro.decay_rate_sonine_closure"),
      ("Grad closure", "theory.hydro.decay_rate_grad_closure"),
      ("local-Maxwellian closure", "theory.hydro.decay_rate_maxwellian_closure"),
      ("drift-diffusion (paper)", "theory.hydro.decay_rate"),
      ("drift-diffusion (kinetic)", "theory.hydro.decay_rate_kinetic")]),
    ("profile exponent p", "profile.exponent", "profile.exponent_stderr",
     [("drift-diffusion (paper)", "theory.hydro.thermal_diffusion_exponent"),
      ("drift-diffusion (kinetic)", "theory.hydro.thermal_diffusion_exponent_kinetic")]),
    ("compressibility factor Z", "pressure.Z", "pressure.Z_stderr",
     [("reference EOS (elastic)", "theory.Z"), ("Enskog: (1+e)/2 × the EOS's collisional part", "theory.Z_enskog")]),
    ("temperature in the medium", "temperature.mean", "temperature.stderr",
     [("medium steady state (EDMD theory)", "theory.medium_steady_temperature")]),
    ("g(σ⁺) from g(r)", "g_r.contact_fit", None, [("reference EOS", "theory.g_contact")]),
    ("Haff time t₀", "haff.t0_measured", None, [("with a₂ correction", "haff.t0_theory")]),
]


def glance_rows(run):
    rows = []
    for quantity, key, err_key, theories in GLANCE:
        v = run.num(key)
        if v is None:
            continue
        if key == "temperature.final" and run.num("theory.haff.temperature_at_t_end") is None:
            continue
        if key in ("temperature.mean", "a2.mean", "temperature.final") and run.solver == "dsmc" and \
                not homogeneous_state(run):
            continue  # imposed profile or walls: the homogeneous T#, a2 are no prediction for the whole domain
        if key == "temperature.mean" and free_cooling(run):
            continue  # results from before 2026-12-05: the window mean of a decaying T
        e = run.num(err_key) if err_key else None
        shown = []
        for label, tkey in theories:
            t = run.num(tkey)
            if t is not None and t not in shown:  # (Enskog's Z of elastic grains is the EOS's: once)
                shown.append(t)
                # a lower-bound error: no deviation in σ (it would overstate the significance)
                sig = None if lower_bound(run, err_key) else e
                # the elastic EOS predicts only a homogeneous, undriven gas of elastic grains, where
                # the run wrote theory.Z_enskog equal to it; elsewhere it is a reference (no σ)
                if tkey == "theory.Z" and run.num("theory.Z_enskog") != t:
                    sig, label = None, "elastic EOS (a reference, not this run's theory)"
                rows.append([quantity, fmt_err(run, v, err_key), label, fmt(t), deviation(v, sig, t)])
    return rows


def overview(run, ctx):
    s = Section("Run and key numbers", "overview")
    p = run.params
    glance = glance_rows(run)
    if glance:
        s.table(["quantity", "simulation", "theory", "value", "theory − simulation (abs., in σ, rel.)"], glance,
                caption="Simulation against theory at a glance (σ: the simulation's standard error; it does not "
                        "include time-step or finite-N bias).")
    rows = [["solver", "`run.solver`", run.solver],
            ["grainbath version", "`run.version`", run.get("run.version", run.root_attr("grainbath_version"))],
            ["git commit of the build", "`run.commit`", run.get("run.commit", "not recorded (before 2026-12-06)")],
            ["seed", "`run.seed`", fmt(run.get("run.seed", run.root_attr("seed")))]]
    for key, label in [("dsmc.particles", "particles"), ("dsmc.dt", "time step Δt"),
                       ("dsmc.t_end", "end time"), ("sampling.steady_from", "averaging from t ="),
                       ("grains.density", "grain density n"), ("grains.temperature", "initial T"),
                       ("grains.drift", "initial drift u(0)"), ("background.density", "background density n_B"),
                       ("background.temperature", "background temperature T_B"),
                       ("background.mass_ratio", "mass ratio α = m_B/(m+m_B)"),
                       ("background.knudsen", "Knudsen number ε"), ("restitution.law", "restitution law"),
                       ("restitution.e", "restitution e"), ("restitution.beta", "restitution β"),
                       ("restitution.delta", "restitution δ"),
                       ("edmd.dimensions", "dimensions"), ("edmd.particles", "particles"),
                       ("edmd.packing_fraction", "packing fraction ν (2D) / φ (3D)"),
                       ("edmd.equilibrate", "equilibration [collisions per particle]"),
                       ("edmd.collisions", "measurement [collisions per particle]"),
                       ("heating.model", "heat bath"), ("heating.kick", "white-noise kick"),
                       ("heating.temperature", "heat-bath temperature"),
                       ("walls.directions", "walls"), ("sampling.free_cooling", "free cooling")]:
        if key.startswith("background.") and key != "background.density" and not p.get("background.density"):
            continue  # no background medium: its other keys are defaults of no consequence
        if key.startswith("heating.") and key != "heating.model" and p.get("heating.model") in (None, "none"):
            continue
        if key in p:
            v = p[key]
            rows.append([label, f"`{key}`", fmt(v) if not isinstance(v, list) else str(v)])
    s.text(UNITS.get(run.solver, ""))
    s.table(["parameter", "key", "value"], rows, caption="Resolved case parameters (from /parameters in results.h5).")

    key_rows = []

    def row(label, key, err_key=None):
        v = run.num(key)
        if v is None:
            return
        e = run.num(err_key) if err_key else None
        mark = error_mark(run, err_key) if e is not None else ""
        key_rows.append([label, f"`{key}`", fmt(v), fmt(e) + mark if e is not None else ""])

    if run.solver == "edmd":
        row("mean temperature T over the run", "temperature.mean", "temperature.stderr")
    elif free_cooling(run):
        # the gas cools: no window mean of T (not written since 2026-12-05; older results held
        # the window mean of the decaying T and a blocked "error" of that trend: not shown)
        pass
    else:
        row("steady temperature T (window mean)", "temperature.mean", "temperature.stderr")
    row("final temperature", "temperature.final")
    row("Sonine coefficient a₂ (window mean)", "a2.mean", "a2.stderr")
    row("final a₂", "a2.final")
    row("final |u − u_B|", "velocity.final")
    row("compressibility factor Z", "pressure.Z", "pressure.Z_stderr")
    row("g(σ) from Z", "pressure.g_contact")
    row("g(σ) from a quadratic fit of g(r)", "g_r.contact_fit")
    row("g(σ⁺) from the collisions", "g_r.contact_from_collisions")
    row("a₂ (EDMD)", "velocity.a2")
    row("mean restitution ⟨e⟩", "restitution.mean_e")
    row("collision frequency / Enskog", "collision.frequency_over_enskog")
    row("loss rate / molecular-chaos loss rate", "loss.gamma_over_gamma_e")
    row("Haff time, measured / theory", "haff.ratio")
    row("T#, local-Maxwellian closure", "theory.equilibrium.maxwellian.T")
    row("T#, Grad closure", "theory.equilibrium.grad.T")
    row("T#, Sonine closure", "theory.equilibrium.sonine.T")
    row("a₂, Sonine closure", "theory.equilibrium.sonine.a2")
    row("T#, ε-expansion to first order", "theory.expansion.first_order.T")
    row("T#, ε-expansion 2nd order (Maxwellian)", "theory.expansion.second_order_maxwellian.T")
    row("T#, ε-expansion 2nd order (Grad)", "theory.expansion.second_order_grad.T")
    row("momentum relaxation rate (theory)", "theory.rates.momentum")
    row("Haff T(t_end), Maxwellian cooling rate (theory)", "theory.haff.temperature_at_t_end_no_a2")
    row("Haff T(t_end) with the van Noije-Ernst a₂ (theory)", "theory.haff.temperature_at_t_end")
    row("a₂ van Noije-Ernst (theory)", "theory.haff.a2_van_noije_ernst")
    row("Z, elastic equation of state (theory; inelastic grains: see the EOS section)", "theory.Z")
    row("g(σ), elastic equation of state (theory)", "theory.g_contact")
    row("energy budget residual (relative)", "energy.budget_relative_residual")
    row("wall time [s]", "performance.wall_seconds")
    row("collisions per second", "performance.collisions_per_second")
    if key_rows:
        s.table(["quantity", "summary.json key", "value", "± std. error"], key_rows,
                caption="Key numbers from summary.json (std. error from block averaging over the window; "
                        "\"no plateau\": the blocking reached no plateau, so the error is a lower bound if the "
                        "series is correlated over a good part of the window, and the mean no steady value if it "
                        "drifts through it; take the error from independent replicas. \"few samples: unchecked\": "
                        "the window held too few samples (≤ 90) to test the blocking for a plateau).")
    return s


def appendix(run, ctx):
    s = Section("Appendix: every summary.json value, the case file, the HDF5 contents", "appendix")
    s.table(["summary.json key", "value"], [[f"`{k}`", fmt(v)] for k, v in run.flat_summary()])
    case = run.text("/case/case.toml")
    if case:
        s.code(case, "case.toml as run (from /case/case.toml)")
    lines = []

    def visit(name, obj):
        shape = getattr(obj, "shape", None)
        lines.append(f"/{name}" + (f"  {shape}" if shape is not None else "/"))
        if shape is None:  # a group: its soft links too (visititems skips them; EDMD's /series/*)
            for k in obj:
                link = obj.get(k, getlink=True)
                if isinstance(link, h5py.SoftLink):
                    lines.append(f"/{name}/{k}  -> {link.path}")

    run.h5.visititems(visit)
    s.code("\n".join(lines), f"results.h5 datasets ({run.out_dir}/results.h5; layout in docs/OUTPUT.md)")
    return s


def window_mask(t, t0):
    return np.asarray(t) >= t0
