#!/usr/bin/env python3
"""Tables and figure of cases/vibrated-walls from output/<run>/ (made by run.py).

  /usr/bin/python3 cases/vibrated-walls/plot.py [--out DIR]

Writes balance.csv (mean temperature vs the energy balance), eos.csv (local equation of
state), fourier.csv (generalised Fourier law fits), tails.csv (velocity-distribution tail
weights) and vibrated-walls.png into DIR (default output/ beside this script, beside the runs;
git ignores it), then compares each table with the shipped one beside this script
(scripts/compare_tables.py). `--out cases/vibrated-walls` replaces the shipped ones."""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

import h5py
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
outdir = os.path.join(here, "output")
tables = outdir  # where the tables and the figure go (--out)


def z_henderson(nu):
    return (1 + nu * nu / 8) / (1 - nu) ** 2


def g_henderson(nu):  # Bizon eq. 5 contact value, Z = 1 + 2 nu g
    return (1 - 7 * nu / 16) / (1 - nu) ** 2


def load(name):
    d = os.path.join(outdir, name)
    if not os.path.exists(os.path.join(d, "summary.json")):
        return None
    s = json.load(open(os.path.join(d, "summary.json")))
    f = h5py.File(os.path.join(d, "results.h5"), "r")
    p = {k: f["profiles"][k][()] for k in f["profiles"].keys() if k != "velocity_histogram"}
    h = {k: f["profiles/velocity_histogram"][k][()] for k in f["profiles/velocity_histogram"].keys()}
    params = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f["parameters"].attrs.items()}
    return {"name": name, "s": s, "p": p, "h": h, "params": params}


def param(run, key, default=None):
    v = run["params"].get(key, default)
    try:
        return float(v)
    except (TypeError, ValueError):
        return v


def interior(run, skip):
    n = len(run["p"]["z"])
    return slice(skip, n - skip)


def eos_rows(run):
    p, e = run["p"], param(run, "restitution.e", 1.0)
    sl = interior(run, 1)
    n, T, pr = p["density"][sl], p["T"][sl], p["p"][sl]
    nu = n * math.pi / 4
    r_el = pr / (n * T * z_henderson(nu))
    r_in = pr / (n * T * (1 + (1 + e) * nu * g_henderson(nu)))
    return r_el, r_in, nu


def fourier_fit(run, skip=2):
    """q_x = -kappa dT/dx - mu dn/dx over the interior slabs, weighted by 1/stderr(q)^2."""
    p = run["p"]
    z, T, n, q, qe = p["z"], p["T"], p["density"], p["q_x"], p["q_x_stderr"]
    dT, dn = np.gradient(T, z), np.gradient(n, z)
    sl = interior(run, skip)
    A = np.column_stack([-dT[sl], -dn[sl]])
    w = 1.0 / np.maximum(qe[sl], 1e-300)
    y = q[sl]
    out = {}
    for label, cols in (("two", [0, 1]), ("one", [0])):
        Aw = A[:, cols] * w[:, None]
        coef, *_ = np.linalg.lstsq(Aw, y * w, rcond=None)
        res = (y - A[:, cols] @ coef) * w
        dof = max(1, len(y) - len(cols))
        cov = np.linalg.inv(Aw.T @ Aw) * max(1.0, (res @ res) / dof)
        out[label] = {"coef": coef, "err": np.sqrt(np.diag(cov)), "chi2_dof": (res @ res) / dof}
    return out


def slab_energy_balance(run):
    """Steady slab energy balance with u = 0: q(x_k) - q(x_1) = -Int loss dx. Returns the rms
    residual over the interior slabs / max|q|, for the total and for the kinetic flux alone."""
    p = run["p"]
    z, L = p["z"], p["loss_rate"]
    w = z[1] - z[0]
    cum = np.concatenate([[0.0], np.cumsum(w * (L[1:] + L[:-1]) / 2)])
    sl = slice(1, len(z) - 1)
    out = []
    for key in ("q_x", "q_kin_x"):
        q = p[key]
        r = (q - (q[1] - (cum - cum[1])))[sl]
        out.append(float(np.sqrt(np.mean(r * r)) / np.max(np.abs(p["q_x"]))))
    return out


def main():
    global tables
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=outdir, help="where the tables and the figure go")
    tables = ap.parse_args().out
    os.makedirs(tables, exist_ok=True)
    names = sorted(d for d in (os.listdir(outdir) if os.path.isdir(outdir) else [])
                   if not d.endswith(".previous") and os.path.exists(os.path.join(outdir, d, "summary.json")))
    if not names:
        raise SystemExit(f"plot.py: no finished runs in {outdir} (run.py makes them)")
    runs = {n: load(n) for n in names}
    # ---- energy balance -----------------------------------------------------------------
    rows = []
    for n, r in runs.items():
        s = r["s"]
        th, w = s["theory"], s["walls"]
        rows.append({"run": n, "e": param(r, "restitution.e"), "nu": param(r, "edmd.packing_fraction"),
                     "T": s["temperature"]["mean"], "T_err": s["temperature"]["stderr"],
                     "T_balance_enskog": th["wall_balance_temperature"],
                     "T_balance_dilute": th["wall_balance_temperature_dilute"],
                     "T_balance_thesis_reading": th["wall_balance_temperature_thesis_reading"],
                     "T_over_balance": w["temperature_over_balance"],
                     "T_over_balance_dilute": w["temperature_over_balance_dilute"],
                     "input_minus_loss_over_loss": w["balance"], "balance_err": w["balance_stderr"],
                     "wall_hits": w["hits_low"] + w["hits_high"]})
        # replicas of run.py --seeds=...: mean and standard error of T/T_bal over seed 1 and them
        # (the blocked T_err of one run is a lower bound in the near-elastic runs)
        ratios, errs = [w["temperature_over_balance"]], [s["temperature"]["stderr"]]
        sdir = os.path.join(here, "output-seeds", n)
        if os.path.isdir(sdir):
            for k in sorted(os.listdir(sdir)):
                f = os.path.join(sdir, k, "summary.json")
                if os.path.exists(f):
                    sk = json.load(open(f))
                    ratios.append(sk["walls"]["temperature_over_balance"])
                    errs.append(sk["temperature"]["stderr"])
        v = np.array(ratios)
        sd = v.std(ddof=1) if len(v) > 1 else float("nan")
        rms = math.sqrt(np.mean(np.array(errs) ** 2)) / th["wall_balance_temperature"]
        rows[-1].update({"seeds": len(v), "T_over_balance_seeds": v.mean(),
                         "T_over_balance_seeds_sem": sd / math.sqrt(len(v)),
                         "T_scatter_over_T_err": sd / rms})
    write_csv("balance.csv", rows)
    # ---- local EOS and Fourier fits -------------------------------------------------------
    eos, four = [], []
    for n, r in runs.items():
        r_el, r_in, nu = eos_rows(r)
        eos.append({"run": n, "e": param(r, "restitution.e"), "nu_global": param(r, "edmd.packing_fraction"),
                    "nu_local_min": nu.min(), "nu_local_max": nu.max(),
                    "p_over_elastic_eos_mean": r_el.mean(), "p_over_elastic_eos_min": r_el.min(),
                    "p_over_elastic_eos_max": r_el.max(), "p_over_enskog_inelastic_mean": r_in.mean(),
                    "p_over_enskog_inelastic_min": r_in.min(), "p_over_enskog_inelastic_max": r_in.max()})
        f = fourier_fit(r)
        p = r["p"]
        sl = interior(r, 2)
        four.append({"run": n, "e": param(r, "restitution.e"), "nu": param(r, "edmd.packing_fraction"),
                     "kappa": f["two"]["coef"][0], "kappa_err": f["two"]["err"][0],
                     "mu": f["two"]["coef"][1], "mu_err": f["two"]["err"][1], "chi2_dof_two": f["two"]["chi2_dof"],
                     "kappa_one": f["one"]["coef"][0], "chi2_dof_one": f["one"]["chi2_dof"],
                     "q_col_over_q_max": float(np.nanmax(np.abs(p["q_col_x"][sl])) / np.nanmax(np.abs(p["q_x"][sl]))),
                     "Pxx_col_over_Pxx_centre": float(p["P_col_xx"][len(p["z"]) // 2] / p["P_xx"][len(p["z"]) // 2]),
                     "Pxx_spread": float(np.std(p["P_xx"][interior(r, 1)]) / np.mean(p["P_xx"][interior(r, 1)])),
                     "slab_balance_rms_q_total": slab_energy_balance(r)[0],
                     "slab_balance_rms_q_kin_only": slab_energy_balance(r)[1]})
    write_csv("eos.csv", eos)
    write_csv("fourier.csv", four)
    # ---- tails (main run): weight beyond 3 and 4 thermal widths, wall slab vs centre ------------
    tails = []
    m = runs.get("main")
    if m is not None:
        h, p = m["h"], m["p"]
        v = h["v"]
        S = len(p["z"])
        for label, slabs in (("wall", [1, S - 2]), ("centre", [S // 2 - 1, S // 2])):
            for a, comp in enumerate("xy"):
                cnt = sum(h["counts"][k, a, :] for k in slabs)
                Ta = np.mean([p["T_" + comp][k] for k in slabs])
                c = np.abs(v) / math.sqrt(Ta)
                tot = cnt.sum()
                row = {"region": label, "component": comp, "T_component": Ta}
                for cut in (2.0, 3.0, 4.0):
                    row[f"P(|c|>{cut:g})"] = cnt[c > cut].sum() / tot
                    row[f"gauss(|c|>{cut:g})"] = math.erfc(cut / math.sqrt(2))
                tails.append(row)
        write_csv("tails.csv", tails)
    figure(runs, rows, four)
    pairs = []
    if os.path.realpath(tables) != os.path.realpath(here):
        pairs = [p for name in ("balance.csv", "eos.csv", "fourier.csv", "tails.csv")
                 if os.path.exists(os.path.join(tables, name))
                 for p in (os.path.join(here, name), os.path.join(tables, name))]
    if pairs:  # (no table written: nothing to compare, and compare_tables.py refuses no arguments)
        subprocess.run([sys.executable, os.path.join(here, "..", "..", "scripts", "compare_tables.py")] + pairs,
                       check=True)


def write_csv(name, rows):
    if not rows:
        return
    with open(os.path.join(tables, name), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    print(f"--- {name}")
    for r in rows:
        print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()))


def figure(runs, rows, four):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(2, 3, figsize=(15, 9))
    m = runs.get("main")
    if m is not None:
        p = m["p"]
        z = p["z"]
        a = ax[0, 0]
        a.errorbar(z, p["density"] / np.mean(p["density"]), p["density_stderr"] / np.mean(p["density"]), label="n / <n>")
        a.errorbar(z, p["T_x"] / np.mean(p["T"]), p["T_x_stderr"] / np.mean(p["T"]), label="T_x / <T>")
        a.errorbar(z, p["T_y"] / np.mean(p["T"]), p["T_y_stderr"] / np.mean(p["T"]), label="T_y / <T>")
        a.set_xlabel("x (sigma)")
        a.set_title("main (nu = 0.1, e = 0.9): density and temperatures")
        a.legend()
        a = ax[0, 1]
        for k, st in (("P_xx", "-"), ("P_col_xx", "--"), ("P_yy", "-"), ("P_col_yy", "--"), ("P_xy", ":")):
            a.errorbar(z, p[k], p[k + "_stderr"], ls=st, label=k)
        a.set_xlabel("x (sigma)")
        a.set_title("stress tensor (kinetic + collisional)")
        a.legend()
        a = ax[0, 2]
        for k, st in (("q_x", "-"), ("q_kin_x", "--"), ("q_col_x", ":")):
            a.errorbar(z, p[k], p[k + "_stderr"], ls=st, label=k)
        f = fourier_fit(m)
        dT, dn = np.gradient(p["T"], z), np.gradient(p["density"], z)
        kap, mu = f["two"]["coef"]
        a.plot(z, -kap * dT - mu * dn, "k.", label=f"fit -k dT/dx - mu dn/dx")
        a.plot(z, -f["one"]["coef"][0] * dT, "r.", ms=3, label="Fourier (mu = 0)")
        a.set_xlabel("x (sigma)")
        a.set_title("heat flux")
        a.legend(fontsize=8)
    a = ax[1, 0]
    for n, r in sorted(runs.items()):
        if n.startswith("e") or n == "main" or n.startswith("dense"):
            r_el, r_in, nu = eos_rows(r)
            a.plot(nu, r_in, ".", label=f"{n}")
    a.axhline(1.0, color="k", lw=0.5)
    a.set_xlabel("local packing fraction")
    a.set_ylabel("p / [n T (1 + (1+e) nu g_H)]")
    a.set_title("local equation of state (interior slabs)")
    a.legend(fontsize=7)
    a = ax[1, 1]
    for prefix, lab in (("dilute-e", "nu = 0.05, L_x = 40"), ("e", "nu = 0.1, L_x = 112")):
        pts = sorted((r["e"], r["T_over_balance_seeds"] if r["seeds"] > 1 else r["T_over_balance"],
                      r["T_over_balance_seeds_sem"] if r["seeds"] > 1 else r["T_err"] / r["T_balance_enskog"],
                      r["T"] / r["T_balance_thesis_reading"])
                     for r in rows if r["run"].startswith(prefix) or (prefix == "e" and r["run"] == "main"))
        if pts:
            e_, y_, err_, th_ = zip(*pts)
            a.errorbar(1 - np.array(e_), y_, err_, marker="o", label=lab + " (Enskog balance)")
            a.plot(1 - np.array(e_), th_, "x--", label=lab + " (thesis reading of B.1)")
    a.set_xscale("log")
    a.axhline(1.0, color="k", lw=0.5)
    a.set_xlabel("1 - e")
    a.set_ylabel("T / T_balance")
    a.set_title("mean temperature vs energy balance")
    a.legend(fontsize=7)
    a = ax[1, 2]
    if m is not None:
        h, p = m["h"], m["p"]
        S = len(p["z"])
        v = h["v"]
        dv = v[1] - v[0]
        for label, slabs in (("wall", [1, S - 2]), ("centre", [S // 2 - 1, S // 2])):
            for ai, comp in enumerate("xy"):
                cnt = sum(h["counts"][k, ai, :] for k in slabs)
                Ta = np.mean([p["T_" + comp][k] for k in slabs])
                c = v / math.sqrt(Ta)
                dens = cnt / cnt.sum() / (dv / math.sqrt(Ta))
                ok = dens > 0
                a.semilogy(c[ok], dens[ok], ".", ms=3, label=f"{label} v_{comp}")
        cc = np.linspace(-6, 6, 200)
        a.semilogy(cc, np.exp(-cc * cc / 2) / math.sqrt(2 * math.pi), "k-", lw=0.8, label="Gaussian")
        a.set_xlim(-8, 8)
        a.set_ylim(1e-7, 1)
        a.set_xlabel("v_a / sqrt(T_a)")
        a.set_title("velocity distributions (main)")
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(tables, "vibrated-walls.png"), dpi=110)
    print(f"wrote {os.path.join(tables, 'vibrated-walls.png')}")


if __name__ == "__main__":
    main()
