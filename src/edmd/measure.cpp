#include "edmd/measure.hpp"

#include <immintrin.h>

#include <algorithm>
#include <bit>

#include "operators/random.hpp"  // Philox4x32Lanes::have_avx2: the run-time SIMD dispatch

namespace grainbath::edmd {

namespace {
inline double& comp(Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
inline double comp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
}  // namespace

void PairStatistics::init(int d, Vec3 box, std::array<bool, 3> w, double r_max, double grb, double cb) {
  dims = d;
  L = box;
  walls = w;
  double half = 1e300;
  for (int k = 0; k < dims; ++k) half = std::min(half, 0.5 * comp(L, k));
  rmax = std::min(r_max, half);
  gr_bin = grb;
  corr_bin = cb;
  gr_counts.assign(static_cast<std::size_t>(std::ceil(rmax / gr_bin)), 0.0);
  const std::size_t nc = static_cast<std::size_t>(std::ceil(rmax / corr_bin));
  corr_par.assign(nc, 0.0);
  corr_perp.assign(nc, 0.0);
  corr_counts.assign(nc, 0.0);
}

// One pair (i, j) at separation dr (the nearest image, j minus i): g(r) and the velocity
// correlations (Bizon eqs. 25-26) into the histograms `h`. Pairs at r >= rmax are ignored.
namespace {
struct PairHistograms {
  double* gr;
  double *par, *perp, *count;
  std::size_t gr_bins, corr_bins;
};
inline void accumulate_pair(const PairHistograms& h, double rmax, double gr_bin, double corr_bin, const Vec3& dr,
                            const Vec3& vi, const Vec3& vj) {
  const double r2 = norm2(dr);
  if (r2 >= rmax * rmax) return;
  const double r = std::sqrt(r2);
  const std::size_t b = static_cast<std::size_t>(r / gr_bin);
  if (b < h.gr_bins) h.gr[b] += 1.0;
  const std::size_t c = static_cast<std::size_t>(r / corr_bin);
  if (c < h.corr_bins && r > 0.0) {
    const Vec3 k = (1.0 / r) * dr;
    const double p1 = dot(vi, k), p2 = dot(vj, k);
    const Vec3 q1 = vi - p1 * k, q2 = vj - p2 * k;
    h.par[c] += p1 * p2;
    h.perp[c] += dot(q1, q2);
    h.count[c] += 1.0;
  }
}

// The grains of a snapshot in cell order, one array per component, so that a run of
// candidates j is read four at a time by the AVX2 kernel below.
struct SortedGrains {
  std::vector<double> x, y, z, vx, vy, vz;
  // three spare grains after the last, read (and ignored) by the last AVX2 group of a run
  void resize(std::size_t n) {
    for (auto* a : {&x, &y, &z, &vx, &vy, &vz}) a->assign(n + 3, 0.0);
  }
  Vec3 position(std::size_t k) const { return {x[k], y[k], z[k]}; }
  Vec3 velocity(std::size_t k) const { return {vx[k], vy[k], vz[k]}; }
};

struct PairBins {
  double rmax, gr_bin, corr_bin;
};

// Grain i (position xi, already shifted to the image of the run) against the candidates
// j0 <= j < j1, one at a time in j order.
void pair_run_scalar(const PairHistograms& h, const PairBins& p, const SortedGrains& g, const Vec3& xi, const Vec3& vi,
                     std::size_t j0, std::size_t j1) {
  for (std::size_t j = j0; j < j1; ++j) accumulate_pair(h, p.rmax, p.gr_bin, p.corr_bin, g.position(j) - xi, vi, g.velocity(j));
}

// dot(a, b) of vec3.hpp in four lanes: (ax bx + ay by) + az bz
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d dot3(__m256d ax, __m256d ay, __m256d az, __m256d bx,
                                                               __m256d by, __m256d bz) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ax, bx), _mm256_mul_pd(ay, by)), _mm256_mul_pd(az, bz));
}

// The candidates of one run that are in range, packed: pass 1 of pair_run_avx2 writes
// them, pass 2 reads them four at a time. Room for a run of `n` candidates plus a group.
struct PackedPairs {
  std::vector<double> dx, dy, dz, r2, vx, vy, vz;
  void reserve(std::size_t n) {
    for (auto* a : {&dx, &dy, &dz, &r2, &vx, &vy, &vz})
      if (a->size() < n + 4) a->assign(n + 4, 1.0);
  }
};

// For each 4-bit mask of accepted lanes, the permutation of eight 32-bit words that moves the
// accepted doubles (two words each) to the front in lane order.
struct PackTable {
  alignas(32) std::int32_t words[16][8];
  constexpr PackTable() : words{} {
    for (int m = 0; m < 16; ++m) {
      int k = 0;
      for (int l = 0; l < 4; ++l)
        if (m & (1 << l)) words[m][2 * k] = 2 * l, words[m][2 * k + 1] = 2 * l + 1, ++k;
      for (; k < 4; ++k) words[m][2 * k] = 0, words[m][2 * k + 1] = 1;
    }
  }
};
constexpr PackTable kPack{};

// Stores the lanes of v selected by perm (a kPack row) to out, packed to the front.
[[gnu::target("avx2"), gnu::always_inline]] inline void pack(double* out, __m256d v, __m256i perm) {
  _mm256_storeu_pd(out, _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(v), perm)));
}

// Pass 1 of the AVX2 kernels for one group of four candidates j .. j + 3 (separations dx, dy,
// dz from grain i; only the first `left` lanes are candidates): r^2 as accumulate_pair
// computes it, and the lanes in range appended to `pk` at n, in j order. Returns the new count.
[[gnu::target("avx2"), gnu::always_inline]] inline std::size_t pack_in_range(__m256d dx, __m256d dy, __m256d dz,
                                                                            const SortedGrains& g, std::size_t j,
                                                                            std::size_t left, __m256d r2max,
                                                                            PackedPairs& pk, std::size_t n) {
  // norm2 = (dx dx + dy dy) + dz dz
  const __m256d r2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
  const unsigned in = static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(r2, r2max, _CMP_LT_OQ))) &
                      (left >= 4 ? 15u : (1u << left) - 1u);
  const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kPack.words[in]));
  pack(&pk.dx[n], dx, perm);
  pack(&pk.dy[n], dy, perm);
  pack(&pk.dz[n], dz, perm);
  pack(&pk.r2[n], r2, perm);
  pack(&pk.vx[n], _mm256_loadu_pd(&g.vx[j]), perm);
  pack(&pk.vy[n], _mm256_loadu_pd(&g.vy[j]), perm);
  pack(&pk.vz[n], _mm256_loadu_pd(&g.vz[j]), perm);
  return n + static_cast<std::size_t>(std::popcount(in));
}

// Pass 2 of the AVX2 kernels: the n packed pairs of grain i (velocity vi) four at a time into
// the histograms: square roots, the three divisions and the correlation products (the IEEE
// operations of accumulate_pair in its order, no FMA: the same values bit for bit), then the
// histograms incremented lane by lane in packed (j) order.
[[gnu::target("avx2"), gnu::always_inline]] inline void accumulate_packed(const PairHistograms& h, const PairBins& p,
                                                                         const Vec3& vi, const PackedPairs& pk,
                                                                         std::size_t n) {
  const __m256d vix = _mm256_set1_pd(vi.x), viy = _mm256_set1_pd(vi.y), viz = _mm256_set1_pd(vi.z);
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d grb = _mm256_set1_pd(p.gr_bin), crb = _mm256_set1_pd(p.corr_bin);
  alignas(32) double rb[4], rc[4], r[4], par[4], perp[4];
  for (std::size_t q = 0; q < n; q += 4) {
    const __m256d dx = _mm256_loadu_pd(&pk.dx[q]), dy = _mm256_loadu_pd(&pk.dy[q]), dz = _mm256_loadu_pd(&pk.dz[q]);
    // lanes past n hold stale or initial values: finite, and their adds go to spare bins
    const __m256d rr = _mm256_sqrt_pd(_mm256_loadu_pd(&pk.r2[q]));
    const __m256d inv = _mm256_div_pd(one, rr);
    const __m256d kx = _mm256_mul_pd(dx, inv), ky = _mm256_mul_pd(dy, inv), kz = _mm256_mul_pd(dz, inv);
    const __m256d vjx = _mm256_loadu_pd(&pk.vx[q]), vjy = _mm256_loadu_pd(&pk.vy[q]), vjz = _mm256_loadu_pd(&pk.vz[q]);
    const __m256d p1 = dot3(vix, viy, viz, kx, ky, kz), p2 = dot3(vjx, vjy, vjz, kx, ky, kz);
    // q = v - p k
    const __m256d q1x = _mm256_sub_pd(vix, _mm256_mul_pd(kx, p1)), q1y = _mm256_sub_pd(viy, _mm256_mul_pd(ky, p1)),
                  q1z = _mm256_sub_pd(viz, _mm256_mul_pd(kz, p1));
    const __m256d q2x = _mm256_sub_pd(vjx, _mm256_mul_pd(kx, p2)), q2y = _mm256_sub_pd(vjy, _mm256_mul_pd(ky, p2)),
                  q2z = _mm256_sub_pd(vjz, _mm256_mul_pd(kz, p2));
    _mm256_store_pd(rb, _mm256_div_pd(rr, grb));
    _mm256_store_pd(rc, _mm256_div_pd(rr, crb));
    _mm256_store_pd(r, rr);
    _mm256_store_pd(par, _mm256_mul_pd(p1, p2));
    _mm256_store_pd(perp, dot3(q1x, q1y, q1z, q2x, q2y, q2z));
    for (int l = 0; l < 4; ++l) {
      const bool lane = q + static_cast<std::size_t>(l) < n;
      // bins of lanes past n are never used: clamp before converting
      const std::size_t b = lane ? static_cast<std::size_t>(rb[l]) : h.gr_bins;
      const std::size_t c = lane ? static_cast<std::size_t>(rc[l]) : h.corr_bins;
      h.gr[b < h.gr_bins ? b : h.gr_bins + l] += 1.0;
      const std::size_t cc = c < h.corr_bins && r[l] > 0.0 ? c : h.corr_bins + l;
      h.par[cc] += par[l];
      h.perp[cc] += perp[l];
      h.count[cc] += 1.0;
    }
  }
}

// The same in AVX2 lanes, in two passes so that the divider (a square root and 1/r per
// pair, the bottleneck: perf puts the samples behind vsqrtpd and vdivpd) only sees pairs in
// range, about half of the candidates at the defaults:
//  1. four candidates at a time: r^2 (accumulate_pair's operations), and the accepted lanes'
//     dr, r^2 and velocity packed to the front of `pk` in j order (a permutation per mask);
//  2. the packed pairs four at a time: square roots, the three divisions and the correlation
//     products (the IEEE operations of accumulate_pair in its order, no FMA: the same values
//     bit for bit), then the histograms incremented lane by lane in j order.
// So the sums are bitwise those of pair_run_scalar (tested). The last group of pass 1 reads
// up to three grains past j1 (the arrays are padded) and masks them; lanes past the packed
// count, bins past the end and r = 0 add to spare bins of their own after the last ones
// (h's arrays have gr_bins + 4 and corr_bins + 4 entries), never read.
[[gnu::target("avx2")]] void pair_run_avx2(const PairHistograms& h, const PairBins& p, const SortedGrains& g,
                                           const Vec3& xi, const Vec3& vi, std::size_t j0, std::size_t j1,
                                           PackedPairs& pk) {
  const __m256d xix = _mm256_set1_pd(xi.x), xiy = _mm256_set1_pd(xi.y), xiz = _mm256_set1_pd(xi.z);
  const __m256d r2max = _mm256_set1_pd(p.rmax * p.rmax);
  std::size_t n = 0;
  for (std::size_t j = j0; j < j1; j += 4) {
    const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(&g.x[j]), xix);
    const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(&g.y[j]), xiy);
    const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(&g.z[j]), xiz);
    n = pack_in_range(dx, dy, dz, g, j, j1 - j, r2max, pk, n);
  }
  accumulate_packed(h, p, vi, pk, n);
}

// std::round (halves away from zero) in four lanes, bit for bit: trunc(q), moved one away from
// zero where |q - trunc(q)| >= 1/2 (q - trunc(q) is exact for every double); trunc keeps the
// sign of a zero as std::round does.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d round_half_away(__m256d q) {
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d t = _mm256_round_pd(q, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
  const __m256d frac = _mm256_andnot_pd(sign, _mm256_sub_pd(q, t));
  const __m256d away = _mm256_add_pd(t, _mm256_or_pd(_mm256_and_pd(q, sign), _mm256_set1_pd(1.0)));
  return _mm256_blendv_pd(t, away, _mm256_cmp_pd(frac, _mm256_set1_pd(0.5), _CMP_GE_OQ));
}

// The direct sum's AVX2 kernel: grain i against the grains i < j < n in id order, with
// add_all_pairs' operations in four lanes (dr = x_j - x_i; along a periodic dimension
// c -= L round(c / L); z = 0 in 2D), then pass 2 as above: the same bits as add_all_pairs
// (tested). `image` holds L along the periodic dimensions and 0 along walls.
[[gnu::target("avx2")]] void pair_all_avx2(const PairHistograms& h, const PairBins& p, const SortedGrains& g,
                                           std::size_t i, std::size_t n_grains, const double (&image)[3], bool flat,
                                           PackedPairs& pk) {
  const __m256d xix = _mm256_set1_pd(g.x[i]), xiy = _mm256_set1_pd(g.y[i]), xiz = _mm256_set1_pd(g.z[i]);
  const __m256d lx = _mm256_set1_pd(image[0]), ly = _mm256_set1_pd(image[1]), lz = _mm256_set1_pd(image[2]);
  const bool wrap_x = image[0] > 0.0, wrap_y = image[1] > 0.0, wrap_z = image[2] > 0.0 && !flat;
  const __m256d r2max = _mm256_set1_pd(p.rmax * p.rmax);
  std::size_t n = 0;
  for (std::size_t j = i + 1; j < n_grains; j += 4) {
    __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(&g.x[j]), xix);
    __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(&g.y[j]), xiy);
    __m256d dz = flat ? _mm256_setzero_pd() : _mm256_sub_pd(_mm256_loadu_pd(&g.z[j]), xiz);
    if (wrap_x) dx = _mm256_sub_pd(dx, _mm256_mul_pd(lx, round_half_away(_mm256_div_pd(dx, lx))));
    if (wrap_y) dy = _mm256_sub_pd(dy, _mm256_mul_pd(ly, round_half_away(_mm256_div_pd(dy, ly))));
    if (wrap_z) dz = _mm256_sub_pd(dz, _mm256_mul_pd(lz, round_half_away(_mm256_div_pd(dz, lz))));
    n = pack_in_range(dx, dy, dz, g, j, n_grains - j, r2max, pk, n);
  }
  accumulate_packed(h, p, g.velocity(i), pk, n);
}

// add_all_pairs through pair_all_avx2. The histograms' running sums are copied into arrays
// with the kernels' four spare bins after each and back, so that every pair adds to them in
// add_all_pairs' order (summing a snapshot apart first would round differently). The direct
// sum serves the boxes too small for the cell search, among them every run of N <= 4000
// grains, whose correlations reach L/2 (driver.cpp): 64 % of a white-noise run of
// cases/bizon-heat-baths went to the scalar loop (perf, docs/performance/edmd.md).
void add_all_pairs_avx2(PairStatistics& s, const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  const std::size_t gb = s.gr_counts.size(), cb = s.corr_counts.size();
  std::vector<double> sums((gb + 4) + 3 * (cb + 4), 0.0);
  double* const gr = sums.data();
  double* const par = gr + gb + 4;
  double* const perp = par + cb + 4;
  double* const count = perp + cb + 4;
  std::copy(s.gr_counts.begin(), s.gr_counts.end(), gr);
  std::copy(s.corr_par.begin(), s.corr_par.end(), par);
  std::copy(s.corr_perp.begin(), s.corr_perp.end(), perp);
  std::copy(s.corr_counts.begin(), s.corr_counts.end(), count);
  const PairHistograms h{gr, par, perp, count, gb, cb};
  SortedGrains g;
  g.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    g.x[i] = x[i].x, g.y[i] = x[i].y, g.z[i] = x[i].z;
    g.vx[i] = v[i].x, g.vy[i] = v[i].y, g.vz[i] = v[i].z;
  }
  double image[3] = {0.0, 0.0, 0.0};
  for (int d = 0; d < s.dims; ++d) image[d] = s.walls[d] ? 0.0 : comp(s.L, d);
  PackedPairs pk;
  pk.reserve(x.size());
  const PairBins bins{s.rmax, s.gr_bin, s.corr_bin};
  for (std::size_t i = 0; i < x.size(); ++i) pair_all_avx2(h, bins, g, i, x.size(), image, s.dims == 2, pk);
  std::copy(gr, gr + gb, s.gr_counts.begin());
  std::copy(par, par + cb, s.corr_par.begin());
  std::copy(perp, perp + cb, s.corr_perp.begin());
  std::copy(count, count + cb, s.corr_counts.begin());
}
}  // namespace

void PairStatistics::add_all_pairs(const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  const PairHistograms h{gr_counts.data(), corr_par.data(), corr_perp.data(), corr_counts.data(), gr_counts.size(),
                         corr_counts.size()};
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) {
      Vec3 dr = x[j] - x[i];
      for (int d = 0; d < dims; ++d) {
        if (walls[d]) continue;
        double& c = comp(dr, d);
        const double l = comp(L, d);
        c -= l * std::round(c / l);
      }
      if (dims == 2) dr.z = 0.0;
      accumulate_pair(h, rmax, gr_bin, corr_bin, dr, v[i], v[j]);
    }
}

void PairStatistics::add(const std::vector<Vec3>& x, const std::vector<Vec3>& v, double temperature, PairKernel kernel) {
  n = x.size();
  ++snapshots;
  temperature_sum += temperature;
  // Cells of side >= rmax / s, s = 2, where the box holds 2s + 1 = 5 of them along every
  // dimension (else all pairs): the candidates of a grain then cover (2s + 1)^D (rmax/s)^D,
  // 6.25 rmax^2 in 2D against 9 rmax^2 for cells of rmax, with the circle pi rmax^2 of the
  // pairs kept. At N = 10^6 disks (rmax = 10) this step took a third of a run's time with
  // cells of rmax, in id order (perf, docs/performance/edmd.md).
  constexpr int s = 2;
  std::array<int, 3> nc{1, 1, 1};
  bool fits = true;
  for (int d = 0; d < dims; ++d) fits = fits && std::floor(comp(L, d) / (rmax / s)) >= 2 * s + 1;
  if (!fits) {
    if (kernel == PairKernel::automatic && Philox4x32Lanes::have_avx2()) add_all_pairs_avx2(*this, x, v);
    else add_all_pairs(x, v);
    return;
  }
  for (int d = 0; d < dims; ++d) nc[d] = static_cast<int>(std::floor(comp(L, d) / (rmax / s)));
  // counting sort by cell: positions wrapped into the box (periodic dimensions) and velocities
  // in cell order, so that a cell's members are read as one contiguous run
  const std::size_t ncell = static_cast<std::size_t>(nc[0]) * nc[1] * nc[2];
  std::vector<std::uint32_t> cell_of(x.size()), start(ncell + 1, 0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::size_t idx = 0;
    for (int d = dims - 1; d >= 0; --d) {
      const double l = comp(L, d);
      double p = comp(x[i], d);
      if (!walls[d]) p -= l * std::floor(p / l);  // periodic: into [0, L); walls: as is
      const int c = std::clamp(static_cast<int>(p / l * nc[d]), 0, nc[d] - 1);
      idx = idx * static_cast<std::size_t>(nc[d]) + static_cast<std::size_t>(c);
    }
    cell_of[i] = static_cast<std::uint32_t>(idx);
    ++start[idx + 1];
  }
  for (std::size_t c = 0; c < ncell; ++c) start[c + 1] += start[c];
  SortedGrains g;
  g.resize(x.size());
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < x.size(); ++i) {
      const std::uint32_t k = fill[cell_of[i]]++;
      Vec3 p = x[i];
      for (int d = 0; d < dims; ++d)
        if (!walls[d]) comp(p, d) -= comp(L, d) * std::floor(comp(p, d) / comp(L, d));
      if (dims == 2) p.z = 0.0;
      g.x[k] = p.x, g.y[k] = p.y, g.z[k] = p.z;
      g.vx[k] = v[i].x, g.vy[k] = v[i].y, g.vz[k] = v[i].z;
    }
  }
  // Half shell: each unordered pair of cells once (offsets after (0, 0, 0) in z, y, x order),
  // pairs inside a cell once. With at least 2s + 1 cells per dimension the offsets reach
  // distinct cells, and for a pair closer than rmax (<= s cells apart) the image the offset
  // implies is the nearest one.
  struct Offset {
    int d[3];
  };
  std::vector<Offset> shell;
  const int zr = dims == 3 ? s : 0;
  for (int dz = -zr; dz <= zr; ++dz)
    for (int dy = -s; dy <= s; ++dy)
      for (int dx = -s; dx <= s; ++dx)
        if (dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx > 0)))) shell.push_back({{dx, dy, dz}});
  // The rows of cells (cy, cz) in a fixed number of chunks of consecutive rows, each with its
  // own histograms, summed in chunk order at the end: the threads ([run] threads) share the
  // chunks, and the sums do not depend on how many there are.
  // each chunk's histograms with four spare bins after each (pair_run_avx2)
  const std::size_t gb = gr_counts.size(), cb = corr_counts.size(), width = (gb + 4) + 3 * (cb + 4);
  // At most 64 chunks, and at most 2^20 histogram values (8 MB) in all: fine bins (gr_bin =
  // 1e-5 over 1.1 sigma, 110000 bins) had 64 copies, 56 MB zeroed and faulted in per snapshot,
  // 60 times the pair loop's time. Neither bound depends on the thread count.
  const std::size_t rows = static_cast<std::size_t>(nc[1]) * nc[2];
  const std::size_t chunks = std::min<std::size_t>({rows, 64, std::max<std::size_t>(1, (std::size_t{1} << 20) / width)});
  std::vector<double> part(chunks * width, 0.0);
  const PairBins bins{rmax, gr_bin, corr_bin};
  const bool avx2 = kernel == PairKernel::automatic && Philox4x32Lanes::have_avx2();
  std::uint32_t longest = 0;  // the most grains in one cell: the longest run of candidates
  for (std::size_t c = 0; c < ncell; ++c) longest = std::max(longest, start[c + 1] - start[c]);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::size_t k = 0; k < chunks; ++k) {
    double* base = &part[k * width];
    const std::size_t g1 = gb + 4, c1 = cb + 4;
    const PairHistograms h{base, base + g1, base + g1 + c1, base + g1 + 2 * c1, gb, cb};
    PackedPairs packed;
    if (avx2) packed.reserve(longest);
    auto run = [&](const Vec3& xi, const Vec3& vi, std::size_t j0, std::size_t j1) {
      if (avx2) pair_run_avx2(h, bins, g, xi, vi, j0, j1, packed);
      else pair_run_scalar(h, bins, g, xi, vi, j0, j1);
    };
    for (std::size_t row = rows * k / chunks; row < rows * (k + 1) / chunks; ++row) {
      const int cy = static_cast<int>(row % static_cast<std::size_t>(nc[1]));
      const int cz = static_cast<int>(row / static_cast<std::size_t>(nc[1]));
      for (int cx = 0; cx < nc[0]; ++cx) {
        const std::size_t a = (static_cast<std::size_t>(cz) * nc[1] + cy) * nc[0] + cx;
        const std::uint32_t a0 = start[a], a1 = start[a + 1];
        for (std::uint32_t i = a0; i < a1; ++i) run(g.position(i), g.velocity(i), i + 1, a1);
        for (const Offset& o : shell) {
          const int c[3] = {cx + o.d[0], cy + o.d[1], cz + o.d[2]};
          int w[3];
          Vec3 shift{0.0, 0.0, 0.0};
          bool skip = false;
          for (int d = 0; d < 3; ++d) {
            w[d] = c[d];
            if (c[d] >= 0 && c[d] < nc[d]) continue;
            if (walls[d]) {
              skip = true;
              break;
            }
            // periodic wrap: the neighbour cell's members are seen shifted by one box length
            w[d] = c[d] < 0 ? c[d] + nc[d] : c[d] - nc[d];
            comp(shift, d) = c[d] < 0 ? -comp(L, d) : comp(L, d);
          }
          if (skip) continue;
          const std::size_t b = (static_cast<std::size_t>(w[2]) * nc[1] + w[1]) * nc[0] + w[0];
          const std::uint32_t b0 = start[b], b1 = start[b + 1];
          for (std::uint32_t i = a0; i < a1; ++i)
            run(g.position(i) - shift, g.velocity(i), b0, b1);  // i seen from the neighbour's image
        }
      }
    }
  }
  for (std::size_t k = 0; k < chunks; ++k) {
    const double* base = &part[k * width];
    const std::size_t g1 = gb + 4, c1 = cb + 4;
    for (std::size_t q = 0; q < gb; ++q) gr_counts[q] += base[q];
    for (std::size_t q = 0; q < cb; ++q) {
      corr_par[q] += base[g1 + q];
      corr_perp[q] += base[g1 + c1 + q];
      corr_counts[q] += base[g1 + 2 * c1 + q];
    }
  }
}

std::vector<double> PairStatistics::gr_radii() const {
  std::vector<double> r(gr_counts.size());
  for (std::size_t b = 0; b < r.size(); ++b) r[b] = (b + 0.5) * gr_bin;
  return r;
}
std::vector<double> PairStatistics::corr_radii() const {
  std::vector<double> r(corr_counts.size());
  for (std::size_t b = 0; b < r.size(); ++b) r[b] = (b + 0.5) * corr_bin;
  return r;
}

std::vector<double> PairStatistics::gr() const {
  std::vector<double> g(gr_counts.size(), 0.0);
  if (snapshots == 0 || n < 2) return g;
  double volume = 1.0;
  for (int d = 0; d < dims; ++d) volume *= comp(L, d);
  for (std::size_t b = 0; b < g.size(); ++b) {
    // the last bin ends at rmax, beyond which no pair is counted (before 2026-12-06 its partial
    // shell was normalised as a whole one: g(r) low there by the missing fraction, 0.49 for
    // half a bin in an ideal gas)
    const double r0 = b * gr_bin, r1 = std::min(r0 + gr_bin, rmax);
    const double shell = dims == 2 ? std::numbers::pi * (r1 * r1 - r0 * r0)
                                   : 4.0 / 3.0 * std::numbers::pi * (r1 * r1 * r1 - r0 * r0 * r0);
    // pairs counted once: of the N(N-1)/2 distinct pairs, the fraction shell/V are ideally
    // in the shell (an ideal gas gives g = 1 at any N). This is also the normalisation of the
    // virial contact value pressure.g_contact, whose T = Sum|c|^2/(DN) is (N-1)/N of the
    // temperature the collisions see: 64 disks at nu = 0.5 give contact_fit / g_contact =
    // 0.9975 +- 0.0006 with N(N-1), and would give 0.982 with the N^2 used before (-1/N).
    const double ideal = 0.5 * n * (n - 1.0) / volume * shell * snapshots;
    g[b] = gr_counts[b] / ideal;
  }
  return g;
}

std::vector<double> PairStatistics::parallel() const {
  std::vector<double> c(corr_counts.size(), 0.0);
  const double t = snapshots ? temperature_sum / snapshots : 1.0;
  for (std::size_t b = 0; b < c.size(); ++b)
    c[b] = corr_counts[b] > 0 ? corr_par[b] / corr_counts[b] / t : 0.0;
  return c;
}

std::vector<double> PairStatistics::perpendicular() const {
  std::vector<double> c(corr_counts.size(), 0.0);
  const double t = snapshots ? temperature_sum / snapshots : 1.0;
  for (std::size_t b = 0; b < c.size(); ++b)
    c[b] = corr_counts[b] > 0 ? corr_perp[b] / corr_counts[b] / (t * (dims - 1)) : 0.0;
  return c;
}

double PairStatistics::contact_value(double width) const {
  // g(sigma+) from a quadratic least-squares fit in r over the bins near contact (sigma = 1):
  // g(r) = c0 + c1 s + c2 s^2, s = (r - 1)/width, for 1 <= r <= 1 + width. A straight line
  // through the bin centres undershot g(sigma+) because g(r) is convex there (2D, nu = 0.65:
  // -3 %, growing with density). What a bin holds is not g at its centre but the shell
  // average of g with the ideal-gas weight r^(D-1) (gr() divides counts by the ideal count):
  //   gbar_b = int_{a_b}^{r1} g(r) r^(D-1) dr / int_{r0}^{r1} r^(D-1) dr,   a_b = max(r0, 1)
  // (g = 0 inside the core, so a bin straddling sigma averages over its part above sigma).
  // For the quadratic this is exactly gbar_b = sum_k c_k M_kb with the moments
  //   M_kb = int_{a_b}^{r1} s^k r^(D-1) dr / int_{r0}^{r1} r^(D-1) dr,
  // so the fit is linear least squares in (c0, c1, c2) against the bin values, exact for a
  // quadratic g at any bin width (the centre value differs from the bin average at second
  // order, c2 (w/width)^2/12, plus the r^(D-1) weight's shift of the mean radius).
  // Bins: every bin reaching above sigma whose centre is at most 1 + width (the default
  // 0.02 sigma bins give the 5 bins of [1, 1.1]); fewer than 3 bins give NaN.
  const auto g = gr();
  const double h = width;
  // int_{x0}^{x1} x^k (1 + x)^(D-1) dx for x = r - 1 (D = 2: (1 + x); D = 3: (1 + x)^2)
  auto moment = [&](int k, double x0, double x1) {
    auto prim = [&](double x) {
      const double p1 = std::pow(x, k + 1) / (k + 1), p2 = std::pow(x, k + 2) / (k + 2);
      if (dims == 2) return p1 + p2;
      return p1 + 2.0 * p2 + std::pow(x, k + 3) / (k + 3);
    };
    return prim(x1) - prim(x0);
  };
  double A[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, y[3] = {0, 0, 0};
  int m = 0;
  for (std::size_t b = 0; b < g.size(); ++b) {
    const double r0 = b * gr_bin, r1 = r0 + gr_bin;
    if (r1 <= 1.0 || 0.5 * (r0 + r1) > 1.0 + width) continue;
    const double a = std::max(r0, 1.0);
    const double V = moment(0, r0 - 1.0, r1 - 1.0);  // the ideal shell, r^(D-1) weight
    double M[3];
    for (int k = 0; k < 3; ++k) M[k] = moment(k, a - 1.0, r1 - 1.0) / (V * std::pow(h, k));
    for (int i = 0; i < 3; ++i) {
      y[i] += M[i] * g[b];
      for (int j = 0; j < 3; ++j) A[i][j] += M[i] * M[j];
    }
    ++m;
  }
  if (m < 3) return std::nan("");
  // normal equations A c = y by Cramer's rule (3 x 3, s in [0, 1] keeps A well scaled)
  auto det3 = [](const double (&X)[3][3]) {
    return X[0][0] * (X[1][1] * X[2][2] - X[1][2] * X[2][1]) - X[0][1] * (X[1][0] * X[2][2] - X[1][2] * X[2][0]) +
           X[0][2] * (X[1][0] * X[2][1] - X[1][1] * X[2][0]);
  };
  const double det = det3(A);
  if (!(std::abs(det) > 0.0)) return std::nan("");
  double A0[3][3];
  for (int i = 0; i < 3; ++i) {
    A0[i][0] = y[i];
    A0[i][1] = A[i][1];
    A0[i][2] = A[i][2];
  }
  return det3(A0) / det;
}

void VelocityHistogram::init(double v_max, int nbins) {
  vmax = v_max;
  bins = nbins;
  for (auto& c : counts) c.assign(static_cast<std::size_t>(bins), 0.0);
}

void VelocityHistogram::add(const std::vector<Vec3>& v, double temperature, int dims) {
  const double s = 1.0 / std::sqrt(temperature);
  const double w = 2.0 * vmax / bins;
  for (const auto& u : v) {
    for (int d = 0; d < dims; ++d) {
      const double c = comp(u, d) * s;
      const int b = static_cast<int>(std::floor((c + vmax) / w));
      if (b >= 0 && b < bins) counts[d][b] += 1.0;
    }
    const double c2 = norm2(u) / temperature;
    c2_sum += c2;
    c4_sum += c2 * c2;
    samples += 1.0;
  }
  total += static_cast<double>(v.size());
}

std::vector<double> VelocityHistogram::density(int d) const {
  std::vector<double> p(counts[d].size(), 0.0);
  const double w = 2.0 * vmax / bins;
  for (std::size_t b = 0; b < p.size(); ++b) p[b] = total > 0 ? counts[d][b] / (total * w) : 0.0;
  return p;
}

std::vector<double> VelocityHistogram::centres() const {
  std::vector<double> c(static_cast<std::size_t>(bins));
  const double w = 2.0 * vmax / bins;
  for (int b = 0; b < bins; ++b) c[b] = -vmax + (b + 0.5) * w;
  return c;
}

}  // namespace grainbath::edmd
