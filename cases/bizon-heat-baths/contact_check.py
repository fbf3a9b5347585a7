#!/usr/bin/env python3
"""g(sigma+) of driven inelastic disks: the pair histogram against what the collisions fix.

Usage: /usr/bin/python3 cases/bizon-heat-baths/contact_check.py RUN_DIR [RUN_DIR ...]
(--out directories of 2D EDMD runs with the same case and different seeds, e.g. the
Boltzmann bath with --set sampling.gr_bin=0.005). Prints mean +- standard error over the runs
(one number per run: independent seeds).

What is exact (docs/edmd.md, "Contact values of inelastic grains"): a pair at separation
sigma < r < sigma + dr approaching with normal speed u reaches contact within dr/u, and a pair
receding there collided within the last dr/u' (u' = e(u) u its post-collision normal speed).
So, with R the collision rate of the box and <.>_c an average over collisions (of the
pre-collision normal speed u, here from the normal-speed histogram),
    g_in(sigma+)  = omega <1/u>_c     / (2 pi n' sigma)      (approaching pairs)
    g_out(sigma+) = omega <1/(e u)>_c / (2 pi n' sigma)      (receding pairs)
    g(sigma+) = g_in + g_out,  n' = (N - 1)/V, omega = 2R/N,
whatever the pair velocity distribution (molecular chaos or not). Under molecular chaos
with e = 1, <1/u>_c = sqrt(pi/T)/2 and g_in = g_out = g/2. The virial and rate estimates
divide by molecular-chaos averages instead:
    collision.g_contact_from_rate = omega / (2 n sigma sqrt(pi T)),
    pressure.g_contact_weighted_e = g_from_rate * <u>_c / sqrt(pi T)   (identity),
    pressure.g_contact            = g_weighted_e * <(1 + e) u>_c / ((1 + <e>) <u>_c).
Also printed: least-squares fits of the histogram's bins (shell averages, exact moments, as
PairStatistics::contact_value) over windows [1, 1 + h] and polynomial orders 1-4, on the run's
bins and re-binned 4x, each as a ratio to the collisions' g(sigma+).
"""
import importlib.util
import json
import os
import sys

import h5py
import numpy as np


# the fit of the bins' shell averages (exact moments), shared with the elastic check
_spec = importlib.util.spec_from_file_location(
    "hard_disk_contact_check",
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "hard-disk-eos", "contact_check.py"))
_elastic = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_elastic)
shell_moments, contact = _elastic.shell_moments, _elastic.contact


def rebin(edges, g, f):
    sh = edges[1:] ** 2 - edges[:-1] ** 2
    n = len(g) // f * f
    G = (g[:n] * sh[:n]).reshape(-1, f).sum(1) / sh[:n].reshape(-1, f).sum(1)
    return edges[: n + 1 : f], G


def restitution(par):
    law = json.loads(par["restitution.law"])  # attributes hold JSON text
    if law == "elastic":
        return lambda u: np.ones_like(u)
    if law == "constant":
        e = float(par["restitution.e"])
        return lambda u: np.full_like(u, e)
    if law == "bizon":
        ec, v0 = float(par["restitution.e"]), float(par["restitution.crossover"])
        return lambda u: np.where(u >= v0, ec, 1.0 - (1.0 - ec) * (np.abs(u) / v0) ** 0.75)
    raise SystemExit(f"restitution law {law}: not handled here")


def get(s, path):
    for k in path.split("."):
        s = s[k]
    return float(s)


def main(runs):
    res = {}
    for run in runs:
        s = json.load(open(os.path.join(run, "summary.json")))
        with h5py.File(os.path.join(run, "results.h5"), "r") as f:
            r = f["observables/gr/r"][()]
            g = f["observables/gr/g"][()]
            c = f["observables/normal_speed/vn_over_sqrtT"][()]
            p = f["observables/normal_speed/density"][()] * (c[1] - c[0])  # fraction of collisions per bin
            par = dict(f["parameters"].attrs)
        nu, N = float(par["edmd.packing_fraction"]), int(par["edmd.particles"])
        T, omega = get(s, "temperature.mean"), get(s, "collision.frequency")
        e_of = restitution(par)
        u = c * np.sqrt(T)
        inv_u = (p / u).sum() / p.sum()
        inv_eu = (p / (e_of(u) * u)).sum() / p.sum()
        n1 = (N - 1) / N * 4 * nu / np.pi  # (N - 1)/V, sigma = 1
        g_in = omega * inv_u / (2 * np.pi * n1)
        g_out = omega * inv_eu / (2 * np.pi * n1)
        g_kin = g_in + g_out
        dr = r[1] - r[0]
        edges = np.append(r - dr / 2, r[-1] + dr / 2)
        add = lambda k, v: res.setdefault(k, []).append(v)
        add("temperature.mean", T)
        add("velocity.a2", get(s, "velocity.a2"))
        add("restitution.mean_e", get(s, "restitution.mean_e"))
        add("collision.vn_over_sqrt_piT  <u>_c/sqrt(pi T)", get(s, "collision.vn_over_sqrt_piT"))
        add("collision.vn2_over_4T       <u^2>_c/(4T)", get(s, "collision.vn2_over_4T"))
        add("<1/u>_c / (sqrt(pi/T)/2)     (1 under chaos)", inv_u / (0.5 * np.sqrt(np.pi / T)))
        add("<1/(e u)>_c / <1/u>_c        (receding excess)", inv_eu / inv_u)
        add("g_in(sigma+)  from collisions", g_in)
        add("g_out(sigma+) from collisions", g_out)
        add("g(sigma+) = g_in + g_out  [A]", g_kin)
        add("g_r.contact_fit (quadratic, [1, 1.1])", get(s, "g_r.contact_fit"))
        add("pressure.g_contact", get(s, "pressure.g_contact"))
        add("pressure.g_contact_weighted_e", get(s, "pressure.g_contact_weighted_e"))
        add("collision.g_contact_from_rate", get(s, "collision.g_contact_from_rate"))
        add("ratio g_r.contact_fit / A", get(s, "g_r.contact_fit") / g_kin)
        add("ratio pressure.g_contact / A", get(s, "pressure.g_contact") / g_kin)
        add("ratio pressure.g_contact_weighted_e / A", get(s, "pressure.g_contact_weighted_e") / g_kin)
        add("ratio collision.g_contact_from_rate / A", get(s, "collision.g_contact_from_rate") / g_kin)
        add("ratio 2 g_in / A", 2 * g_in / g_kin)
        for fac in (1, 4) if dr < 0.0075 else (1,):
            e, G = rebin(edges, g, fac)
            for h in (0.01, 0.02, 0.03, 0.05, 0.1, 0.2):
                for order in (1, 2, 3, 4):
                    v = contact(e, G, h, order)
                    if np.isfinite(v):
                        add(f"fit / A: bins {fac * dr:.3f}, [1, {1 + h:.2f}], order {order}", v / g_kin)
    print(f"{len(runs)} runs; mean +- standard error over the runs (sd)")
    for k, v in res.items():
        v = np.array(v)
        se = v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.nan
        sd = v.std(ddof=1) if len(v) > 1 else np.nan
        print(f"  {k:58s} {v.mean():9.5f} +- {se:.5f}  ({sd:.5f})")


if __name__ == "__main__":
    main(sys.argv[1:])
