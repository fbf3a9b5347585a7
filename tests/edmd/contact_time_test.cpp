// The first contact time of two grains under constant accelerations (src/edmd/contact_time.hpp,
// the air table's pair prediction) against an independent reference: a branch-and-bound search
// for the first point where f(t) = |dr + dv t + da t^2/2|^2 - 1 is <= 0, in long double with
// interval bounds of the polynomial on each piece (a piece whose bound is positive holds no
// contact; the search goes left to right and halves the others down to 1e-15 relative), over
// random pairs that approach, recede and come back, graze, and touch while parting.
// Milliseconds to a second in Release.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <random>

#include "edmd/contact_time.hpp"

using namespace grainbath::edmd;

namespace {

using LD = long double;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Interval {
  LD lo, hi;
};

// f on [lo, hi] (lo >= 0) by interval Horner: an enclosure of its values there
Interval bound(const Poly& p, LD lo, LD hi) {
  Interval s{p.c[p.deg], p.c[p.deg]};
  for (int k = p.deg - 1; k >= 0; --k) {
    const LD a = s.lo * lo, b = s.lo * hi, c = s.hi * lo, d = s.hi * hi;
    s = {std::min({a, b, c, d}) + p.c[k], std::max({a, b, c, d}) + p.c[k]};
  }
  return s;
}

LD value(const Poly& p, LD t) {
  LD s = p.c[p.deg];
  for (int k = p.deg - 1; k >= 0; --k) s = s * t + p.c[k];
  return s;
}

// The first point of [lo, hi] where f may be <= 0 (to 1e-15 relative), or +inf; `nodes`
// counts the pieces looked at (the search gives up, returning NaN, beyond a budget).
LD first_nonpositive(const Poly& p, LD lo, LD hi, long& nodes) {
  if (++nodes > 2000000) return std::numeric_limits<LD>::quiet_NaN();
  if (bound(p, lo, hi).lo > 0) return std::numeric_limits<LD>::infinity();
  if (hi - lo <= 1e-15L * std::max<LD>(1, hi)) return lo;
  const LD mid = 0.5L * (lo + hi);
  const LD left = first_nonpositive(p, lo, mid, nodes);
  if (!std::isinf(left)) return left;
  return first_nonpositive(p, mid, hi, nodes);
}

Poly contact_poly(const double dr[3], const double dv[3], const double da[3]) {
  double rr = 0, rv = 0, vv = 0, rs = 0, vs = 0, ss = 0;
  for (int k = 0; k < 3; ++k) {
    const double s = 0.5 * da[k];
    rr += dr[k] * dr[k];
    rv += dr[k] * dv[k];
    vv += dv[k] * dv[k];
    rs += dr[k] * s;
    vs += dv[k] * s;
    ss += s * s;
  }
  Poly p;  // the coefficients as first_contact_time forms them
  p.c[4] = ss;
  p.c[3] = 2.0 * vs;
  p.c[2] = vv + 2.0 * rs;
  p.c[1] = 2.0 * rv;
  p.c[0] = rr - 1.0;
  p.deg = p.c[4] > 0.0 ? 4 : 2;
  return p;
}

struct Tally {
  int cases = 0, contacts = 0, none = 0, ambiguous = 0;
};

// One case: our root against the reference. A disagreement is accepted as ambiguous only
// where the reference's contact is a graze (|f'| tiny there: its time is ill-conditioned)
// or the search hit its budget.
void check_case(const Poly& p, double tmax, LD search_from, Tally& tally, const char* what) {
  ++tally.cases;
  const double ours = first_entering_root(p, tmax);
  long nodes = 0;
  const LD ref = first_nonpositive(p, search_from, tmax, nodes);
  if (std::isnan(ref)) {
    ++tally.ambiguous;
    return;
  }
  if (std::isinf(ref) && std::isinf(ours)) {
    ++tally.none;
    return;
  }
  const Poly dp = p.derivative();
  const LD slope = std::isinf(ref) ? 0 : value(dp, ref);
  const LD scale = std::max<LD>(1, std::isinf(ref) ? ours : ref);
  const bool agree = !std::isinf(ref) && !std::isinf(ours) && std::fabs(ours - ref) <= 1e-9L * scale;
  if (agree) {
    ++tally.contacts;
    // the contract: at the time returned the pair touches or overlaps by round-off
    EXPECT_LE(p(ours), 0.0) << what << ": f(t) > 0 at the returned contact t = " << ours;
    EXPECT_LE(value(dp, ours), 1e-12L) << what << ": the returned root is not a fall through zero";
    return;
  }
  // a graze: the reference's first non-positive point with f' ~ 0, or ours where f' ~ 0
  const LD our_slope = std::isinf(ours) ? 0 : value(dp, ours);
  const bool graze = (!std::isinf(ref) && std::fabs(slope) < 1e-6L * scale) ||
                     (!std::isinf(ours) && std::fabs(our_slope) < 1e-6L * scale);
  if (graze) {
    ++tally.ambiguous;
    return;
  }
  ADD_FAILURE() << what << ": first contact " << ours << ", reference " << static_cast<double>(ref)
                << " (f' there " << static_cast<double>(slope) << "); coefficients " << p.c[0] << " " << p.c[1]
                << " " << p.c[2] << " " << p.c[3] << " " << p.c[4] << ", tmax " << tmax;
}

// f's first maximum after 0 for a pair that parts now (f' > 0 just after 0): the first sign
// change of f', on a geometric grid from 1e-9 and then by bisection; 1e6 if there is none
// before it.
LD first_maximum(const Poly& p) {
  const Poly dp = p.derivative();
  LD prev = 0, t = 1e-9L;
  bool found = false;
  while (t < 1e6L) {
    if (value(dp, t) <= 0) {
      found = true;
      break;
    }
    prev = t;
    t *= 1.05L;
  }
  LD lo = 1e6L;
  if (found) {
    LD a = prev, b = t;
    for (int it = 0; it < 200; ++it) {
      const LD m = 0.5L * (a + b);
      if (value(dp, m) > 0)
        a = m;
      else
        b = m;
    }
    lo = b;
  }
  return lo;
}

void random_vector(std::mt19937_64& rng, double scale, double out[3]) {
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < 3; ++k) out[k] = scale * g(rng);
}

// dv re-aimed, its speed kept, at the partner at distance `dist` along -dr with impact
// parameter b (b < 1: a head-on or oblique hit, b > 1: a miss unless accelerations bend it)
void aim(std::mt19937_64& rng, const double dr[3], double dist, double b, double dv[3]) {
  double e[3];
  random_vector(rng, 1.0, e);
  double re = 0.0;
  for (int k = 0; k < 3; ++k) re += e[k] * dr[k] / dist;
  for (int k = 0; k < 3; ++k) e[k] -= re * dr[k] / dist;
  const double en = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  const double speed = std::sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
  const double sin_t = std::min(1.0, b / dist), cos_t = std::sqrt(1.0 - sin_t * sin_t);
  for (int k = 0; k < 3; ++k) dv[k] = speed * (-cos_t * dr[k] / dist + sin_t * e[k] / en);
}

}  // namespace

// Pairs apart now (|dr| in (1, 4)), relative velocities and accelerations over four decades,
// horizons from 0.3 to the engine's 1e6: approaching pairs, receding ones the acceleration
// brings back, near misses.
TEST(ContactTime, FirstContactOfPairsApartMatchesBranchAndBound) {
  std::mt19937_64 rng(20261207);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Tally tally;
  for (int n = 0; n < 20000; ++n) {
    double dr[3], dv[3], da[3];
    random_vector(rng, 1.0, dr);
    const double norm = std::sqrt(dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2]);
    const double dist = 1.0 + 3.0 * u(rng) * u(rng) + 1e-9;
    for (double& x : dr) x *= dist / norm;
    random_vector(rng, std::pow(10.0, -1.0 + 2.0 * u(rng)), dv);
    random_vector(rng, std::pow(10.0, -2.0 + 3.0 * u(rng)), da);
    if (n % 3 == 1) aim(rng, dr, dist, 1.3 * u(rng), dv);  // impact parameters 0 .. 1.3
    if (n % 3 == 2) {  // receding, the acceleration towards the partner: many come back
      for (int k = 0; k < 3; ++k) dv[k] = -dv[k];
      aim(rng, dr, dist, 1.3 * u(rng), dv);
      for (int k = 0; k < 3; ++k) dv[k] = -dv[k];
      const double speed = std::sqrt(da[0] * da[0] + da[1] * da[1] + da[2] * da[2]);
      for (int k = 0; k < 3; ++k) da[k] = -speed * dr[k] / dist + 0.3 * da[k];
    }
    if (n % 4 == 0) dr[2] = dv[2] = da[2] = 0.0;  // disks
    const double horizons[] = {0.3, 3.0, 30.0, 1e6};
    const double tmax = horizons[n % 4];
    const Poly p = contact_poly(dr, dv, da);
    if (p.c[0] <= 0.0) continue;  // (dist rounds to 1: touching, not this test's case)
    check_case(p, tmax, 0.0L, tally, "apart");
  }
  std::printf("pairs apart: %d cases, %d contacts, %d without contact, %d grazing (ambiguous)\n", tally.cases,
              tally.contacts, tally.none, tally.ambiguous);
  EXPECT_GT(tally.contacts, 4000);
  EXPECT_GT(tally.none, 3000);
  EXPECT_LT(tally.ambiguous, tally.cases / 200);
}

// Pairs that touch now (f(0) = 0 up to round-off) and part: the parting is no contact; the
// first contact is the re-contact the relative acceleration brings, found by the reference
// after f's first maximum.
TEST(ContactTime, PartingPairsFindOnlyTheReContact) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Tally tally;
  int recontacts = 0;
  for (int n = 0; n < 20000; ++n) {
    double dr[3], dv[3], da[3];
    random_vector(rng, 1.0, dr);
    const double norm = std::sqrt(dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2]);
    for (double& x : dr) x /= norm;
    random_vector(rng, 1.0, dv);
    double rv = dr[0] * dv[0] + dr[1] * dv[1] + dr[2] * dv[2];
    if (rv < 0.0)
      for (int k = 0; k < 3; ++k) dv[k] -= 2.0 * rv * dr[k];  // parting: the normal velocity outward
    random_vector(rng, std::pow(10.0, -1.0 + 2.0 * u(rng)), da);
    // pull the acceleration towards the partner half of the time, so that many come back
    if (n % 2 == 0) {
      const double ra = dr[0] * da[0] + dr[1] * da[1] + dr[2] * da[2];
      if (ra > 0.0)
        for (int k = 0; k < 3; ++k) da[k] -= 2.0 * ra * dr[k];
    }
    Poly p = contact_poly(dr, dv, da);
    if (n % 3 == 0) p.c[0] = 0.0;  // exactly touching, as well as the round-off of |dr|^2 - 1
    if (!(p.c[1] > 0.0)) continue;
    // the reference searches after f's first maximum (f rises from the contact first)
    const LD lo = first_maximum(p);
    const double ours = first_entering_root(p, 1e6);
    if (!std::isinf(ours)) ++recontacts;
    check_case(p, 1e6, lo, tally, "parting");
  }
  std::printf("parting pairs: %d cases, %d re-contacts, %d without, %d grazing (ambiguous)\n", tally.cases,
              recontacts, tally.none, tally.ambiguous);
  EXPECT_GT(recontacts, 1500);
  EXPECT_GT(tally.none, 2000);
  EXPECT_LT(tally.ambiguous, tally.cases / 200);
}

// Without relative acceleration the quartic is the ballistic quadratic: the first contact is
// the closed form (|dr|^2 - 1) / (-b + sqrt(b^2 - |dv|^2 (|dr|^2 - 1))), b = dr.dv.
TEST(ContactTime, BallisticPairsGiveTheClosedForm) {
  std::mt19937_64 rng(11);
  int contacts = 0;
  for (int n = 0; n < 5000; ++n) {
    double dr[3], dv[3], da[3] = {0, 0, 0};
    random_vector(rng, 1.5, dr);
    random_vector(rng, 1.0, dv);
    const double dist = std::sqrt(dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2]);
    if (n % 2 == 0) aim(rng, dr, dist, 1.2 * std::uniform_real_distribution<double>(0.0, 1.0)(rng), dv);
    const Poly p = contact_poly(dr, dv, da);
    if (p.c[0] <= 0.0) continue;
    ASSERT_EQ(p.deg, 2);
    const double b = 0.5 * p.c[1], q2 = p.c[0], v2 = p.c[2];
    const double disc = b * b - v2 * q2;
    const double expected = (b < 0.0 && disc > 0.0) ? q2 / (-b + std::sqrt(disc)) : kInf;
    const double ours = first_entering_root(p, 1e6);
    if (std::isinf(expected)) {
      EXPECT_TRUE(std::isinf(ours)) << "no contact expected, found " << ours;
    } else {
      ++contacts;
      EXPECT_NEAR(ours, expected, 1e-12 * std::max(1.0, expected));
    }
  }
  EXPECT_GT(contacts, 1000);
}

// The roots of cubics and quadratics that the splitting uses, against their factors.
TEST(ContactTime, RootsOfKnownCubicsAndQuadratics) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-2.0, 5.0);
  for (int n = 0; n < 5000; ++n) {
    double r[3] = {u(rng), u(rng), u(rng)};
    std::sort(r, r + 3);
    if (r[1] - r[0] < 1e-3 || r[2] - r[1] < 1e-3) continue;
    const double lead = n % 2 == 0 ? 1.0 : -0.25;
    Poly p;  // lead (t - r0)(t - r1)(t - r2)
    p.deg = 3;
    p.c[3] = lead;
    p.c[2] = -lead * (r[0] + r[1] + r[2]);
    p.c[1] = lead * (r[0] * r[1] + r[0] * r[2] + r[1] * r[2]);
    p.c[0] = -lead * r[0] * r[1] * r[2];
    double out[3];
    const int m = contact_detail::roots_in(p, 0.0, 4.0, out);
    int expected = 0;
    for (double x : r)
      if (x > 0.0 && x < 4.0) {
        ASSERT_LT(expected, m);
        EXPECT_NEAR(out[expected], x, 1e-10 * std::max(1.0, std::fabs(x)));
        ++expected;
      }
    EXPECT_EQ(m, expected);
    Poly q;  // (t - r0)(t - r2)
    q.deg = 2;
    q.c[2] = 1.0;
    q.c[1] = -(r[0] + r[2]);
    q.c[0] = r[0] * r[2];
    const int mq = contact_detail::roots_in(q, 0.0, 4.0, out);
    int eq = 0;
    for (double x : {r[0], r[2]})
      if (x > 0.0 && x < 4.0) {
        ASSERT_LT(eq, mq);
        EXPECT_NEAR(out[eq], x, 1e-12 * std::max(1.0, std::fabs(x)));
        ++eq;
      }
    EXPECT_EQ(mq, eq);
  }
}

// --- Added by the mutation audit of contact_time.hpp (docs/reviews/mutation-audit-contact-time.md)

namespace {

// Unit vector dr scaled to `dist`, dv of typical size `v`, da of typical size `a`; disks when
// `disk` (the z components zero).
void pair_at(std::mt19937_64& rng, double dist, double v, double a, bool disk, double dr[3], double dv[3],
             double da[3]) {
  random_vector(rng, 1.0, dr);
  random_vector(rng, v, dv);
  random_vector(rng, a, da);
  if (disk) dr[2] = dv[2] = da[2] = 0.0;
  const double norm = std::sqrt(dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2]);
  for (int k = 0; k < 3; ++k) dr[k] *= dist / norm;
}

double dot3(const double x[3], const double y[3]) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; }

// Higham's bound on the rounding error of Horner's rule in double at t >= 0 ("Accuracy and
// Stability of Numerical Algorithms", eq. 5.3): gamma_{2n} sum_k |c_k| t^k, gamma_m = m u / (1 - m u),
// u = 2^-53. Where |f| exceeds it the sign of f computed in double is right (with or without
// fused multiply-adds, which only remove roundings).
LD horner_error_bound(const Poly& p, LD t) {
  LD s = std::fabs(p.c[p.deg]);
  for (int k = p.deg - 1; k >= 0; --k) s = s * t + std::fabs(p.c[k]);
  const LD mu = 2 * p.deg * (std::numeric_limits<double>::epsilon() / 2.0L);
  return mu / (1 - mu) * s;
}

}  // namespace

// Pairs that overlap now and part: f < 0 at 0, rising through zero while they part; that
// rise is no contact. The first contact is the fall after f's first maximum (none if that
// maximum is <= 0: they never separate). PartingPairsFindOnlyTheReContact has overlaps of a
// few ulp only (|dr|^2 - 1 rounded), where the rise is too short for a search that strays
// from its monotone bracket to land on it; here the overlaps run from 1e-15 to 0.1 of a
// diameter (beyond what the engine leaves, but the same shape at resolvable scales, and
// within the contract).
TEST(ContactTime, OverlappingPartingPairsSkipTheRiseThroughZero) {
  std::mt19937_64 rng(20261208);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Tally tally;
  int recontacts = 0, never_apart = 0;
  for (int n = 0; n < 20000; ++n) {
    double dr[3], dv[3], da[3];
    const double overlap = std::pow(10.0, -15.0 + 14.0 * u(rng));
    pair_at(rng, 1.0 - overlap, std::pow(10.0, -2.0 + 2.0 * u(rng)), std::pow(10.0, -1.0 + 2.0 * u(rng)), n % 4 == 0,
            dr, dv, da);
    const double d2 = dot3(dr, dr), rv = dot3(dr, dv);
    if (rv < 0.0)
      for (int k = 0; k < 3; ++k) dv[k] -= 2.0 * rv * dr[k] / d2;  // parting
    if (n % 2 == 0) {  // pulled back towards the partner: many come back
      const double ra = dot3(dr, da);
      if (ra > 0.0)
        for (int k = 0; k < 3; ++k) da[k] -= 2.0 * ra * dr[k] / d2;
    }
    const Poly p = contact_poly(dr, dv, da);
    if (!(p.c[0] < 0.0 && p.c[1] > 0.0)) continue;
    const double ours = first_entering_root(p, 1e6);
    const LD lo = first_maximum(p);
    const LD fmax = value(p, lo);
    if (fmax <= 0) {  // f never positive: no fall through zero (unless the maximum grazes 0)
      if (fmax < -1e-9L * std::fabs(p.c[0])) {
        ++never_apart;
        EXPECT_TRUE(std::isinf(ours)) << "f <= 0 throughout, contact found at " << ours << "; overlap " << overlap;
      }
      continue;
    }
    if (!std::isinf(ours)) ++recontacts;
    check_case(p, 1e6, lo, tally, "overlapping, parting");
  }
  std::printf("overlapping parting pairs: %d cases, %d re-contacts, %d without, %d never apart, %d grazing (ambiguous)\n",
              tally.cases, recontacts, tally.none, never_apart, tally.ambiguous);
  EXPECT_GT(recontacts, 2000);
  EXPECT_GT(tally.none, 2000);
  EXPECT_LT(tally.ambiguous, tally.cases / 200);
}

// Slow pairs near contact (gaps 1e-12 to 0.1, speeds 1e-3 to 1) under strong relative
// accelerations (components of size 1 to 1e3; the Bizon cases drive with a0 up to 30), with
// the horizon the engine uses while a grain has no candidate yet (1e6): f' at the horizon
// (~4 c4 t^3) dwarfs its values near the critical points, so the secant start of the cubic's
// last bracket can round onto the bracket's near end, and the search must then go on from the
// midpoint (without it the critical point came out as the horizon and the contact was lost:
// 0.2 % of such pairs, 26 in 400 000 with components up to 60 and none up to 8; scratch
// count of the audit).
TEST(ContactTime, StrongAccelerationsUpToTheUnboundedHorizon) {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Tally tally;
  for (int n = 0; n < 20000; ++n) {
    double dr[3], dv[3], da[3];
    pair_at(rng, 1.0 + std::pow(10.0, -12.0 + 11.0 * u(rng)), std::pow(10.0, -3.0 + 3.0 * u(rng)),
            std::pow(10.0, 3.0 * u(rng)), n % 2 == 0, dr, dv, da);
    const Poly p = contact_poly(dr, dv, da);
    if (p.c[0] <= 0.0) continue;
    check_case(p, 1e6, 0.0L, tally, "strong acceleration");
  }
  std::printf("strong accelerations: %d cases, %d contacts, %d without contact, %d grazing (ambiguous)\n", tally.cases,
              tally.contacts, tally.none, tally.ambiguous);
  EXPECT_GT(tally.contacts, 5000);
  EXPECT_GT(tally.none, 2000);
  EXPECT_LT(tally.ambiguous, tally.cases / 200);
}

// A cubic's roots before a far end: three roots of size 1e-3 and the end at 1e6, where the
// cubic is ~1e18 times its values between the roots (the engine's critical points are the
// roots of the cubic f' up to the horizon, 1e6 while there is no candidate yet).
TEST(ContactTime, RootsOfACubicBeforeAFarEnd) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(1.0, 4.0);
  for (int n = 0; n < 1000; ++n) {
    double r[3] = {1e-3 * u(rng), 1e-3 * u(rng), 1e-3 * u(rng)};
    std::sort(r, r + 3);
    if (r[1] - r[0] < 1e-5 || r[2] - r[1] < 1e-5) continue;
    Poly p;  // (t - r0)(t - r1)(t - r2)
    p.deg = 3;
    p.c[3] = 1.0;
    p.c[2] = -(r[0] + r[1] + r[2]);
    p.c[1] = r[0] * r[1] + r[0] * r[2] + r[1] * r[2];
    p.c[0] = -r[0] * r[1] * r[2];
    double out[3];
    const int m = contact_detail::roots_in(p, 0.0, 1e6, out);
    ASSERT_EQ(m, 3) << r[0] << " " << r[1] << " " << r[2];
    // 1e-9 relative: the roots are 1e-5 apart and the coefficients rounded to 1e-16 relative
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(out[k], r[k], 1e-9 * r[k]);
  }
}

// The closed form of a quadratic's roots must not cancel: a root of size 1e-9 to 1e-3 and one
// of 1 to 1e9 (3 to 18 decades apart), both positive or both negative (both signs of the
// middle coefficient), each found to 1e-14 of itself. The coefficients carry one rounding
// each (~1e-16 relative), which moves such well-separated roots by about as much; the
// cancelling form loses eps times the ratio of the roots (>= 2e-13) on the small one.
TEST(ContactTime, QuadraticRootsOfDisparateSizes) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checked = 0;
  for (int n = 0; n < 2000; ++n) {
    const double small = std::pow(10.0, -9.0 + 6.0 * u(rng)), large = std::pow(10.0, 0.0 + 9.0 * u(rng));
    const double sign = n % 2 == 0 ? 1.0 : -1.0;  // both roots positive, or both negative
    double r[2] = {sign * small, sign * large};
    if (r[0] > r[1]) std::swap(r[0], r[1]);
    Poly q;  // (t - r0)(t - r1), scaled by 3 (a leading coefficient that is not 1)
    q.deg = 2;
    q.c[2] = 3.0;
    q.c[1] = -3.0 * (r[0] + r[1]);
    q.c[0] = 3.0 * (r[0] * r[1]);
    double out[2];
    const int m = contact_detail::roots_in(q, -2e9, 2e9, out);
    ASSERT_EQ(m, 2);
    for (int k = 0; k < 2; ++k) EXPECT_NEAR(out[k], r[k], 1e-14 * std::fabs(r[k])) << "roots " << r[0] << " " << r[1];
    ++checked;
  }
  EXPECT_EQ(checked, 2000);
}

// A bracket of two adjacent doubles (a critical point and the horizon one ulp apart, or two
// critical points): no interior point to try, and the answer is the end on the overlapping
// side, b, where p <= 0 for a fall (and p >= 0 for a rise: "b's side of the sign change").
TEST(ContactTime, BracketOfAdjacentDoublesGivesItsOverlappingEnd) {
  for (double b : {1.0, 0.7, 3.25e-4, 12345.678}) {
    const double a = std::nextafter(b, 0.0);
    Poly fall;  // b - t: exactly b - a > 0 at a, 0 at b
    fall.deg = 1;
    fall.c[0] = b;
    fall.c[1] = -1.0;
    EXPECT_EQ(contact_detail::bracketed_root(fall, fall.derivative(), a, b, fall(a), fall(b)), b);
    Poly rise = fall;  // t - b
    rise.c[0] = -b;
    rise.c[1] = 1.0;
    EXPECT_EQ(contact_detail::bracketed_root(rise, rise.derivative(), a, b, rise(a), rise(b)), b);
  }
}

// The contract's precision: the time returned is the root to within what the sign of f
// computed in double can resolve. With E(t) Higham's bound on Horner's rounding error at t and
// s = f'(t), the computed sign of f is right outside |t - root| <= E/|s| (to first order); the
// search ends within a few ulp of a point where the computed f changes sign, so the root lies
// within tol = 2 E/|s| + 16 ulp of the time returned: f > 0 at t - tol and f < 0 at t + tol,
// both evaluated in long double (rounding 2^11 times smaller than E). Pairs apart, parting
// from contact and overlapping, at all the scales of the tests above; grazes (the first-order
// band wider than 1e-9 relative) are left out, and must be few.
TEST(ContactTime, ContactIsTheRootToWithinTheRoundingOfF) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checked = 0, grazes = 0;
  LD widest = 0;  // the largest |t - root| bound used, in ulp of t (reported)
  for (int n = 0; n < 60000; ++n) {
    double dr[3], dv[3], da[3];
    const int kind = n % 3;  // apart, parting from contact, strong accelerations near contact
    const double dist = kind == 0 ? 1.0 + 3.0 * u(rng) * u(rng) + 1e-9
                        : kind == 1 ? 1.0 - std::pow(10.0, -16.0 + 14.0 * u(rng))
                                    : 1.0 + std::pow(10.0, -12.0 + 11.0 * u(rng));
    const double v = kind == 2 ? std::pow(10.0, -3.0 + 3.0 * u(rng)) : std::pow(10.0, -1.0 + 2.0 * u(rng));
    const double a = kind == 2 ? std::pow(10.0, 3.0 * u(rng)) : std::pow(10.0, -2.0 + 3.0 * u(rng));
    pair_at(rng, dist, v, a, n % 4 == 0, dr, dv, da);
    const double d2 = dot3(dr, dr), rv = dot3(dr, dv), ra = dot3(dr, da);
    if (kind == 1 && rv < 0.0)
      for (int k = 0; k < 3; ++k) dv[k] -= 2.0 * rv * dr[k] / d2;
    if (kind != 2 && ra > 0.0 && n % 2 == 0)
      for (int k = 0; k < 3; ++k) da[k] -= 2.0 * ra * dr[k] / d2;
    const Poly p = contact_poly(dr, dv, da);
    if (kind != 1 && p.c[0] <= 0.0) continue;
    if (kind == 1 && !(p.c[1] > 0.0)) continue;
    const double tmax = kind == 2 ? 1e6 : std::pow(10.0, -1.0 + 7.0 * u(rng));
    const double t = first_entering_root(p, tmax);
    if (std::isinf(t)) continue;
    const LD slope = value(p.derivative(), t);
    const LD ulp = std::nextafter(t, kInf) - t;
    const LD tol = 2 * horner_error_bound(p, t) / std::fabs(slope) + 16 * ulp;
    if (!(slope < 0) || tol > 1e-9L * std::max<LD>(1, t)) {
      ++grazes;
      continue;
    }
    ++checked;
    widest = std::max(widest, tol / ulp);
    EXPECT_GT(value(p, t - tol), 0) << "the root is more than " << static_cast<double>(tol) << " after t = " << t
                                    << " (tmax " << tmax << ", " << static_cast<double>(tol / ulp) << " ulp)";
    EXPECT_LT(value(p, t + tol), 0) << "the root is more than " << static_cast<double>(tol) << " before t = " << t
                                    << " (tmax " << tmax << ", " << static_cast<double>(tol / ulp) << " ulp)";
  }
  std::printf("rounding: %d contacts checked (bound up to %.0f ulp), %d grazes left out\n", checked,
              static_cast<double>(widest), grazes);
  EXPECT_GT(checked, 10000);
  EXPECT_LT(grazes, checked / 100);
}

// --- Added by the mutation audit of first_contact_time (docs/reviews/mutation-audit-pair-time.md)

namespace {

using grainbath::Vec3;

// A pair as Engine::scan_cell hands it over: separation, relative velocity and relative
// acceleration now, and the horizon (the time to the grain's best candidate, +inf without one).
struct Flight {
  double dr[3], dv[3], da[3];
  double tmax;
  double contact() const {
    return first_contact_time(Vec3{dr[0], dr[1], dr[2]}, Vec3{dv[0], dv[1], dv[2]}, Vec3{da[0], da[1], da[2]}, tmax);
  }
};

// The reference below works on the separation x(t) = dr + dv t + da t^2/2 itself, not on the
// coefficients of |x|^2 - 1, so that it also checks how first_contact_time forms them.
// One component of x on [lo, hi]: its exact range (the ends and the vertex of the parabola).
Interval component_range(LD r, LD v, LD a, LD lo, LD hi) {
  const auto x = [&](LD t) { return r + v * t + 0.5L * a * t * t; };
  Interval s{std::min(x(lo), x(hi)), std::max(x(lo), x(hi))};
  if (a != 0) {
    const LD vertex = -v / a;
    if (vertex > lo && vertex < hi) s = {std::min(s.lo, x(vertex)), std::max(s.hi, x(vertex))};
  }
  return s;
}

// A lower bound of |x|^2 - 1 on [lo, hi]
LD gap2_lower_bound(const Flight& f, LD lo, LD hi) {
  LD s = 0;
  for (int k = 0; k < 3; ++k) {
    const Interval c = component_range(f.dr[k], f.dv[k], f.da[k], lo, hi);
    if (c.lo > 0) s += c.lo * c.lo;
    if (c.hi < 0) s += c.hi * c.hi;
  }
  return s - 1;
}

LD gap2(const Flight& f, LD t) {  // |x(t)|^2 - 1
  LD s = 0;
  for (int k = 0; k < 3; ++k) {
    const LD x = f.dr[k] + f.dv[k] * t + 0.5L * f.da[k] * t * t;
    s += x * x;
  }
  return s - 1;
}

LD gap2_rate(const Flight& f, LD t) {  // d/dt |x(t)|^2 = 2 x.x'
  LD s = 0;
  for (int k = 0; k < 3; ++k) s += 2 * (f.dr[k] + f.dv[k] * t + 0.5L * f.da[k] * t * t) * (f.dv[k] + f.da[k] * t);
  return s;
}

// The first point of [lo, hi] where |x| may be <= 1 (to 1e-14 relative), +inf if none, NaN
// beyond the budget
LD first_touch(const Flight& f, LD lo, LD hi, long& nodes) {
  if (++nodes > 400000) return std::numeric_limits<LD>::quiet_NaN();
  if (gap2_lower_bound(f, lo, hi) > 0) return std::numeric_limits<LD>::infinity();
  if (hi - lo <= 1e-14L * std::max<LD>(1, hi)) return lo;
  const LD mid = 0.5L * (lo + hi);
  const LD left = first_touch(f, lo, mid, nodes);
  return std::isinf(left) ? first_touch(f, mid, hi, nodes) : left;
}

enum class Outcome { contact, none, ambiguous };

// The reference first contact within the horizon (1e6 for tmax = +inf). A pair touching now
// (|dr|^2 - 1 within round-off of 0) and parting: searched after the first maximum of |x|.
// Ambiguous: a graze (|x|' ~ 0 at the contact), a contact within 1e-9 of the horizon (a tie
// with the candidate that set it), or a parting pair whose |x| never clearly exceeds 1.
Outcome reference_contact(const Flight& f, LD& t) {
  const LD horizon = std::isinf(f.tmax) ? 1e6L : f.tmax;
  LD from = 0;
  if (gap2(f, 0) <= 1e-15L) {
    EXPECT_GT(gap2_rate(f, 0), 0) << "reference_contact: pairs touching now must part";
    LD prev = 0, next = 1e-9L;
    while (next < horizon && gap2_rate(f, next) > 0) prev = next, next *= 1.05L;
    if (next >= horizon) return Outcome::none;
    for (int it = 0; it < 200; ++it) {
      const LD mid = 0.5L * (prev + next);
      (gap2_rate(f, mid) > 0 ? prev : next) = mid;
    }
    if (gap2(f, next) <= 1e-12L) return Outcome::ambiguous;
    from = next;
  }
  long nodes = 0;
  t = first_touch(f, from, horizon, nodes);
  if (std::isnan(t)) return Outcome::ambiguous;
  if (std::isinf(t)) return Outcome::none;
  // the time is known to ~ (rounding of |x|^2 in double) / |d|x|^2/dt|; the size of the terms
  // of |x|^2 sets that rounding
  LD terms = 0;
  for (int k = 0; k < 3; ++k) terms += std::fabs(f.dr[k]) + std::fabs(f.dv[k]) * t + 0.5L * std::fabs(f.da[k]) * t * t;
  if (std::fabs(gap2_rate(f, t)) * std::max<LD>(1, t) < 1e-5L * (1 + terms * terms)) return Outcome::ambiguous;
  if (horizon - t < 1e-9L * std::max<LD>(1, horizon)) return Outcome::ambiguous;
  return Outcome::contact;
}

void set_length(double x[3], double length) {
  const double n = std::sqrt(dot3(x, x));
  for (int k = 0; k < 3; ++k) x[k] *= length / n;
}

}  // namespace

// first_contact_time over pairs drawn as the engine meets them, against the reference on the
// separation itself: apart at distances 1-4 with horizons from 0.01 to +inf; slow pairs near
// contact under relative accelerations up to 60 per component (Bizon's a0 up to 30); pairs
// parting from contact; relative accelerations down to 1e-10 (and none); dilute pairs up to
// 21 diameters apart, slow, with long horizons. Each contact to 1e-9; no contact where the
// reference finds none within the horizon. It checks the whole function: the coefficients of
// |x|^2 - 1, the cheap rejection (its reach must bound |dv| t + |da| t^2/2: with half that
// acceleration term, or without it, contacts within the horizon were lost), the shortcut for
// a non-decreasing |x| (it needs all of c1, c2, c3 >= 0), the degree (a relative
// acceleration of 1e-6 still bends the path) and the horizon.
TEST(ContactTime, FirstContactTimeMatchesTheSeparationItself) {
  std::mt19937_64 rng(20261209);
  std::uniform_real_distribution<double> u(0.0, 1.0), sym(-1.0, 1.0);
  const char* names[5] = {"apart", "slow, strong acceleration", "parting", "weak or no acceleration", "dilute, slow"};
  const double horizons[5] = {0.01, 0.3, 3.0, 30.0, kInf};
  for (int family = 0; family < 5; ++family) {
    int contacts = 0, none = 0, ambiguous = 0;
    for (int n = 0; n < 12000; ++n) {
      Flight f;
      random_vector(rng, 1.0, f.dr);
      if (n % 2 == 0) f.dr[2] = 0.0;  // disks
      const double dist = family == 0   ? 1.0 + 3.0 * u(rng) * u(rng) + 1e-9
                          : family == 1 ? 1.0 + std::pow(10.0, -12.0 + 11.0 * u(rng))
                          : family == 2 ? 1.0
                          : family == 3 ? 1.0 + 3.0 * u(rng) + 1e-9
                                        : 1.0 + 20.0 * u(rng);
      set_length(f.dr, dist);
      random_vector(rng, family == 1 || family == 4 ? std::pow(10.0, -3.0 + 3.0 * u(rng)) : std::pow(10.0, -1.0 + 2.0 * u(rng)),
                    f.dv);
      const double a = family == 0   ? std::pow(10.0, -2.0 + 3.78 * u(rng))
                       : family == 1 ? std::pow(10.0, -1.0 + 2.78 * u(rng))
                       : family == 2 ? std::pow(10.0, -1.0 + 2.5 * u(rng))
                       : family == 3 ? (n % 2 ? 0.0 : std::pow(10.0, -10.0 + 6.0 * u(rng)))
                                     : std::pow(10.0, -3.0 + 4.0 * u(rng));
      for (double& x : f.da) x = a * sym(rng);  // components up to 60
      if (n % 2 == 0) f.dv[2] = f.da[2] = 0.0;
      const double d2 = dot3(f.dr, f.dr);
      const double rv = dot3(f.dr, f.dv);
      if ((family == 2 && rv < 0.0) || (family != 2 && n % 3 == 2 && rv > 0.0))  // parting; approaching
        for (int k = 0; k < 3; ++k) f.dv[k] -= 2.0 * rv * f.dr[k] / d2;
      const double ra = dot3(f.dr, f.da);
      if (family != 1 && family != 3 && n % 3 == 1 && ra > 0.0)  // pulled towards the partner
        for (int k = 0; k < 3; ++k) f.da[k] -= 2.0 * ra * f.dr[k] / d2;
      f.tmax = family == 1 || family == 2 ? (n % 2 ? kInf : std::pow(10.0, -2.0 + 8.0 * u(rng)))
               : family == 4              ? (n % 2 ? kInf : std::pow(10.0, 7.0 * u(rng)))
                                          : horizons[n % 5];
      if (family == 2 && !(gap2_rate(f, 0) > 0)) continue;
      LD ref = 0;
      const Outcome expected = reference_contact(f, ref);
      const double ours = f.contact();
      // a time beyond the horizon is no contact for the caller (its candidate comes first)
      const bool found = ours <= (std::isinf(f.tmax) ? 1e6 : f.tmax);
      if (expected == Outcome::ambiguous) {
        ++ambiguous;
      } else if (expected == Outcome::none) {
        ++none;
        EXPECT_FALSE(found) << names[family] << ": contact at " << ours << " where there is none within " << f.tmax;
      } else {
        ++contacts;
        EXPECT_TRUE(found && std::fabs(ours - ref) <= 1e-9L * std::max<LD>(1, ref))
            << names[family] << ": contact at " << ours << ", reference " << static_cast<double>(ref) << " (horizon "
            << f.tmax << "; dr " << f.dr[0] << " " << f.dr[1] << " " << f.dr[2] << ", dv " << f.dv[0] << " " << f.dv[1]
            << " " << f.dv[2] << ", da " << f.da[0] << " " << f.da[1] << " " << f.da[2] << ")";
      }
    }
    std::printf("%s: %d contacts, %d without contact, %d ambiguous\n", names[family], contacts, none, ambiguous);
    EXPECT_GT(contacts, 300) << names[family];
    EXPECT_GT(none, 3000) << names[family];
    EXPECT_LT(ambiguous, 60) << names[family];
  }
}

// A pair that touches now (|dr| = 1 up to round-off, or exactly) and approaches collides now,
// whatever its acceleration and horizon: the contact time is 0. (The search for an entering
// root would skip it: f is not positive before it.)
TEST(ContactTime, TouchingApproachingPairsCollideAtOnce) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int exact = 0;
  for (int n = 0; n < 4000; ++n) {
    Flight f;
    random_vector(rng, 1.0, f.dr);
    random_vector(rng, std::pow(10.0, -3.0 + 4.0 * u(rng)), f.dv);
    random_vector(rng, n % 3 == 0 ? 0.0 : std::pow(10.0, -2.0 + 3.78 * u(rng)), f.da);
    if (n % 2 == 0) f.dr[2] = f.dv[2] = f.da[2] = 0.0;
    if (n % 4 == 1) {  // exactly touching: a unit vector along an axis
      f.dr[0] = f.dr[1] = f.dr[2] = 0.0;
      f.dr[n % 8 == 1 ? 0 : 1] = n % 16 < 8 ? 1.0 : -1.0;
    } else {
      set_length(f.dr, 1.0);
    }
    const double rv = dot3(f.dr, f.dv), d2 = dot3(f.dr, f.dr);
    if (rv > 0.0)
      for (int k = 0; k < 3; ++k) f.dv[k] -= 2.0 * rv * f.dr[k] / d2;  // approaching
    if (!(d2 - 1.0 <= 0.0 && dot3(f.dr, f.dv) < 0.0)) continue;
    if (d2 == 1.0) ++exact;
    f.tmax = n % 5 == 0 ? kInf : std::pow(10.0, -3.0 + 6.0 * u(rng));
    EXPECT_EQ(f.contact(), 0.0) << "|dr|^2 - 1 = " << d2 - 1.0 << ", dr.dv = " << dot3(f.dr, f.dv);
  }
  EXPECT_GT(exact, 500);
}

// Without a candidate yet (tmax = +inf) the search runs to 1e6: slow pairs whose contact comes
// after 1e2 to 5e5 (head-on or oblique, a weak relative acceleration or none) must find it.
TEST(ContactTime, FarContactsAreFoundWithoutACandidate) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checked = 0;
  for (int n = 0; n < 2000; ++n) {
    const bool disk = n % 2 == 0;
    Flight f;
    const double dist = 1.0 + 20.0 * u(rng) + 0.01;
    random_vector(rng, 1.0, f.dr);
    if (disk) f.dr[2] = 0.0;
    set_length(f.dr, dist);
    // a direction e perpendicular to dr (in the plane for disks), and the velocity at the
    // angle of impact parameter b < 0.9 from -dr, at the speed that meets in about `when`
    double e[3] = {-f.dr[1], f.dr[0], 0.0};
    if (!disk) {
      double w[3];
      random_vector(rng, 1.0, w);
      e[0] = f.dr[1] * w[2] - f.dr[2] * w[1], e[1] = f.dr[2] * w[0] - f.dr[0] * w[2], e[2] = f.dr[0] * w[1] - f.dr[1] * w[0];
    }
    set_length(e, 1.0);
    const double when = std::pow(10.0, 2.0 + 3.7 * u(rng));
    const double speed = (dist - 1.0) / when, sin_b = 0.9 * u(rng) / dist, cos_b = std::sqrt(1.0 - sin_b * sin_b);
    for (int k = 0; k < 3; ++k) f.dv[k] = speed * (-cos_b * f.dr[k] / dist + sin_b * e[k]);
    random_vector(rng, n % 3 == 0 ? 0.0 : 1e-3 * (dist - 1.0) / (when * when), f.da);  // a weak bend
    if (disk) f.da[2] = 0.0;
    f.tmax = kInf;
    LD ref = 0;
    if (reference_contact(f, ref) != Outcome::contact || ref < 1e2) continue;
    ++checked;
    EXPECT_NEAR(f.contact(), static_cast<double>(ref), 1e-9 * static_cast<double>(ref)) << "meeting after about " << when;
  }
  EXPECT_GT(checked, 1500);
}
