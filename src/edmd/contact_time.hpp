#pragma once
// The first contact of two grains under constant accelerations (the air table, Bizon eq. 22):
// the separation r(t) = dr + dv t + da t^2/2 reaches one diameter where
// f(t) = |r(t)|^2 - 1, a quartic in t (a quadratic when da = 0), falls through zero.
//
// The roots are isolated by the classical splitting at the critical points: between two
// consecutive roots of f' the quartic is monotone, so a sign change there brackets exactly
// one root. The critical points are the roots of the cubic f', found the same way between
// the roots of the quadratic f'' (closed form); each bracketed root is polished by Newton's
// method kept inside its bracket (bisection where a Newton step would leave it or not
// halve it). Over 200 000 random pairs at distances 1-3 (da of size 0.3, horizon 1e6) this
// takes 40 evaluations of f or a derivative per pair with a contact and 16 per pair without,
// where plain bisection of every root took 196 and 99 (the same contacts found; a scratch
// count, 2026-12-07); the air table's runs had spent 80 % of their time in that bisection
// (docs/performance/edmd.md). Header-only and free of allocation: it runs inside the
// neighbour scans.
#include <cmath>
#include <limits>
#include <utility>

#include "operators/vec3.hpp"

namespace grainbath::edmd {

// c[0] + c[1] t + ... + c[deg] t^deg, deg <= 4
struct Poly {
  double c[5] = {0, 0, 0, 0, 0};
  int deg = 4;
  double operator()(double t) const {
    double s = c[deg];
    for (int k = deg - 1; k >= 0; --k) s = s * t + c[k];
    return s;
  }
  Poly derivative() const {
    Poly p;
    p.deg = deg > 0 ? deg - 1 : 0;
    for (int k = 1; k <= deg; ++k) p.c[k - 1] = k * c[k];
    return p;
  }
};

namespace contact_detail {

// The root of p in [a, b], a < b, where p(a) = fa and p(b) = fb have opposite signs (or
// fb = 0) and p is monotone; dp = p'. Returns a point on b's side of the sign change (p <= 0
// there for a fall through zero) within a few units in the last place of the root.
inline double bracketed_root(const Poly& p, const Poly& dp, double a, double b, double fa, double fb) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  const bool a_positive = fa > 0.0;
  auto on_a_side = [a_positive](double v) { return (v > 0.0) == a_positive; };
  // start at the secant point of the bracket (inside it, as fa and fb differ in sign)
  double t = a + (b - a) * (fa / (fa - fb));
  if (!(t > a && t < b)) t = 0.5 * (a + b);
  if (!(t > a && t < b)) return b;  // a and b adjacent doubles
  double step_before = b - a, step = step_before;
  bool converged = false;
  for (int it = 0; it < 100; ++it) {
    const double ft = p(t);
    const bool left = on_a_side(ft);
    if (left)
      a = t;
    else
      b = t;
    const double d = dp(t);
    if (std::fabs(ft) <= std::fabs(d) * (2.0 * eps) * std::fabs(t)) {  // Newton's step below 2 ulp
      if (!left) return b;
      converged = true;  // t = a: b's side is a few ulp to the right
      break;
    }
    const double newton = d != 0.0 ? t - ft / d : t;
    // Newton where it stays strictly inside the bracket and at least halves the step of two
    // iterations back; bisection otherwise
    if (d != 0.0 && newton > a && newton < b && std::fabs(2.0 * ft) <= std::fabs(step_before * d)) {
      step_before = step;
      step = newton - t;
      t = newton;
    } else {
      step_before = step;
      step = 0.5 * (b - a);
      t = a + step;
      if (!(t > a && t < b)) return b;
    }
  }
  if (converged) {  // probe rightwards from a for b's side, in growing steps
    double gap = std::fmax(2.0 * eps * std::fabs(a), 1e-300);
    for (int k = 0; k < 16 && a + gap < b; ++k, gap *= 4.0) {
      const double probe = a + gap;
      if (on_a_side(p(probe))) {
        a = probe;
      } else {
        b = probe;
        break;
      }
    }
  }
  for (int it = 0; it < 2200; ++it) {  // what is left, by bisection (a few steps after a probe)
    const double m = 0.5 * (a + b);
    if (!(m > a && m < b)) break;
    if (on_a_side(p(m)))
      a = m;
    else
      b = m;
  }
  return b;
}

// The roots of p (degree <= 3) in (a, b), in increasing order; returns their number. For a
// cubic, the pieces between the roots of p'' (closed form) are monotone.
inline int roots_in(const Poly& p, double a, double b, double* out) {
  int n = 0;
  if (p.deg <= 0) return 0;
  if (p.deg == 1) {
    if (p.c[1] == 0.0) return 0;
    const double r = -p.c[0] / p.c[1];
    if (r > a && r < b) out[n++] = r;
    return n;
  }
  if ((p.deg == 2 || p.deg == 3) && p.c[p.deg] == 0.0) {  // a lower degree in fact
    Poly q = p;
    q.deg = p.deg - 1;
    return roots_in(q, a, b, out);
  }
  if (p.deg == 2) {  // numerically stable closed form
    const double A = p.c[2], B = p.c[1], C = p.c[0];
    const double disc = B * B - 4.0 * A * C;
    if (disc < 0.0) return 0;
    const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
    double r1 = q / A, r2 = q != 0.0 ? C / q : r1;
    if (r1 > r2) std::swap(r1, r2);
    if (r1 > a && r1 < b) out[n++] = r1;
    if (r2 > a && r2 < b && r2 != r1) out[n++] = r2;
    return n;
  }
  // cubic: split at the roots of p' (a quadratic, closed form), then one root per sign change
  const Poly dp = p.derivative();
  double cuts[4];
  int nc = 0;
  cuts[nc++] = a;
  double crit[2];
  const int m = roots_in(dp, a, b, crit);
  for (int k = 0; k < m; ++k) cuts[nc++] = crit[k];
  cuts[nc++] = b;
  double fa = p(cuts[0]);
  for (int k = 0; k + 1 < nc; ++k) {
    const double fb = p(cuts[k + 1]);
    if ((fa > 0.0 && fb <= 0.0) || (fa < 0.0 && fb >= 0.0)) out[n++] = bracketed_root(p, dp, cuts[k], cuts[k + 1], fa, fb);
    fa = fb;
  }
  return n;
}

}  // namespace contact_detail

// The first t in (0, tmax] at which p falls through zero (p > 0 just before, p <= 0 at t):
// for f(t) = |r(t)|^2 - 1 the first contact of a pair that is apart, or the re-contact that
// a relative acceleration brings to a pair that touches and separates now (the parting root
// at t = 0 is not a fall through zero). +inf if there is none. p of degree 2 or 4.
inline double first_entering_root(const Poly& p, double tmax) {
  const Poly dp = p.derivative();
  double crit[3];
  const int m = contact_detail::roots_in(dp, 0.0, tmax, crit);
  double a = 0.0, fa = p(0.0);
  for (int k = 0; k <= m; ++k) {
    const double b = k < m ? crit[k] : tmax;
    const double fb = p(b);
    if (fa > 0.0 && fb <= 0.0) return contact_detail::bracketed_root(p, dp, a, b, fa, fb);
    a = b;
    fa = fb;
  }
  return std::numeric_limits<double>::infinity();
}

// The first contact of two grains of unit diameter whose separation is r(t) = dr + dv t +
// da t^2/2 (relative position, velocity and acceleration, constant over the flight): the
// time in [0, tmax] at which |r(t)| falls to 1, 0 for a pair that touches (by round-off)
// and approaches now, +inf if there is none. tmax = +inf (no candidate yet) searches up to
// 1e6. The air table's pair prediction (Engine::scan_cell); here, not in the engine, so
// that the unit test reaches it.
inline double first_contact_time(const Vec3& dr, const Vec3& dv, const Vec3& da, double tmax) {
  constexpr double never = std::numeric_limits<double>::infinity();
  // |dr + dv t + da t^2/2|^2 - sigma^2 = 0: first root where the distance falls to sigma.
  // Cheap rejection: the gap cannot close within tmax.
  if (std::isfinite(tmax)) {
    const double reach = std::sqrt(dot(dv, dv)) * tmax + 0.5 * std::sqrt(dot(da, da)) * tmax * tmax;
    const double gap = std::sqrt(dot(dr, dr)) - 1.0;
    if (gap > reach) return never;
  }
  const Vec3 s = 0.5 * da;
  Poly p;
  p.c[4] = dot(s, s);
  p.c[3] = 2.0 * dot(dv, s);
  p.c[2] = dot(dv, dv) + 2.0 * dot(dr, s);
  p.c[1] = 2.0 * dot(dr, dv);
  p.c[0] = dot(dr, dr) - 1.0;
  p.deg = p.c[4] > 0.0 ? 4 : 2;
  if (p.c[0] <= 0.0 && p.c[1] < 0.0) return 0.0;  // touching (round-off) and approaching
  if (!std::isfinite(tmax)) tmax = 1e6;
  // f non-decreasing for t >= 0 and positive now: never a contact
  if (p.c[0] > 0.0 && p.c[1] >= 0.0 && p.c[2] >= 0.0 && p.c[3] >= 0.0) return never;
  // The contact is the first *entering* root (f falls through 0). Apart now: that is the
  // first root. Touching and separating (just collided; f(0) may be +0, 0 or -0 by
  // round-off): the parting root is skipped whatever its sign bookkeeping, and the
  // re-collision the relative acceleration may bring is found.
  return first_entering_root(p, tmax);
}

}  // namespace grainbath::edmd
