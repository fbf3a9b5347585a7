#!/usr/bin/env python3
"""Slab-average bias of the conductivity analysis (src/edmd/transport.cpp, "T_plane", "dTdz").

Usage: /usr/bin/python3 cases/bizon-conductivity/gradient_bias.py RUN_DIR [RUN_DIR ...]
(RUN_DIR = a run's --out directory with results.h5 of a [transport] case).

What a slab holds is the slab average of the number density, n_k, and the slab average of
the kinetic energy density, e_k = n_k T_k (T_k is total kinetic energy / number in the slab,
i.e. density-weighted). The point values at a plane z_p that Fourier's law wants are
n(z_p), T(z_p) = e(z_p)/n(z_p) and T'(z_p). Three estimators of kappa/kappa_Enskog over the
summary's fit planes, each with a jackknife error over the stored blocks:
  two-point  : (T_k - T_{k-1})/w, T_plane and packing_plane the means of the two slabs
               (the analysis before 2026-12-05);
  fourth     : point values and derivatives at the plane from the cell averages of n and e
               (4-slab stencils exact for cubics: f = [7(a_k + a_{k-1}) - (a_{k+1} + a_{k-2})]/12,
               f' = [15(a_k - a_{k-1}) - (a_{k+1} - a_{k-2})]/(12 w)), T = e/n, T' = (e' - T n')/n;
  sixth      : the same with 6-slab stencils (exact for quintics): the size of what the
               fourth-order stencils leave.
The differences of the means are the bias (the same blocks: their jackknife error is the
error of the difference). A model check independent of the stencils: a smooth symmetric
profile (cosine series fitted to the cell averages), its exact slab averages by quadrature,
and the two estimators applied to them against the model's point values.
"""
import json
import os
import sys

import h5py
import numpy as np

PI = np.pi
ORDERS = (2, 4, 6, "ls6", "ls8")


def g_cs_disk(nu):  # Henderson, Bizon eq. 5 (theory::g_contact_disk_cs)
    return (1 - 7 * nu / 16) / (1 - nu) ** 2


def kappa_enskog_2d(nu, T):
    # theory::enskog_conductivity, D = 2: lam_0 [(1 + 3G/2)^2/chi + (4/pi) nu G], G = nu chi,
    # lam_0 = 2 sqrt(T/pi)
    chi = g_cs_disk(nu)
    G = nu * chi
    return 2 * np.sqrt(T / PI) * ((1 + 1.5 * G) ** 2 / chi + 4 / PI * nu * G)


def roll(a, s):  # a[k + s] (periodic)
    return np.roll(a, -s, axis=-1)


def stencil(m, deg):
    """Weights on the m slabs k - m/2 .. k + m/2 - 1 around plane k (z = 0, w = 1) giving the
    value and the slope at the plane of the least-squares polynomial of degree deg whose slab
    averages fit the m slab averages (m = deg + 1: interpolation)."""
    c = np.arange(m) - m / 2 + 0.5
    X = np.array([[((ci + 0.5) ** (j + 1) - (ci - 0.5) ** (j + 1)) / (j + 1) for j in range(deg + 1)] for ci in c])
    P = np.linalg.pinv(X)
    return P[0], P[1]


STENCILS = {4: (4, 3), 6: (6, 5), "ls6": (6, 3), "ls8": (8, 3)}


def apply(a, weights):
    m = len(weights)
    return sum(wt * roll(a, j - m // 2) for j, wt in enumerate(weights))


def plane_value(a, order):
    if order == 2:
        return 0.5 * (a + roll(a, -1))
    return apply(a, stencil(*STENCILS[order])[0])


def plane_slope(a, w, order):
    if order == 2:
        return (a - roll(a, -1)) / w
    return apply(a, stencil(*STENCILS[order])[1]) / w


def estimate(n, e, F, w, order):
    """kappa/kappa_Enskog per plane from slab averages n, e (last axis = slab)."""
    if order == 2:  # the two-point analysis: slab temperatures and packings averaged
        T = e / n
        Tp = plane_value(T, 2)
        dT = plane_slope(T, w, 2)
        nup = plane_value(n, 2) * PI / 4
    else:
        n_p, e_p = plane_value(n, order), plane_value(e, order)
        dn, de = plane_slope(n, w, order), plane_slope(e, w, order)
        Tp = e_p / n_p
        dT = (de - Tp * dn) / n_p
        nup = n_p * PI / 4
    kappa = -F / dT
    return kappa / kappa_enskog_2d(nup, Tp), Tp, dT, nup


def load(run):
    with h5py.File(os.path.join(run, "results.h5"), "r") as h:
        t = h["transport/blocks/time"][()]
        slab = h["transport/blocks/slab"][()]
        plane = h["transport/blocks/plane"][()]
        zp = h["transport/z_plane"][()]
        par = h["parameters"].attrs
        aspect = json.loads(par["edmd.aspect"]) if "edmd.aspect" in par else [1.0]
        dims = int(par["edmd.dimensions"])
    if any(a != 1.0 for a in aspect) or dims != 2:
        sys.exit(f"{run}: this analysis assumes a square 2D box (the cases' boxes)")
    S = slab.shape[1]
    w = zp[1] - zp[0]
    L = S * w
    A = L  # cross-section of the square 2D box
    return t, slab, plane, S, w, L, A


def sums_to_fields(time, slab, plane, w, A):
    V = A * w
    occ = slab[..., 3]
    n = occ / (time[..., None] * V)
    u = slab[..., 4:7] / occ[..., None]
    vv = np.stack([slab[..., 7 + 4 * p] for p in range(2)], axis=-1) / occ[..., None]
    T = (vv - u[..., :2] ** 2).sum(-1) / 2
    F = (plane[..., 0] + plane[..., 1]) / (A * time[..., None])
    return n, n * T, F


def jack(fn, t, slab, plane):
    tot = fn(t.sum(), slab.sum(0), plane.sum(0))
    loo = np.array([fn(t.sum() - t[b], slab.sum(0) - slab[b], plane.sum(0) - plane[b]) for b in range(len(t))])
    B = len(t)
    return tot, np.sqrt((B - 1) / B * ((loo - loo.mean(0)) ** 2).sum(0))


def cell_average(f, zc, w, q=64):
    x, wt = np.polynomial.legendre.leggauss(q)
    return np.array([0.5 * np.sum(wt * f(z + 0.5 * w * x)) for z in zc])


def main(runs):
    for run in runs:
        t, slab, plane, S, w, L, A = load(run)
        zp = np.arange(S) * w
        d = np.abs(zp - 0.5 * L) / (0.5 * L)
        sel = (d >= 0.2) & (d <= 0.8)
        summ = json.load(open(os.path.join(run, "summary.json")))
        kr_summary = summ["transport"]["kappa_over_enskog"]

        def scal(tt, sl, pl, order):
            n, e, F = sums_to_fields(tt, sl, pl, w, A)
            kr = estimate(n, e, F, w, order)[0]
            return kr[sel].mean()

        def all3(tt, sl, pl):
            return np.array([scal(tt, sl, pl, o) for o in ORDERS])

        val, err = jack(all3, t, slab, plane)

        def diffs(tt, sl, pl):
            v = all3(tt, sl, pl)
            return v[1:] / v[0] - 1

        dv, de = jack(diffs, t, slab, plane)
        print(f"== {run}: S = {S}, w = {w:.4f}, {len(t)} blocks; summary kappa_over_enskog = {kr_summary:.5f}")
        for name, v, e in zip([str(o) for o in ORDERS], val, err):
            print(f"   {name:5s} kappa/kappa0 = {v:.5f} +- {e:.5f}")
        print("   over the two-point one - 1: " + ", ".join(f"{o}: {x:+.5f} +- {y:.5f}" for o, x, y in zip(ORDERS[1:], dv, de)))
        # per-term split of the two-point bias (fourth as the reference), total run
        n, e, F = sums_to_fields(t.sum(), slab.sum(0), plane.sum(0), w, A)
        k2, T2, g2, nu2 = estimate(n, e, F, w, 2)
        k4, T4, g4, nu4 = estimate(n, e, F, w, 4)
        r_grad = (g4 / g2)[sel].mean() - 1  # kappa2/kappa4 from the gradient alone
        r_T = (kappa_enskog_2d(nu4, T4) / kappa_enskog_2d(nu4, T2))[sel].mean() - 1
        r_nu = (kappa_enskog_2d(nu4, T4) / kappa_enskog_2d(nu2, T4))[sel].mean() - 1
        print(f"   two-point vs fourth, per term (planes' mean): gradient {r_grad:+.5f}, T_plane {r_T:+.5f}, "
              f"packing_plane {r_nu:+.5f}")
        # model check: a smooth profile symmetric about the forcing peak (cosine series of M
        # modes fitted to the symmetrised cell averages: the noise is not fitted for small M),
        # its exact cell averages by Gauss-Legendre quadrature, the estimators applied to them
        # against the model's point values at the planes
        zc = (np.arange(S) + 0.5) * w
        ns, es = 0.5 * (n + n[::-1]), 0.5 * (e + e[::-1])
        for M in (4, 6, 8):
            m = np.arange(M + 1)
            kz = 2 * PI * m / L
            sinc = np.ones(M + 1)
            sinc[1:] = np.sin(kz[1:] * w / 2) / (kz[1:] * w / 2)
            X = np.cos(np.outer(zc - 0.5 * L, kz)) * sinc
            cn = np.linalg.lstsq(X, ns, rcond=None)[0]
            ce = np.linalg.lstsq(X, es, rcond=None)[0]

            def fz(c, z, der=0):
                ph = np.outer(np.atleast_1d(z) - 0.5 * L, kz)
                return np.cos(ph) @ c if der == 0 else -(np.sin(ph) * kz) @ c

            nbar = cell_average(lambda z: fz(cn, z), zc, w)
            ebar = cell_average(lambda z: fz(ce, z), zc, w)
            n_true, e_true = fz(cn, zp), fz(ce, zp)
            T_true = e_true / n_true
            dT_true = (fz(ce, zp, 1) - T_true * fz(cn, zp, 1)) / n_true
            Fm = -kappa_enskog_2d(n_true * PI / 4, T_true) * dT_true  # an Enskog fluid: kappa/kappa0 = 1
            res = []
            for order in ORDERS:
                kr = estimate(nbar, ebar, Fm, w, order)[0]
                res.append(f"order {order}: {kr[sel].mean() - 1:+.6f} (max plane {np.abs(kr[sel] - 1).max():.6f})")
            chi = max(np.abs(X @ cn - ns).max() / ns.mean(), np.abs(X @ ce - es).max() / es.mean())
            print(f"   model M = {M} (max misfit {chi:.1e}): kappa/kappa0 - 1 over the fit planes, " + "; ".join(res))

if __name__ == "__main__":
    main(sys.argv[1:])
