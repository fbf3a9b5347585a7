// The transport bookkeeping (src/edmd/transport.*) on hand-built states whose sums are known
// without the code's formulas: single grains thrown through planes (a turning point, the
// periodic face, a position one ulp across a plane, a nearly free flight), collisions typed by
// hand across one, two and the periodic plane, the blocks of many sampling intervals and their
// jackknife, the fields of a block of given sums and the summary scalars of a checkpoint made
// by hand. docs/reviews/mutation-audit-edmd-transport.md lists the mutations each test kills.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "edmd/theory.hpp"
#include "edmd/transport.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
constexpr int kS = SlabTransport::kSlab, kP = SlabTransport::kPlane;
double cmp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
int wrap_slab(long k, int S) { return static_cast<int>(((k % S) + S) % S); }

// Expected raw sums, accumulated from the layout documented in transport.hpp.
struct Ref {
  int S, c, z;
  std::vector<double> slab, plane;
  Ref(int S_, int c_, int z_) : S(S_), c(c_), z(z_), slab(S_ * kS, 0.0), plane(S_ * kP, 0.0) {}
  double& s(int k, int q) { return slab[static_cast<std::size_t>(wrap_slab(k, S)) * kS + q]; }
  double& p(int k, int q) { return plane[static_cast<std::size_t>(wrap_slab(k, S)) * kP + q]; }
  // free flight v(t) = v0 + a t spent inside slab k for t in [ta, tb]: the work and impulses
  // are differences of the end values, the time integrals by Simpson's rule (exact: the
  // integrands are polynomials of degree <= 2 in t)
  void piece(int k, const Vec3& v0, const Vec3& a, double ta, double tb) {
    auto v = [&](double t) { return v0 + t * a; };
    const double h = tb - ta, m = 0.5 * (ta + tb);
    s(k, 0) += 0.5 * norm2(v(tb)) - 0.5 * norm2(v(ta));
    s(k, 1) += cmp(v(tb), c) - cmp(v(ta), c);
    s(k, 19) += cmp(v(tb), z) - cmp(v(ta), z);
    s(k, 3) += h;
    for (int p = 0; p < 3; ++p) {
      s(k, 4 + p) += h / 6.0 * (cmp(v(ta), p) + 4.0 * cmp(v(m), p) + cmp(v(tb), p));
      for (int q = 0; q < 3; ++q)
        s(k, 7 + 3 * p + q) += h / 6.0 * (cmp(v(ta), p) * cmp(v(ta), q) + 4.0 * cmp(v(m), p) * cmp(v(m), q) +
                                          cmp(v(tb), p) * cmp(v(tb), q));
    }
  }
  // the grain crosses plane `level` (z = level w) at time t, upward (+1) or downward (-1)
  void crossing(long level, int sign, const Vec3& v0, const Vec3& a, double t) {
    const Vec3 v = v0 + t * a;
    p(level, 0) += sign * 0.5 * norm2(v);
    p(level, 2) += sign * cmp(v, c);
    p(level, 4) += sign * cmp(v, z);
    p(level, 6) += sign;
  }
  // a whole flight from slab k: pieces between the given crossings (time, level, sign);
  // returns the slab it ends in
  struct Cross {
    double t;
    long level;
    int sign;
  };
  int flight(int k, const Vec3& v0, const Vec3& a, double dt, const std::vector<Cross>& xs) {
    double t0 = 0.0;
    for (const auto& x : xs) {
      piece(k, v0, a, t0, x.t);
      crossing(x.level, x.sign, v0, a, x.t);
      k = wrap_slab(x.sign > 0 ? x.level : x.level - 1, S);
      t0 = x.t;
    }
    piece(k, v0, a, t0, dt);
    return k;
  }
};

// The engine's side of a free flight: r1, v1 unwrapped (the hook's convention), then the
// position wrapped into the box along `axis`.
struct Grain {
  Vec3 r, v, a;
};
void fly(SlabTransport& t, std::uint32_t id, Grain& g, double dt, int axis, double L) {
  const Vec3 r1 = g.r + dt * g.v + (0.5 * dt * dt) * g.a, v1 = g.v + dt * g.a;
  t.add_move(id, g.r, g.v, r1, v1, g.a, dt);
  g.r = r1, g.v = v1;
  double& zr = axis == 0 ? g.r.x : axis == 1 ? g.r.y : g.r.z;
  zr -= L * std::floor(zr / L);
}

void expect_sums(const TransportBlock& got, const Ref& want, double tol, const char* what) {
  ASSERT_EQ(got.slab.size(), want.slab.size());
  ASSERT_EQ(got.plane.size(), want.plane.size());
  for (std::size_t q = 0; q < want.slab.size(); ++q)
    EXPECT_NEAR(got.slab[q], want.slab[q], tol * (1.0 + std::abs(want.slab[q])))
        << what << ": slab " << q / kS << " entry " << q % kS;
  for (std::size_t q = 0; q < want.plane.size(); ++q)
    EXPECT_NEAR(got.plane[q], want.plane[q], tol * (1.0 + std::abs(want.plane[q])))
        << what << ": plane " << q / kP << " entry " << q % kP;
}

// Storage entries [16..18] of slab k from the contents at the start and the end.
void storage(Ref& r, const std::vector<int>& k0, const std::vector<Vec3>& v0, const std::vector<int>& k1,
             const std::vector<Vec3>& v1) {
  for (std::size_t i = 0; i < v0.size(); ++i) {
    r.s(k0[i], 16) -= 0.5 * norm2(v0[i]), r.s(k0[i], 17) -= cmp(v0[i], r.c), r.s(k0[i], 18) -= cmp(v0[i], r.z);
    r.s(k1[i], 16) += 0.5 * norm2(v1[i]), r.s(k1[i], 17) += cmp(v1[i], r.c), r.s(k1[i], 18) += cmp(v1[i], r.z);
  }
}

// Roots of z0 + vz t + az t^2/2 = level by Newton's method in long double from a guess.
double newton_root(double z0, double vz, double az, double level, double guess) {
  long double t = guess;
  for (int it = 0; it < 60; ++it) {
    const long double f = z0 + vz * t + 0.5L * az * t * t - level, df = vz + az * t;
    t -= f / df;
  }
  return static_cast<double>(t);
}
}  // namespace

// One grain in 2D (axis y, component x, 8 slabs of width 1) thrown up through planes 3 and 4
// under a constant acceleration that turns it round at z = 4.3 and brings it back through
// both: four crossings at the roots of z(t), each carrying E, v_x, v_y at its own time; the
// time integrals split at them. Every raw sum against its definition (transport.hpp).
TEST(TransportExact, OneGrainThrownUpThroughTwoPlanesAndBack) {
  SlabTransport t;
  t.init({2, Vec3{3.0, 8.0, 1.0}, 1, 0, 8}, 1);
  ASSERT_DOUBLE_EQ(t.slab_width(), 1.0);
  Grain g{{1.0, 2.5, 0.0}, {0.3, 1.2, 0.0}, {0.1, -0.4, 0.0}};
  const Vec3 v0 = g.v, a = g.a;
  t.begin({g.r}, {g.v});
  ASSERT_EQ(t.slab_of_particle(0), 2);
  fly(t, 0, g, 6.0, 1, 8.0);
  t.end_interval(6.0, {g.v});
  // z(t) = 2.5 + 1.2 t - 0.2 t^2 = level: t = 3 -+ sqrt(9 - 5 (level - 2.5)); turning point t = 3
  auto up = [](double level) { return 3.0 - std::sqrt(9.0 - 5.0 * (level - 2.5)); };
  auto down = [](double level) { return 3.0 + std::sqrt(9.0 - 5.0 * (level - 2.5)); };
  Ref r(8, 0, 1);
  const int k = r.flight(2, v0, a, 6.0, {{up(3), 3, +1}, {up(4), 4, +1}, {down(4), 4, -1}, {down(3), 3, -1}});
  EXPECT_EQ(k, 2);
  EXPECT_EQ(t.slab_of_particle(0), 2);
  storage(r, {2}, {v0}, {2}, {g.v});
  expect_sums(t.total(), r, 1e-12, "thrown grain");
  // the net number of crossings of each plane is zero, the momentum along y carried through
  // plane 4 is v_y(up) - v_y(down) = 2 * 0.2 * (down - up) > 0
  EXPECT_EQ(t.total().plane[4 * kP + 6], 0.0);
  EXPECT_NEAR(t.total().plane[4 * kP + 4], 0.4 * (down(4) - up(4)), 1e-12);
}

// Free flights through the periodic face both ways, one without acceleration along the axis
// (the linear root), a position one ulp across a plane from where the last flight left the
// grain (its tracked slab wins), and a nearly free flight whose crossing time the textbook
// quadratic formula loses to cancellation.
TEST(TransportExact, FlightsThroughThePeriodicFaceAndARoundOffPosition) {
  const double L = 8.0;
  SlabTransport t;
  t.init({2, Vec3{3.0, L, 1.0}, 1, 0, 8}, 4);
  std::vector<Grain> g = {
      {{0.5, 0.4, 0.0}, {0.2, -1.0, 0.0}, {0.3, 0.0, 0.0}},   // down through z = 0, then plane 7
      {{1.5, 7.5, 0.0}, {0.0, 1.0, 0.0}, {-0.2, 0.0, 0.0}},   // up through z = L (plane 0)
      {{2.0, 0.5, 0.0}, {0.1, 1.0, 0.0}, {0.0, 0.0, 0.0}},    // stops one ulp below plane 1
      {{2.5, 3.5, 0.0}, {0.4, -1.0, 0.0}, {0.0, 1e-6, 0.0}},  // nearly free, down through plane 3
  };
  std::vector<Vec3> x0, v0;
  for (const auto& q : g) x0.push_back(q.r), v0.push_back(q.v);
  t.begin(x0, v0);
  Ref r(8, 0, 1);
  std::vector<int> k(4);
  // grain 0: z = 0.4 - t, crossing z = 0 at t = 0.4 (into slab 7), then from 7.4 through z = 7 at 0.4
  k[0] = r.flight(0, g[0].v, g[0].a, 1.0, {{0.4, 0, -1}});
  fly(t, 0, g[0], 1.0, 1, L);
  EXPECT_EQ(t.slab_of_particle(0), 7);
  EXPECT_NEAR(g[0].r.y, 7.4, 1e-15);
  k[0] = r.flight(k[0], g[0].v, g[0].a, 0.5, {{0.4, 7, -1}});
  fly(t, 0, g[0], 0.5, 1, L);
  // grain 1: z = 7.5 + t crosses z = 8 (plane 8 = plane 0) at t = 0.5
  k[1] = r.flight(7, g[1].v, g[1].a, 1.0, {{0.5, 8, +1}});
  fly(t, 1, g[1], 1.0, 1, L);
  // grain 2: a flight handed over ending one ulp below z = 1 (no crossing), then the next one
  // starting exactly on z = 1: still in slab 0 by its crossings, it crosses plane 1 at t = 0
  {
    const Vec3 r1{2.05, std::nextafter(1.0, 0.0), 0.0};
    t.add_move(2, g[2].r, g[2].v, r1, g[2].v, g[2].a, 0.5);
    r.flight(0, g[2].v, g[2].a, 0.5, {});
    EXPECT_EQ(t.slab_of_particle(2), 0);
    g[2].r = {2.05, 1.0, 0.0};
    k[2] = r.flight(0, g[2].v, g[2].a, 0.5, {{0.0, 1, +1}});
    fly(t, 2, g[2], 0.5, 1, L);
  }
  // grain 3: z = 3.5 - t + 5e-7 t^2 crosses z = 3 at t = 0.50000012500006...
  {
    const double tc = newton_root(3.5, -1.0, 1e-6, 3.0, 0.5);
    EXPECT_NEAR(tc, 0.5000001250000625, 1e-15);
    k[3] = r.flight(3, g[3].v, g[3].a, 1.0, {{tc, 3, -1}});
    fly(t, 3, g[3], 1.0, 1, L);
  }
  EXPECT_EQ(k, (std::vector<int>{6, 0, 1, 2}));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(t.slab_of_particle(i), k[i]) << i;
  std::vector<Vec3> v1;
  for (const auto& q : g) v1.push_back(q.v);
  t.end_interval(1.0, v1);
  storage(r, {0, 7, 0, 3}, v0, k, v1);
  expect_sums(t.total(), r, 1e-13, "periodic and round-off flights");
}

// Collisions typed by hand (2D, axis y, component x, L = 4, 8 slabs of width 0.5, so that a
// contact can span two planes): rough impulses (J not along r_ij), energy changes of both
// grains. Expected per transport.hpp: (dE_i + dE_j)/2 sunk in each grain's slab, (dE_j -
// dE_i)/2, J_x, J_y carried from slab(i) to slab(j) through every plane between them, the
// virial r_x J_x, r_y J_y, r_y J_x split over the slabs by the fraction of the centre-to-centre
// segment's y extent inside each.
TEST(TransportExact, HandMadeCollisionsThroughOneTwoAndThePeriodicPlanes) {
  const int S = 8;
  const double L = 4.0, w = 0.5;
  SlabTransport t;
  t.init({2, Vec3{3.0, L, 1.0}, 1, 0, S}, 8);
  // grains at rest at their contact positions; pairs (0,1), (2,3), (4,5), (6,7)
  struct Coll {
    Vec3 ri, rij, J;
    double dEi, dEj;
    std::uint32_t i, j;
    std::vector<std::pair<long, int>> planes;      // plane, sign
    std::vector<std::pair<int, double>> shares;    // slab, fraction of the segment
  };
  const std::vector<Coll> cs = {
      // up through plane 3: y 1.1 -> 1.7; 0.4 of 0.6 in slab 2, 0.2 in slab 3
      {{0.5, 1.1, 0.0}, {0.8, 0.6, 0.0}, {0.35, 0.5, 0.0}, -0.4, 0.1, 0, 1, {{3, +1}}, {{2, 0.4 / 0.6}, {3, 0.2 / 0.6}}},
      // up through planes 1 and 2: y 0.45 -> 1.41
      {{1.0, 0.45, 0.0}, {0.28, 0.96, 0.0}, {0.1, 0.7, 0.0}, -0.2, -0.05, 2, 3, {{1, +1}, {2, +1}},
       {{0, 0.05 / 0.96}, {1, 0.5 / 0.96}, {2, 0.41 / 0.96}}},
      // down through z = 0 and plane 7: y 0.2 -> -0.6 (slab 6 through the periodic face)
      {{2.0, 0.2, 0.0}, {0.6, -0.8, 0.0}, {0.3, -0.6, 0.0}, 0.15, -0.3, 4, 5, {{0, -1}, {7, -1}},
       {{0, 0.2 / 0.8}, {7, 0.5 / 0.8}, {6, 0.1 / 0.8}}},
      // i on plane 4 by round-off but in slab 3 by its crossings, j in slab 5: planes 4 and 5;
      // the segment 2.0 -> 2.6 lies in slabs 4 (0.5) and 5 (0.1), none of it in slab 3
      {{2.5, 2.0, 0.0}, {0.8, 0.6, 0.0}, {0.2, 0.45, 0.0}, -0.1, 0.02, 6, 7, {{4, +1}, {5, +1}},
       {{4, 0.5 / 0.6}, {5, 0.1 / 0.6}}},
  };
  std::vector<Vec3> x(8), v(8, Vec3{0, 0, 0});
  for (const auto& c : cs) {
    x[c.i] = c.ri, x[c.j] = c.ri + c.rij;
    x[c.j].y -= L * std::floor(x[c.j].y / L);
  }
  x[6].y = std::nextafter(2.0, 0.0);  // tracked in slab 3 (begin); the contact reports y = 2
  t.begin(x, v);
  ASSERT_EQ(t.slab_of_particle(6), 3);
  ASSERT_EQ(t.slab_of_particle(5), 6);
  Ref r(S, 0, 1);
  for (const auto& c : cs) {
    CollisionRecord rec;
    rec.ri = c.ri, rec.rij = c.rij, rec.impulse = c.J, rec.dEi = c.dEi, rec.dEj = c.dEj, rec.id_i = c.i, rec.id_j = c.j;
    t.add_collision(rec);
    r.s(t.slab_of_particle(c.i), 2) += 0.5 * (c.dEi + c.dEj);
    r.s(t.slab_of_particle(c.j), 2) += 0.5 * (c.dEi + c.dEj);
    for (const auto& [pl, sg] : c.planes) {
      r.p(pl, 1) += sg * 0.5 * (c.dEj - c.dEi);
      r.p(pl, 3) += sg * c.J.x;
      r.p(pl, 5) += sg * c.J.y;
    }
    double total = 0.0;
    for (const auto& [k, f] : c.shares) {
      r.s(k, 20) += f * c.rij.x * c.J.x;
      r.s(k, 21) += f * c.rij.y * c.J.y;
      r.s(k, 22) += f * c.rij.y * c.J.x;
      total += f;
    }
    EXPECT_NEAR(total, 1.0, 1e-15);
  }
  t.end_interval(1.0, v);
  expect_sums(t.total(), r, 1e-13, "collisions");
  (void)w;
}

// 200 sampling intervals of unequal length: a block per interval until 64 blocks, merged
// pairwise into 32 blocks of 2, and so on (transport.hpp kMaxBlocks): 50 blocks of 4
// intervals at the end. Every block's time and slab sums are those of its own intervals;
// the errors of transport_result are the jackknife over the blocks computed here from the
// blocks' sums (density: Int N dt / (time V)); the slab and plane positions.
TEST(TransportExact, BlocksMergePairwiseAndErrorsAreTheJackknifeOverThem) {
  const int S = 4;
  const double L = 4.0, Lx = 2.0;
  auto make = [&](SlabTransport& t) {
    t.init({2, Vec3{Lx, L, 1.0}, 1, 0, S}, 2);
  };
  SlabTransport t;
  make(t);
  std::vector<Grain> g = {{{0.3, 0.2, 0.0}, {0.0, 0.37, 0.0}, {0.0, 0.0, 0.0}},
                          {{1.1, 2.9, 0.0}, {0.5, -0.23, 0.0}, {0.0, 0.0, 0.0}}};
  t.begin({g[0].r, g[1].r}, {g[0].v, g[1].v});
  std::vector<double> dt;
  SlabTransport resumed;
  for (int n = 0; n < 200; ++n) {
    const double d = 0.6 + 0.5 * std::sin(1.3 * n) * std::sin(1.3 * n);
    const std::vector<Grain> before = g;
    for (std::uint32_t i = 0; i < 2; ++i) fly(t, i, g[i], d, 1, L);
    t.end_interval(d, {g[0].v, g[1].v});
    dt.push_back(d);
    if (n == 129) {
      // a checkpoint in the middle of a block (2 of its 4 intervals): the copy must continue alike
      make(resumed);
      resumed.load(t.save(), true);
    } else if (n > 129) {
      for (std::uint32_t i = 0; i < 2; ++i) {
        Grain h = before[i];
        fly(resumed, i, h, d, 1, L);
      }
      resumed.end_interval(d, {g[0].v, g[1].v});
    }
  }
  const auto& bl = t.blocks();
  ASSERT_EQ(bl.size(), 50u);
  double total_time = 0.0;
  for (std::size_t b = 0; b < bl.size(); ++b) {
    double want = 0.0;
    for (int q = 0; q < 4; ++q) want += dt[4 * b + q];
    EXPECT_NEAR(bl[b].time, want, 1e-13) << b;
    // both grains are somewhere all the time: Int N dt over the slabs = 2 x the block's time
    double occ = 0.0;
    for (int k = 0; k < S; ++k) occ += bl[b].slab[k * kS + 3];
    EXPECT_NEAR(occ, 2.0 * want, 1e-12) << b;
    total_time += want;
  }
  EXPECT_NEAR(t.total().time, total_time, 1e-12);
  // the resumed copy holds the same blocks
  ASSERT_EQ(resumed.blocks().size(), bl.size());
  for (std::size_t b = 0; b < bl.size(); ++b) {
    EXPECT_NEAR(resumed.blocks()[b].time, bl[b].time, 1e-12) << b;
    for (int k = 0; k < S; ++k) EXPECT_NEAR(resumed.blocks()[b].slab[k * kS + 3], bl[b].slab[k * kS + 3], 1e-9) << b;
  }
  // jackknife of the density from the blocks' sums
  const TransportResult res = transport_result(t);
  EXPECT_EQ(res.blocks, 50u);
  const double w = L / S, V = Lx * w;
  const auto& dens = res.field("density");
  for (int k = 0; k < S; ++k) {
    double n_all = 0.0, t_all = 0.0;
    for (const auto& b : bl) n_all += b.slab[k * kS + 3], t_all += b.time;
    std::vector<double> loo;
    for (const auto& b : bl) loo.push_back((n_all - b.slab[k * kS + 3]) / ((t_all - b.time) * V));
    const double B = static_cast<double>(loo.size());
    double avg = 0.0, ss = 0.0;
    for (double l : loo) avg += l / B;
    for (double l : loo) ss += (l - avg) * (l - avg);
    EXPECT_NEAR(dens.mean[k], n_all / (t_all * V), 1e-12) << k;
    EXPECT_NEAR(dens.stderr_[k], std::sqrt((B - 1.0) / B * ss), 1e-9 * std::sqrt((B - 1.0) / B * ss)) << k;
    EXPECT_GT(dens.stderr_[k], 1e-4) << k;
    EXPECT_DOUBLE_EQ(res.z_slab[k], (k + 0.5) * w) << k;
    EXPECT_DOUBLE_EQ(res.z_plane[k], k * w) << k;
  }
}

namespace {
// A block of slab and plane sums made from given per-slab states: occupation N_k (mean number
// of grains), flow u_k and kinetic temperature tensor Th_k (Int Sum v_a v_b dt = Int N dt
// (u_a u_b + Th_ab)); every other entry a distinct value.
struct SlabState {
  double N;
  Vec3 u;
  double Th[3][3];
};
TransportBlock make_block(int S, double time, const std::vector<SlabState>& st, double seed) {
  TransportBlock b{time, std::vector<double>(S * kS, 0.0), std::vector<double>(S * kP, 0.0)};
  for (int k = 0; k < S; ++k) {
    double* s = &b.slab[static_cast<std::size_t>(k) * kS];
    const SlabState& x = st[k];
    const double occ = x.N * time;
    s[3] = occ;
    for (int p = 0; p < 3; ++p) {
      s[4 + p] = occ * cmp(x.u, p);
      for (int q = 0; q < 3; ++q) s[7 + 3 * p + q] = occ * (cmp(x.u, p) * cmp(x.u, q) + x.Th[p][q]);
    }
    s[0] = time * (0.8 + 0.3 * std::cos(seed + k));          // work
    s[1] = time * 0.2 * std::sin(2.0 * std::numbers::pi * (k + 0.5) / S + 0.1 * seed);  // forcing impulse
    s[2] = -time * (0.5 + 0.1 * std::sin(seed * k));          // sink
    s[16] = time * 0.05 * std::cos(3.0 * k + seed);           // storage
    s[17] = time * 0.01 * k, s[18] = -time * 0.02 * k, s[19] = time * 0.03;
    s[20] = time * (1.1 + 0.1 * k), s[21] = time * (0.9 + 0.05 * k), s[22] = time * (0.2 - 0.07 * k);
    double* p = &b.plane[static_cast<std::size_t>(k) * kP];
    for (int q = 0; q < kP; ++q) p[q] = time * (0.3 * std::sin(1.7 * k + q + seed) + 0.05 * q);
  }
  return b;
}
const std::vector<double>& fld(const std::vector<TransportField>& f, const char* name) {
  for (const auto& x : f)
    if (x.name == name) return x.mean;
  throw std::out_of_range(name);
}
double sinc(double x) { return std::sin(x) / x; }
}  // namespace

// The fields of one block of given sums against their definitions (docs/edmd.md "Transport
// coefficients", transport.hpp), in 2D (axis y, component x) and 3D (axis z, component x): a
// flowing, anisotropic, sheared state in each slab.
TEST(TransportExact, FieldsOfAGivenBlockFollowTheirDefinitions) {
  for (int D : {2, 3}) {
    const int S = 6, ax = D == 2 ? 1 : 2, c = 0;
    const Vec3 box = D == 2 ? Vec3{2.0, 9.0, 1.0} : Vec3{2.0, 1.5, 9.0};  // slabs of width 1.5: V != A
    SlabTransport t;
    t.init({D, box, ax, c, S}, 1);
    const double w = 1.5, A = D == 2 ? 2.0 : 3.0, V = A * w, time = 2.5;
    ASSERT_DOUBLE_EQ(t.slab_width(), w);
    ASSERT_DOUBLE_EQ(t.cross_section(), A);
    std::vector<SlabState> st(S);
    for (int k = 0; k < S; ++k) {
      SlabState& x = st[k];
      x.N = 0.4 + 0.1 * k + 0.05 * (k % 2);
      x.u = {0.3 * std::sin(1.0 + k), 0.0, 0.0};
      (ax == 1 ? x.u.y : x.u.z) = 0.1 - 0.04 * k;
      const double tx = 1.0 + 0.2 * k, ty = 0.7 + 0.1 * k * k / 5.0, tz = D == 3 ? 0.9 - 0.05 * k : 0.0;
      const double txy = 0.1 + 0.02 * k;
      for (auto& row : x.Th)
        for (double& e : row) e = 0.0;
      x.Th[0][0] = tx, x.Th[1][1] = ty, x.Th[2][2] = tz;
      x.Th[0][ax] = x.Th[ax][0] = txy;  // component-axis correlation
    }
    const TransportBlock b = make_block(S, time, st, 0.3 * D);
    const auto f = transport_fields(t, b);
    auto sl = [&](int k, int q) { return b.slab[static_cast<std::size_t>((k + S) % S) * kS + q]; };
    auto pl = [&](int k, int q) { return b.plane[static_cast<std::size_t>((k + S) % S) * kP + q]; };
    const double pack_per_n = D == 2 ? std::numbers::pi / 4.0 : std::numbers::pi / 6.0;
    double fb = 0.0, fz = 0.0;
    for (int k = 0; k < S; ++k) {
      const SlabState& x = st[k];
      const double n = x.N / V, Tc = x.Th[c][c], Tz = x.Th[ax][ax], T = (x.Th[0][0] + x.Th[1][1] + x.Th[2][2]) / D;
      const double tol = 1e-12;
      SCOPED_TRACE(::testing::Message() << "D = " << D << ", slab/plane " << k);
      EXPECT_NEAR(fld(f, "density")[k], n, tol);
      EXPECT_NEAR(fld(f, "packing")[k], n * pack_per_n, tol);
      EXPECT_NEAR(fld(f, "T")[k], T, tol);
      EXPECT_NEAR(fld(f, "T_c")[k], Tc, tol);
      EXPECT_NEAR(fld(f, "T_z")[k], Tz, tol);
      EXPECT_NEAR(fld(f, "u_c")[k], cmp(x.u, c), tol);
      EXPECT_NEAR(fld(f, "u_z")[k], cmp(x.u, ax), tol);
      EXPECT_NEAR(fld(f, "work_rate")[k], sl(k, 0) / (V * time), tol);
      EXPECT_NEAR(fld(f, "loss_rate")[k], -sl(k, 2) / (V * time), tol);
      EXPECT_GT(fld(f, "loss_rate")[k], 0.0);
      EXPECT_NEAR(fld(f, "storage_rate")[k], sl(k, 16) / (V * time), tol);
      EXPECT_NEAR(fld(f, "forcing_density")[k], sl(k, 1) / (V * time), tol);
      // pressure tensor of the slab: kinetic n Th + virial / (V time)
      const double pcc = n * Tc + sl(k, 20) / (V * time), pzz = n * Tz + sl(k, 21) / (V * time);
      EXPECT_NEAR(fld(f, "P_cc_slab")[k], pcc, tol);
      EXPECT_NEAR(fld(f, "P_zz_slab")[k], pzz, tol);
      EXPECT_NEAR(fld(f, "P_cz_slab")[k], n * x.Th[c][ax] + sl(k, 22) / (V * time), tol);
      EXPECT_NEAR(fld(f, "normal_stress_difference")[k], (pcc - pzz) / (0.5 * (pcc + pzz)), tol);
      // planes
      const double Fk = pl(k, 0) / (A * time), Fc = pl(k, 1) / (A * time);
      EXPECT_NEAR(fld(f, "energy_flux_kin")[k], Fk, tol);
      EXPECT_NEAR(fld(f, "energy_flux_col")[k], Fc, tol);
      EXPECT_NEAR(fld(f, "energy_flux")[k], Fk + Fc, tol);
      if (k == 0) fb = Fk + Fc;
      EXPECT_NEAR(fld(f, "energy_flux_balance")[k], fb, tol);
      EXPECT_NEAR(fld(f, "energy_flux_bizon")[k], fz, tol);
      fb += (sl(k, 0) + sl(k, 2) - sl(k, 16)) / (A * time);
      fz += (sl(k, 0) + sl(k, 2)) / (A * time);
      EXPECT_NEAR(fld(f, "P_cz_kin")[k], pl(k, 2) / (A * time), tol);
      EXPECT_NEAR(fld(f, "P_cz_col")[k], pl(k, 3) / (A * time), tol);
      EXPECT_NEAR(fld(f, "P_cz")[k], (pl(k, 2) + pl(k, 3)) / (A * time), tol);
      EXPECT_NEAR(fld(f, "P_zz")[k], (pl(k, 4) + pl(k, 5)) / (A * time), tol);
      EXPECT_NEAR(fld(f, "net_flux")[k], pl(k, 6) / (A * time), tol);
      const double du = (cmp(x.u, c) - cmp(st[(k + S - 1) % S].u, c)) / (w * std::pow(sinc(std::numbers::pi / S), 2));
      EXPECT_NEAR(fld(f, "dudz")[k], du, tol);
      // Enskog at the plane's packing and temperature (their stencils are tested elsewhere)
      const double pp = fld(f, "packing_plane")[k], tp = fld(f, "T_plane")[k];
      const double g = D == 2 ? theory::g_contact_disk_cs(pp) : theory::g_contact_sphere_cs(pp);
      const double ke = theory::enskog_conductivity(D, pp, g, tp);
      EXPECT_NEAR(fld(f, "kappa_enskog")[k], ke, tol * ke);
      EXPECT_NEAR(fld(f, "mu_enskog")[k], theory::enskog_viscosity(D, pp, g, tp), tol * ke);
      const double kappa = -(Fk + Fc) / fld(f, "dTdz")[k];
      EXPECT_NEAR(fld(f, "kappa")[k], kappa, 1e-12 * std::abs(kappa));
      EXPECT_NEAR(fld(f, "kappa_ratio")[k], kappa / ke, 1e-12 * std::abs(kappa / ke));
      // the plane's packing from the stencil's n (cubic-exact average of the four slabs)
      auto nn = [&](int j) { return st[(j + S) % S].N / V; };
      EXPECT_NEAR(pp, pack_per_n * (7.0 * (nn(k) + nn(k - 1)) - (nn(k + 1) + nn(k - 2))) / 12.0, tol);
    }
  }
}

// Where the stencil cannot be used the planes keep the two-slab forms: with three slabs (the
// stencil would reuse a slab), and at a plane whose stencil n is positive but whose stencil
// n T is not (hot outer slabs).
TEST(TransportExact, TwoSlabFormsWithThreeSlabsAndWhereTheStencilEnergyIsNotPositive) {
  auto check = [](int S, const std::vector<double>& n, const std::vector<double>& T, const std::vector<int>& planes) {
    SlabTransport t;
    t.init({2, Vec3{1.0, 1.0 * S, 1.0}, 1, 0, S}, 1);
    std::vector<SlabState> st(S);
    for (int k = 0; k < S; ++k) {
      st[k].N = n[k], st[k].u = {0, 0, 0};
      for (auto& row : st[k].Th)
        for (double& e : row) e = 0.0;
      st[k].Th[0][0] = st[k].Th[1][1] = T[k];
    }
    const auto f = transport_fields(t, make_block(S, 1.0, st, 0.0));
    for (int k : planes) {
      const int km = (k + S - 1) % S;
      SCOPED_TRACE(::testing::Message() << "S = " << S << ", plane " << k);
      EXPECT_NEAR(fld(f, "T_plane")[k], 0.5 * (T[k] + T[km]), 1e-12);
      EXPECT_NEAR(fld(f, "dTdz")[k], T[k] - T[km], 1e-12);
      EXPECT_NEAR(fld(f, "packing_plane")[k], 0.5 * std::numbers::pi / 4.0 * (n[k] + n[km]), 1e-12);
    }
  };
  check(3, {0.3, 0.5, 0.4}, {1.0, 2.0, 4.0}, {0, 1, 2});
  // 8 slabs, n = 0.5 everywhere, slabs 1 and 4 twenty times hotter: plane 3's stencil n T is
  // (7 (0.5 + 0.5) - (10 + 10)) / 12 < 0
  check(8, std::vector<double>(8, 0.5), {1, 20, 1, 1, 20, 1, 1, 1}, {3});
}

namespace {
// A SlabTransport holding the given blocks (through a checkpoint made by hand).
void hold_blocks(SlabTransport& t, const std::vector<TransportBlock>& bl) {
  const int S = t.setup().slabs;
  TransportCheckpoint ck;
  ck.stored.assign(3 * static_cast<std::size_t>(S), 0.0);
  for (const auto& b : bl) {
    ck.blocks.push_back(b.time);
    ck.blocks.insert(ck.blocks.end(), b.slab.begin(), b.slab.end());
    ck.blocks.insert(ck.blocks.end(), b.plane.begin(), b.plane.end());
  }
  ck.open.assign(1 + static_cast<std::size_t>(S) * (kS + kP), 0.0);
  ck.slab_of.assign(1, 0);
  ck.counts = {1, 0, bl.size()};
  t.load(ck, true);
}
double scalar(const std::vector<TransportScalar>& s, const std::string& name) {
  for (const auto& x : s)
    if (x.name == name) return x.value;
  throw std::out_of_range(name);
}
}  // namespace

// The summary scalars of two blocks of given sums (10 slabs of width 2 in 2D) against their
// definitions (docs/edmd.md "Output"), computed here from the fields of the summed block: the
// grain-weighted T_mean, the box means of the pressure tensor, the fit planes 1-4 and 6-9 (at
// 0.2-0.8 of L/2 from the peak, both ends included) and those below packing 0.70 among them,
// Newton's least-squares line and the forced mode, the mode amplitudes at the slab centres.
TEST(TransportExact, SummaryScalarsFollowTheirDefinitions) {
  const int S = 10;
  const double L = 20.0, w = 2.0, A = 5.0, V = A * w;
  SlabTransport t;
  t.init({2, Vec3{A, L, 1.0}, 1, 0, S}, 1);
  std::vector<SlabState> st(S);
  for (int k = 0; k < S; ++k) {
    SlabState& x = st[k];
    const double zc = (k + 0.5) * w;
    // dense, cold near the periodic face, dilute and hot at the peak: packing 0.47-0.86
    x.N = V * (1.1 - 0.5 * std::sin(std::numbers::pi * zc / L) + 0.02 * (k % 3));
    x.u = {0.3 * std::sin(2.0 * std::numbers::pi * zc / L) + 0.04 * std::cos(4.0 * k), 0.01 * k - 0.05, 0.0};
    for (auto& row : x.Th)
      for (double& e : row) e = 0.0;
    x.Th[0][0] = 0.5 + 1.5 * std::sin(std::numbers::pi * zc / L) + 0.03 * k;
    x.Th[1][1] = 0.45 + 1.4 * std::sin(std::numbers::pi * zc / L);
  }
  std::vector<TransportBlock> bl = {make_block(S, 3.0, st, 0.7), make_block(S, 2.0, st, 1.9)};
  hold_blocks(t, bl);
  ASSERT_EQ(t.blocks().size(), 2u);
  const auto f = transport_fields(t, t.total());
  const auto &dens = fld(f, "density"), &T = fld(f, "T");
  double occ = 0.0, Tm = 0.0;
  for (int k = 0; k < S; ++k) occ += dens[k], Tm += dens[k] * T[k];
  Tm /= occ;
  const double pack = std::numbers::pi / 4.0 * occ / S;
  TransportAnalysis an;
  for (auto kind : {TransportAnalysis::conductivity, TransportAnalysis::viscosity}) {
    an.kind = kind;
    const auto sc = transport_scalars(t, an);
    SCOPED_TRACE(kind == TransportAnalysis::conductivity ? "conductivity" : "viscosity");
    EXPECT_NEAR(scalar(sc, "T_mean"), Tm, 1e-12);
    EXPECT_NEAR(scalar(sc, "packing_mean"), pack, 1e-12);
    double pc = 0.0, pz = 0.0, pzp = 0.0;
    for (int k = 0; k < S; ++k) pc += fld(f, "P_cc_slab")[k], pz += fld(f, "P_zz_slab")[k], pzp += fld(f, "P_zz")[k];
    EXPECT_NEAR(scalar(sc, "P_cc_mean"), pc / S, 1e-12);
    EXPECT_NEAR(scalar(sc, "P_zz_mean"), pz / S, 1e-12);
    EXPECT_NEAR(scalar(sc, "P_zz_planes_mean"), pzp / S, 1e-12);
    EXPECT_NEAR(scalar(sc, "normal_stress_difference"), (pc - pz) / (0.5 * (pc + pz)), 1e-12);
  }
  {
    an.kind = TransportAnalysis::conductivity;
    const auto sc = transport_scalars(t, an);
    const auto &kr = fld(f, "kappa_ratio"), &ka = fld(f, "kappa"), &ke = fld(f, "kappa_enskog"), &tp = fld(f, "T_plane");
    const auto &F = fld(f, "energy_flux"), &Fb = fld(f, "energy_flux_bizon"), &pp = fld(f, "packing_plane");
    double r = 0, kk = 0, kke = 0, tt = 0, sf = 0, sfb = 0, rf = 0, tf = 0, nf = 0, solid = 0;
    for (int k : {1, 2, 3, 4, 6, 7, 8, 9}) {
      r += kr[k] / 8, kk += ka[k] / 8, kke += ke[k] / 8, tt += tp[k] / 8, sf += std::abs(F[k]), sfb += std::abs(Fb[k]);
      if (pp[k] < 0.70) rf += kr[k], tf += tp[k], nf += 1.0;
      else solid += 1.0;
    }
    ASSERT_GE(nf, 2.0);
    ASSERT_GE(solid, 2.0);  // both kinds of fit plane are present
    EXPECT_NEAR(scalar(sc, "kappa_over_enskog"), r, 1e-12 * std::abs(r));
    EXPECT_NEAR(scalar(sc, "kappa"), kk, 1e-12 * std::abs(kk));
    EXPECT_NEAR(scalar(sc, "kappa_enskog"), kke, 1e-12 * kke);
    EXPECT_NEAR(scalar(sc, "T_fit"), tt, 1e-12);
    EXPECT_NEAR(scalar(sc, "flux_over_bizon_integrated"), sf / sfb, 1e-12 * sf / sfb);
    EXPECT_NEAR(scalar(sc, "kappa_over_enskog_fluid"), rf / nf, 1e-12 * std::abs(rf / nf));
    EXPECT_NEAR(scalar(sc, "T_fit_fluid"), tf / nf, 1e-12);
    EXPECT_EQ(scalar(sc, "fluid_planes"), nf);
  }
  {
    an.kind = TransportAnalysis::viscosity;
    const auto sc = transport_scalars(t, an);
    const auto &P = fld(f, "P_cz"), &du = fld(f, "dudz"), &uc = fld(f, "u_c"), &fd = fld(f, "forcing_density");
    const auto &Tc = fld(f, "T_c"), &Tz = fld(f, "T_z");
    // least squares P = alpha + beta du/dz in centred form
    double mx = 0, my = 0;
    for (int k = 0; k < S; ++k) mx += du[k] / S, my += P[k] / S;
    double sxx = 0, sxy = 0;
    for (int k = 0; k < S; ++k) sxx += (du[k] - mx) * (du[k] - mx), sxy += (du[k] - mx) * (P[k] - my);
    const double beta = sxy / sxx, alpha = my - beta * mx;
    const double mu0 = theory::enskog_viscosity(2, pack, theory::g_contact_disk_cs(pack), Tm);
    EXPECT_NEAR(scalar(sc, "mu"), -beta, 1e-10 * std::abs(beta));
    EXPECT_NEAR(scalar(sc, "fit_intercept"), alpha, 1e-10 * (std::abs(alpha) + std::abs(my)));
    EXPECT_NEAR(scalar(sc, "mu_enskog"), mu0, 1e-12 * mu0);
    EXPECT_NEAR(scalar(sc, "mu_over_enskog"), -beta / mu0, 1e-10 * std::abs(beta / mu0));
    const double kw = 2.0 * std::numbers::pi / L, sn = sinc(std::numbers::pi / S);
    double Pc = 0, Gc = 0, Us = 0, Fs = 0, umax = 0, gmax = 0, an_sum = 0;
    for (int k = 0; k < S; ++k) {
      const double zp = k * w, zc = (k + 0.5) * w;
      Pc += P[k] * std::cos(kw * zp), Gc += du[k] * std::cos(kw * zp);
      Us += uc[k] * std::sin(kw * zc), Fs += fd[k] * std::sin(kw * zc);
      umax = std::max(umax, std::abs(uc[k])), gmax = std::max(gmax, std::abs(du[k]));
      an_sum += Tc[k] / Tz[k] - 1.0;
    }
    EXPECT_NEAR(scalar(sc, "mu_mode"), -Pc / Gc, 1e-12 * std::abs(Pc / Gc));
    EXPECT_NEAR(scalar(sc, "mu_mode_over_enskog"), -Pc / Gc / mu0, 1e-12 * std::abs(Pc / Gc / mu0));
    EXPECT_NEAR(scalar(sc, "velocity_amplitude"), 2.0 * Us / (S * sn), 1e-12);
    EXPECT_NEAR(scalar(sc, "force_amplitude"), 2.0 * Fs / (S * sn), 1e-12);
    EXPECT_NEAR(scalar(sc, "mu_from_forcing"), Fs / (kw * kw * Us), 1e-12 * std::abs(Fs / (kw * kw * Us)));
    EXPECT_NEAR(scalar(sc, "mach_max"), umax / std::sqrt(Tm), 1e-12);
    EXPECT_NEAR(scalar(sc, "shear_rate_max"), gmax, 1e-12);
    EXPECT_NEAR(scalar(sc, "anisotropy"), an_sum / S, 1e-12);
    // the velocity's sine mode is resolved (0.3 at the slab centres, times sinc(pi/S))
    EXPECT_NEAR(2.0 * Us / (S * sn), 0.3, 0.05);
  }
}
