#!/usr/bin/env python3
"""Linear Sonine approximations of order K = 2..6 for the homogeneous cooling state of d = 3
hard spheres with constant restitution e (docs/closures.md Sec. H.8): the truncation estimate
behind the tolerance of the free-cooling tests. An independent implementation of the same
collision moments as closures/hcs.cpp (numpy/scipy rules; Sonine polynomials from scipy's
generalised Laguerre), linear in a_2 .. a_K; K = 2 is van Noije-Ernst, K = 3 the linear second
Sonine approximation of closures::hcs_sonine2_linear (same numbers to ~1e-12).

f(c) = phi(c) [1 + sum_{k=2}^K a_k S_k(c^2)], c = v/sqrt(2T/m); steady scaled state:
mu_{2k} = (2k/3) mu_2 <c^{2k}>, k = 2..K (docs eq. H4), linearised in the a_k.

usage: /usr/bin/python3 scripts/hcs_sonine_series.py [e ...]
"""
import argparse

import numpy as np
from numpy.polynomial.hermite import hermgauss
from numpy.polynomial.laguerre import laggauss
from numpy.polynomial.legendre import leggauss
from scipy.special import eval_genlaguerre, gamma, roots_genlaguerre

KMAX = 6


def sonine(k, x):
    return eval_genlaguerre(k, 0.5, x)


def table():
    """T[k, l, t]: coefficient of lambda^l (lambda = (1+e)/2) in mu_{2k} for the weight term t
    (t = 0: 1; t = j >= 2: S_j(x1) + S_j(x2)). Exact Gauss rules (docs eq. H5): the integrand
    has degree <= 4 KMAX in G, <= 2 KMAX + 1 in u = g^2/2 and <= 2 KMAX + 2 in cos(g, n)."""
    hx, hw = hermgauss(2 * KMAX + 2)
    lx, lw = laggauss(2 * KMAX + 4)
    mx, mw = leggauss(2 * KMAX + 2)
    mx, mw = 0.5 * (mx + 1), 0.5 * mw
    gx, gw = hx / np.sqrt(2), hw / np.sqrt(np.pi)          # G ~ N(0, I/4) per axis
    GX, GY, GZ = [a.ravel() for a in np.meshgrid(gx, gx, gx, indexing="ij")]
    GW = (gw[:, None, None] * gw[None, :, None] * gw[None, None, :]).ravel()
    T = np.zeros((KMAX + 1, 2 * KMAX + 1, KMAX + 1))
    norm = (2 * np.pi) ** -1.5 * 4 * np.pi * 2 * np.pi      # g density, hemisphere azimuth
    for u, wu in zip(lx, lw):
        r = np.sqrt(2 * u)
        for mu, wm in zip(mx, mw):
            q, sn = r * mu, np.sqrt(1 - mu * mu)                # q = g.n
            w = -0.5 * norm * wu * wm * r * q * GW               # r^2 dr = r du; factor (g.n)
            z1, z2 = GZ + r / 2, GZ - r / 2
            x1, x2 = GX**2 + GY**2 + z1**2, GX**2 + GY**2 + z2**2
            c1n, c2n = GX * sn + z1 * mu, GX * sn + z2 * mu
            W = [np.ones_like(x1), None] + [sonine(j, x1) + sonine(j, x2) for j in range(2, KMAX + 1)]
            A1 = [x1, -2 * q * c1n, np.full_like(x1, q * q)]   # c1'^2 in powers of lambda
            A2 = [x2, 2 * q * c2n, np.full_like(x2, q * q)]
            P1, P2 = [np.ones_like(x1)], [np.ones_like(x2)]
            for k in range(1, KMAX + 1):
                N1 = [np.zeros_like(x1) for _ in range(2 * k + 1)]
                N2 = [np.zeros_like(x1) for _ in range(2 * k + 1)]
                for i in range(len(P1)):
                    for j in range(3):
                        N1[i + j] = N1[i + j] + P1[i] * A1[j]
                        N2[i + j] = N2[i + j] + P2[i] * A2[j]
                P1, P2 = N1, N2
                for l in range(1, 2 * k + 1):
                    d = w * (P1[l] + P2[l])
                    for t in range(KMAX + 1):
                        if t != 1:
                            T[k, l, t] += np.sum(d * W[t])
    return T


def solve(T, e, K):
    lam = (1 + e) / 2
    coef = lambda k: sum(lam**l * T[k, l] for l in range(2 * k + 1))
    xs, ws = roots_genlaguerre(40, 0.5)
    ws = ws / gamma(1.5)                                     # <.> over phi in x = c^2
    c2 = coef(1)
    A, b = np.zeros((K - 1, K - 1)), np.zeros(K - 1)
    for i, k in enumerate(range(2, K + 1)):
        ck, f = coef(k), 2 * k / 3
        m = [np.sum(ws * xs**k)] + [0.0] + [np.sum(ws * xs**k * sonine(j, xs)) for j in range(2, K + 1)]
        b[i] = -(ck[0] - f * c2[0] * m[0])
        for jj, j in enumerate(range(2, K + 1)):
            A[i, jj] = ck[j] - f * (c2[0] * m[j] + c2[j] * m[0])
    return np.linalg.solve(A, b)


def main(es):
    T = table()
    print("linear Sonine approximations of order K (a_2, and a_3 where K >= 3)")
    print(f"{'e':>5s} " + " ".join(f"{'K=%d a2' % K:>10s}" for K in range(2, KMAX + 1)) + "   "
          + " ".join(f"{'K=%d a3' % K:>10s}" for K in range(3, KMAX + 1)))
    for e in es:
        s = [solve(T, e, K) for K in range(2, KMAX + 1)]
        print(f"{e:5.2f} " + " ".join(f"{x[0]:+10.6f}" for x in s) + "   "
              + " ".join(f"{x[1]:+10.6f}" for x in s[1:]))


if __name__ == "__main__":
    ap = argparse.ArgumentParser(prog="hcs_sonine_series.py", description="Linear Sonine approximations of the "
                                 "homogeneous cooling state (see the top of this file).")
    ap.add_argument("e", nargs="*", type=float, help="restitution coefficients (default 0.95 0.9 ... 0.2 0.0)")
    main(ap.parse_args().e or [0.95, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.0])
