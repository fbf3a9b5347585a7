#include "dsmc/decomposition.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include "dsmc/global_blocks.hpp"
#include "dsmc/spatial.hpp"

#ifdef GRAINBATH_MPI
#include <mpi.h>
#endif

namespace grainbath::dsmc {

std::size_t reduction_block_cells(const Config& c) {
  if (!c.spatial()) return 1;
  const double per_cell = static_cast<double>(c.particles) / static_cast<double>(c.domain.cell_count());
  std::size_t b = 1;
  while (b < 256 && static_cast<double>(2 * b) * per_cell <= 1024.0) b *= 2;
  return b;
}

bool medium_present(const Config& c) {
  return c.background.present() || c.field.profile == BackgroundProfile::file;
}

// ---------------------------------------------------------------- MPI environment
namespace mpi_env {
namespace {
bool g_active = false;
int g_rank = 0, g_size = 1;
}  // namespace

void init(int* argc, char*** argv) {
#ifdef GRAINBATH_MPI
  // only under a launcher: a plain run of the MPI build stays a plain process (and can fork
  // the variants of a sweep as the plain build does)
  const bool launched = std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMIX_RANK") || std::getenv("PMI_SIZE");
  if (!launched) return;
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
  g_active = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_size);
#else
  (void)argc;
  (void)argv;
#endif
}

void finalize() {
#ifdef GRAINBATH_MPI
  if (g_active) MPI_Finalize();
#endif
  g_active = false;
}

bool active() { return g_active; }
int world_rank() { return g_rank; }
int world_size() { return g_size; }

void abort(int code) {
#ifdef GRAINBATH_MPI
  if (g_active && g_size > 1) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::_Exit(code);
}

void barrier() {
#ifdef GRAINBATH_MPI
  if (g_active) MPI_Barrier(MPI_COMM_WORLD);
#endif
}

long long sum(long long x) {
#ifdef GRAINBATH_MPI
  if (g_active) {
    long long t = 0;
    MPI_Allreduce(&x, &t, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    return t;
  }
#endif
  return x;
}

int node_ranks() {
#ifdef GRAINBATH_MPI
  if (g_active) {
    MPI_Comm node;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    int n = 1;
    MPI_Comm_size(node, &n);
    MPI_Comm_free(&node);
    return n;
  }
#endif
  return 1;
}
}  // namespace mpi_env

namespace {
// A migrating grain travels as one record of doubles: id (its 64 bits), velocity, position
// (one per dimension) and, in runs with a medium, the carried bath residual (also outside
// MPI builds: the fused step packs its leavers with it, src/dsmc/fused.cpp).
struct MigrantRecord {
  int dims;
  bool hazard;
  std::size_t width;
  explicit MigrantRecord(const Config& c)
      : dims(c.domain.dimensions), hazard(medium_present(c)), width(4 + static_cast<std::size_t>(dims) + (hazard ? 1 : 0)) {}
  // the record's layout: the id's 64 bits, vx, vy, vz, the position (one per dimension),
  // the bath residual if a medium is present
  void pack(std::uint64_t id, const double (&v)[3], const double (&r)[3], double residual, std::vector<double>& o) const {
    double bits;
    std::memcpy(&bits, &id, sizeof bits);  // the 64-bit id travels bit for bit
    o.insert(o.end(), {bits, v[0], v[1], v[2], r[0]});
    if (dims > 1) o.push_back(r[1]);
    if (dims > 2) o.push_back(r[2]);
    if (hazard) o.push_back(residual);
  }
  void unpack(const double* rec, std::uint64_t& id, double (&v)[3], double (&r)[3], double& residual) const {
    std::memcpy(&id, &rec[0], sizeof id);
    v[0] = rec[1], v[1] = rec[2], v[2] = rec[3];
    r[0] = rec[4];
    r[1] = dims > 1 ? rec[5] : 0.0;
    r[2] = dims > 2 ? rec[6] : 0.0;
    residual = hazard ? rec[4 + dims] : 0.0;
  }
  void pack(const Particles& p, std::size_t i, std::vector<double>& o) const {
    pack(p.id[i], {p.vx[i], p.vy[i], p.vz[i]}, {p.x[i], dims > 1 ? p.y[i] : 0.0, dims > 2 ? p.z[i] : 0.0},
         hazard ? p.bath_hazard[i] : 0.0, o);
  }
  std::uint32_t cell(const CellGrid& grid, const double* r) const {
    return grid(r[4], dims > 1 ? r[5] : 0.0, dims > 2 ? r[6] : 0.0);
  }
  // append the records in `in` to the particles, and their cells to `cells`
  void append(const std::vector<double>& in, const CellGrid& grid, Particles& p, std::vector<std::uint32_t>& cells) const {
    const std::size_t n = p.size(), arrived = in.size() / width;
    // not zero-filled (core/no_fill_vector.hpp): the loop below writes every arrival's entries
    p.resize(n + arrived, false);
    p.x.resize(n + arrived);
    if (dims > 1) p.y.resize(n + arrived);
    if (dims > 2) p.z.resize(n + arrived);
    if (hazard) p.bath_hazard.resize(n + arrived);
    cells.resize(n + arrived);
    for (std::size_t j = 0; j < arrived; ++j) {
      const double* rec = in.data() + j * width;
      const std::size_t i = n + j;
      double v[3], r[3], residual;
      unpack(rec, p.id[i], v, r, residual);
      p.vx[i] = v[0], p.vy[i] = v[1], p.vz[i] = v[2];
      p.x[i] = r[0];
      if (dims > 1) p.y[i] = r[1];
      if (dims > 2) p.z[i] = r[2];
      if (hazard) p.bath_hazard[i] = residual;
      cells[i] = cell(grid, rec);
    }
  }
};
}  // namespace

// ---------------------------------------------------------------- decomposition
#ifdef GRAINBATH_MPI
namespace {
// Counts and displacements for the v-collectives (in elements).
std::vector<int> displacements(const std::vector<int>& counts) {
  std::vector<int> d(counts.size(), 0);
  for (std::size_t r = 1; r < counts.size(); ++r) d[r] = d[r - 1] + counts[r - 1];
  return d;
}
int to_int(std::size_t n, const char* what) {
  if (n > static_cast<std::size_t>(INT32_MAX))
    throw std::runtime_error(std::string("MPI: ") + what + " exceeds 2^31 - 1 elements in one message");
  return static_cast<int>(n);
}
// Personalised all-to-all of doubles: out[r] goes to rank r; returns what arrived, in rank order.
std::vector<double> exchange_doubles(const std::vector<std::vector<double>>& out, int size) {
  std::vector<int> send_counts(size), recv_counts(size);
  std::size_t total = 0;
  for (int r = 0; r < size; ++r) {
    send_counts[r] = to_int(out[r].size(), "a particle exchange");
    total += out[r].size();
  }
  MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  std::vector<double> send;
  send.reserve(total);
  for (const auto& o : out) send.insert(send.end(), o.begin(), o.end());
  const std::vector<int> sd = displacements(send_counts), rd = displacements(recv_counts);
  std::size_t received = 0;
  for (int c : recv_counts) received += static_cast<std::size_t>(c);
  std::vector<double> recv(received);
  MPI_Alltoallv(send.data(), send_counts.data(), sd.data(), MPI_DOUBLE, recv.data(), recv_counts.data(), rd.data(),
                MPI_DOUBLE, MPI_COMM_WORLD);
  return recv;
}

// One round of the ring: send `to_left` / `to_right` to the neighbours and receive what they
// sent this way (any length: the receiver probes the size, so no separate count message).
// With two ranks both neighbours are the same rank; the tags keep the two messages apart.
constexpr int kTagRightward = 7001, kTagLeftward = 7002;
void exchange_with_neighbours(const std::vector<double>& to_left, const std::vector<double>& to_right, int left,
                              int right, std::vector<double>& from_left, std::vector<double>& from_right) {
  MPI_Request sent[2];
  MPI_Isend(to_right.data(), to_int(to_right.size(), "a migration message"), MPI_DOUBLE, right, kTagRightward,
            MPI_COMM_WORLD, &sent[0]);
  MPI_Isend(to_left.data(), to_int(to_left.size(), "a migration message"), MPI_DOUBLE, left, kTagLeftward,
            MPI_COMM_WORLD, &sent[1]);
  auto receive = [](int from, int tag, std::vector<double>& in) {
    MPI_Status status;
    MPI_Probe(from, tag, MPI_COMM_WORLD, &status);
    int count = 0;
    MPI_Get_count(&status, MPI_DOUBLE, &count);
    in.resize(static_cast<std::size_t>(count));
    MPI_Recv(in.data(), count, MPI_DOUBLE, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  };
  receive(left, kTagRightward, from_left);
  receive(right, kTagLeftward, from_right);
  MPI_Waitall(2, sent, MPI_STATUSES_IGNORE);
}
}  // namespace
#endif

Decomposition::Decomposition(const Config& c, bool use_world) {
  world_ = use_world && mpi_env::active() && mpi_env::world_size() > 1;
  if (world_) {
    rank_ = mpi_env::world_rank();
    size_ = mpi_env::world_size();
  }
  cells_ = c.spatial() ? c.domain.cell_count() : 1;
  block_cells_ = reduction_block_cells(c);
  blocks_ = (cells_ + block_cells_ - 1) / block_cells_;
  first_block_.assign(size_ + 1, blocks_);
  first_block_[0] = 0;  // until distribute(): everything on rank 0
  spatial_ = c.spatial();
  if (size_ > 1) work_.assign(blocks_, 0);
}

std::size_t Decomposition::first_cell(int r) const { return std::min(cells_, first_block_[r] * block_cells_); }
std::size_t Decomposition::end_cell(int r) const { return std::min(cells_, first_block_[r + 1] * block_cells_); }

int Decomposition::owner_of_block(std::size_t b) const {
  // first_block_ is non-decreasing; the owner is the last rank whose range starts at or before b
  const auto it = std::upper_bound(first_block_.begin(), first_block_.end() - 1, b);
  return static_cast<int>(it - first_block_.begin()) - 1;
}

void Decomposition::block_bounds(const State& s, const Config& c, std::vector<std::size_t>& bounds) const {
  bounds.clear();
  if (!c.spatial()) {
    constexpr std::size_t kBlock = 4096;
    const std::size_t n = s.particles.size();
    for (std::size_t lo = 0; lo < n; lo += kBlock) bounds.push_back(lo);
    bounds.push_back(n);
    return;
  }
  for (std::size_t b = first_block(); b < end_block(); ++b) bounds.push_back(s.cell_start[b * block_cells_]);
  bounds.push_back(s.cell_start[std::min(cells_, end_block() * block_cells_)]);
}

std::vector<unsigned char> Decomposition::allgather_bytes(const std::vector<unsigned char>& mine,
                                                         std::size_t bytes_per_block) const {
#ifdef GRAINBATH_MPI
  std::vector<int> counts(size_);
  const int n = to_int(mine.size(), "a gathered block list");
  if (bytes_per_block > 0) {  // one entry per block: every rank's size is known
    for (int r = 0; r < size_; ++r)
      counts[r] = to_int((first_block_[r + 1] - first_block_[r]) * bytes_per_block, "a gathered block list");
    if (counts[rank_] != n) throw std::logic_error("combine_in_order: not one partial per reduction block");
  } else {
    MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  }
  const std::vector<int> d = displacements(counts);
  std::vector<unsigned char> all(static_cast<std::size_t>(d.back()) + counts.back());
  MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), d.data(), MPI_BYTE, MPI_COMM_WORLD);
  return all;
#else
  (void)bytes_per_block;
  return mine;
#endif
}

int Decomposition::any_bits(int bits) const {
#ifdef GRAINBATH_MPI
  if (size_ > 1) {
    int out = 0;
    MPI_Allreduce(&bits, &out, 1, MPI_INT, MPI_BOR, MPI_COMM_WORLD);
    return out;
  }
#endif
  return bits;
}

double Decomposition::sum(double x) const {
  std::vector<double> v{x};
  combine_in_order(v);
  double t = 0.0;
  for (double y : v) t += y;
  return t;
}

long long Decomposition::max(long long x) const {
#ifdef GRAINBATH_MPI
  if (size_ > 1) {
    long long out = 0;
    MPI_Allreduce(&x, &out, 1, MPI_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
    return out;
  }
#endif
  return x;
}

void Decomposition::share(std::size_t count, std::size_t granule, std::size_t& lo, std::size_t& hi) const {
  const std::size_t units = (count + granule - 1) / granule, r = static_cast<std::size_t>(rank_),
                    n = static_cast<std::size_t>(size_);
  lo = std::min(count, units * r / n * granule);
  hi = std::min(count, units * (r + 1) / n * granule);
}

// The ranks form a ring in cell order (rank r's cells precede rank r + 1's; the last rank's
// neighbour on the right is rank 0). A grain goes the shorter way round (ties: rightwards),
// so it never needs more than size/2 hops.
int Decomposition::ring_offset(int to) const {
  const int right = (to - rank_ + size_) % size_;
  return right <= size_ - right ? right : right - size_;
}

Moments Decomposition::moments(const Particles& p, const std::vector<std::size_t>& bounds, double mass,
                               bool per_block) const {
  std::vector<RawMomentSums> raw;
  raw_moment_sums(p, bounds, raw);
  combine_in_order(raw, per_block);
  Moments m = moments_from_raw(raw, mass);
  std::vector<CentralMomentSums> central;
  central_moment_sums(p, bounds, m.mean_velocity, central);
  combine_in_order(central, per_block);
  finish_moments(central, mass, m);
  return m;
}

// Boundaries that split the block weights into `size_` nearly equal contiguous parts:
// rank r starts at the first block where the running weight reaches r/size of the total.
std::vector<std::size_t> balanced_block_boundaries(const std::vector<std::uint64_t>& w, int ranks) {
  const std::size_t blocks = w.size();
  std::vector<std::size_t> first(static_cast<std::size_t>(ranks) + 1, blocks);
  first[0] = 0;
  std::uint64_t total = 0;
  for (auto x : w) total += x;
  const auto n = static_cast<std::uint64_t>(ranks);
  std::uint64_t run = 0;  // weight of the blocks before b
  int r = 1;
  // b runs to blocks inclusive: a target inside the last block still gets its cut (before
  // that block, or at the end); with b < blocks only, 2 blocks of unequal weight all went to
  // rank 0 whenever the first was the lighter (found 2026-11-27 by the idle-rank note)
  for (std::size_t b = 0; b <= blocks; ++b) {
    while (r < ranks && run * n >= static_cast<std::uint64_t>(r) * total) {
      // cut before b, or before b - 1 if that is nearer the target r * total / ranks
      const std::uint64_t target = static_cast<std::uint64_t>(r) * total, before = (run - (b > 0 ? w[b - 1] : 0)) * n;
      const bool earlier = b > first[r - 1] && target - before < run * n - target;
      first[r] = earlier ? b - 1 : b;
      ++r;
    }
    if (b < blocks) run += w[b];
  }
  return first;
}

std::vector<std::size_t> Decomposition::balanced_boundaries(const std::vector<std::uint64_t>& w) {
  std::vector<std::size_t> first = balanced_block_boundaries(w, size_);
  std::uint64_t total = 0, worst = 0;
  for (auto x : w) total += x;
  for (int q = 0; q < size_; ++q) {
    std::uint64_t part = 0;
    for (std::size_t b = first[q]; b < first[q + 1]; ++b) part += w[b];
    worst = std::max(worst, part);
  }
  imbalance_ = total > 0 ? static_cast<double>(worst) * size_ / static_cast<double>(total) : 1.0;
  return first;
}

// The cell of every local particle into s.sort.cell (kRemoved for those that left through
// an open face), marked fresh so that sort_by_cell does not recompute it.
void Decomposition::cells_of_all(State& s, const Config& c, const std::vector<std::uint8_t>* removed) const {
  Particles& p = s.particles;
  const std::size_t n = p.size();
  SortScratch& w = s.sort;
  if (w.cell_fresh && w.cell.size() == n) return;
  w.cell.resize(n);
  const Domain& d = c.domain;
  const CellGrid grid(d);
  const bool any_removed = removed && removed->size() == n;
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i)
    w.cell[i] = (any_removed && (*removed)[i])
                    ? kRemoved
                    : grid(p.x[i], d.dimensions > 1 ? p.y[i] : 0.0, d.dimensions > 2 ? p.z[i] : 0.0);
  w.cell_fresh = true;
}

void Decomposition::plan_restart(const std::vector<std::uint64_t>& grains_per_block, std::uint64_t& first,
                                 std::uint64_t& end) {
  if (grains_per_block.size() != blocks_) throw std::logic_error("plan_restart: not one count per reduction block");
  std::vector<std::uint64_t> w = grains_per_block;
  for (auto& x : w) ++x;  // +1: empty regions are still spread out (as distribute)
  first_block_ = balanced_boundaries(w);
  first = end = 0;
  for (std::size_t b = 0; b < end_block(); ++b) (b < first_block() ? first : end) += grains_per_block[b];
  end += first;
}

void Decomposition::distribute(State& s, const Config& c, bool read_own) {
  Particles& p = s.particles;
  note_particles(p.size());
  if (size_ == 1) return;
  if (!c.spatial()) {  // one cell: rank 0 holds every grain, the others idle
    first_block_.assign(size_ + 1, blocks_);
    first_block_[0] = 0;
    if (!root()) p.resize(0, false);
    return;
  }
  cells_of_all(s, c, nullptr);
  if (read_own) {  // the boundaries were chosen by plan_restart; every grain is this rank's
    balanced_at_step_ = s.step;
    return;
  }
  std::vector<std::uint64_t> w(blocks_, 0);
  for (std::uint32_t k : s.sort.cell)
    if (k != kRemoved) ++w[k / block_cells_];
#ifdef GRAINBATH_MPI
  // particles per block over all ranks (integers: the sum is exact in any order)
  MPI_Allreduce(MPI_IN_PLACE, w.data(), to_int(blocks_, "the reduction blocks"), MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
#endif
  for (auto& x : w) ++x;  // +1: empty regions are still spread out
  first_block_ = balanced_boundaries(w);
  balanced_at_step_ = s.step;
  send_to_owners(s, c);
  note_particles(p.size());
}

void Decomposition::send_to_owners(State& s, const Config& c) {
#ifdef GRAINBATH_MPI
  Particles& p = s.particles;
  const MigrantRecord rec(c);
  std::vector<std::vector<double>> out(size_);
  std::vector<std::uint32_t>& cell = s.sort.cell;
  const std::uint32_t lo = static_cast<std::uint32_t>(first_cell(rank_)), hi = static_cast<std::uint32_t>(end_cell(rank_));
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t k = cell[i];
    if (k == kRemoved || (k >= lo && k < hi)) continue;
    rec.pack(p, i, out[owner_of_block(k / block_cells_)]);
    cell[i] = kRemoved;  // dropped here by the next sort
  }
  rec.append(exchange_doubles(out, size_), CellGrid(c.domain), p, cell);
#else
  (void)s;
  (void)c;
#endif
}

std::size_t Decomposition::migrant_width(const Config& c) { return MigrantRecord(c).width; }
void Decomposition::pack_migrant(const Config& c, std::uint64_t id, const double (&v)[3], const double (&r)[3],
                                 double residual, std::vector<double>& out) {
  MigrantRecord(c).pack(id, v, r, residual, out);
}
void Decomposition::unpack_migrant(const Config& c, const double* record, std::uint64_t& id, double (&v)[3],
                                   double (&r)[3], double& residual) {
  MigrantRecord(c).unpack(record, id, v, r, residual);
}

void Decomposition::migrate(State& s, const Config& c, std::vector<std::uint8_t>& removed) {
  if (size_ == 1) return;
  cells_of_all(s, c, &removed);
#ifdef GRAINBATH_MPI
  Particles& p = s.particles;
  const MigrantRecord rec(c);
  std::vector<std::uint32_t>& cell = s.sort.cell;
  const std::uint32_t lo = static_cast<std::uint32_t>(first_cell(rank_)), hi = static_cast<std::uint32_t>(end_cell(rank_));
  std::vector<double> leaving;
  const std::size_t n = p.size();
  std::size_t gone = 0;  // removed through an open face, or sent away
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t k = cell[i];
    if (k >= lo && k < hi) continue;
    ++gone;
    if (k == kRemoved) continue;
    rec.pack(p, i, leaving);
    cell[i] = kRemoved;  // dropped here by the next sort
  }
  const std::vector<double> kept = migrate_records(c, leaving, n - gone);
  rec.append(kept, CellGrid(c.domain), p, cell);
  note_particles(p.size());
#else
  (void)s;
#endif
}

std::vector<double> Decomposition::migrate_records(const Config& c, const std::vector<double>& leaving,
                                                   std::size_t staying) {
  std::vector<double> kept;
  if (size_ == 1) return kept;
#ifdef GRAINBATH_MPI
  const MigrantRecord rec(c);
  const CellGrid grid(c.domain);
  std::vector<double> to_left, to_right, from_left, from_right;
  int hops = 0;  // the most ranks any of this rank's migrants has to cross
  for (std::size_t j = 0; j < leaving.size(); j += rec.width) {
    const double* r = leaving.data() + j;
    const int d = ring_offset(owner_of_block(rec.cell(grid, r) / block_cells_));
    std::vector<double>& to = d > 0 ? to_right : to_left;
    to.insert(to.end(), r, r + rec.width);
    hops = std::max(hops, std::abs(d));
    ++stats_.migrants;
  }
  // How many rounds: with 2 or 3 ranks every other rank is a neighbour, so one round always
  // suffices and no collective is needed. With more, the ranks agree on the largest hop
  // count (an all-reduce of one int, overlapped with the first round); a grain that crosses
  // several ranks' cells in one step (large dt, thin slabs, a reflection or a periodic wrap
  // inside a rank's range) is forwarded by the ranks it passes, one hop per round.
  int rounds = hops;
  MPI_Request agreed = MPI_REQUEST_NULL;
  if (size_ > 3) {
    MPI_Iallreduce(&hops, &rounds, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD, &agreed);
    ++stats_.collectives;
  }
  const int left = (rank_ + size_ - 1) % size_, right = (rank_ + 1) % size_;
  for (int round = 1;; ++round) {
    exchange_with_neighbours(to_left, to_right, left, right, from_left, from_right);
    ++stats_.rounds;
    stats_.messages += 2;
    stats_.bytes += static_cast<long long>((to_left.size() + to_right.size()) * sizeof(double));
    to_left.clear();
    to_right.clear();
    for (const std::vector<double>* in : {&from_left, &from_right})
      for (std::size_t j = 0; j < in->size(); j += rec.width) {
        const double* r = in->data() + j;
        const int owner = owner_of_block(rec.cell(grid, r) / block_cells_);
        std::vector<double>& to = owner == rank_ ? kept : ring_offset(owner) > 0 ? to_right : to_left;
        to.insert(to.end(), r, r + rec.width);
      }
    if (round == 1 && agreed != MPI_REQUEST_NULL) MPI_Wait(&agreed, MPI_STATUS_IGNORE);
    if (round >= rounds) break;
  }
  if (!to_left.empty() || !to_right.empty())
    throw std::logic_error("migrate: a grain did not reach the rank that owns its cell");
  stats_.max_hops = std::max(stats_.max_hops, rounds);
  ++stats_.steps;
  const bool empty = staying + kept.size() / rec.width == 0;
  if (empty) ++stats_.empty_steps;
  if (!empty && stats_.empty_after_last_step) ++stats_.refills;
  stats_.empty_after_last_step = empty;
#else
  (void)c;
  (void)leaving;
  (void)staying;
#endif
  return kept;
}

// Per-cell data that lives with the cell's owner: the NTC remainder and the field sums.
// Cells are sent from their old owner to their new one, in ascending cell order.
void Decomposition::move_cell_data(State& s, const std::vector<std::size_t>& old_first) {
#ifdef GRAINBATH_MPI
  FieldAccumulator& f = s.fields;
  auto old_cell = [&](int r, bool end) { return std::min(cells_, old_first[r + (end ? 1 : 0)] * block_cells_); };
  std::vector<std::vector<double>> out(size_);
  const std::size_t my_lo = old_cell(rank_, false), my_hi = old_cell(rank_, true);
  for (int r = 0; r < size_; ++r) {
    if (r == rank_) continue;
    const std::size_t lo = std::max(my_lo, first_cell(r)), hi = std::min(my_hi, end_cell(r));
    for (std::size_t k = lo; k < hi; ++k) {
      out[r].push_back(s.remainder[k]);
      for (int b = 0; f.cells > 0 && b < f.batches; ++b) {
        const double* a = f.sums.data() + (static_cast<std::size_t>(b) * f.cells + k) * FieldAccumulator::kSums;
        out[r].insert(out[r].end(), a, a + FieldAccumulator::kSums);
      }
    }
  }
  const std::vector<double> in = exchange_doubles(out, size_);
  std::size_t at = 0;
  for (int r = 0; r < size_; ++r) {  // arrivals are in rank order, each in ascending cells
    if (r == rank_) continue;
    const std::size_t lo = std::max(old_cell(r, false), first_cell(rank_)), hi = std::min(old_cell(r, true), end_cell(rank_));
    for (std::size_t k = lo; k < hi; ++k) {
      s.remainder[k] = in[at++];
      for (int b = 0; f.cells > 0 && b < f.batches; ++b) {
        double* a = f.sums.data() + (static_cast<std::size_t>(b) * f.cells + k) * FieldAccumulator::kSums;
        std::copy(in.begin() + at, in.begin() + at + FieldAccumulator::kSums, a);
        at += FieldAccumulator::kSums;
      }
    }
  }
  if (at != in.size()) throw std::logic_error("move_cell_data: message size mismatch");
#else
  (void)s;
  (void)old_first;
#endif
}

bool Decomposition::rebalance(State& s, const Config& c) {
  if (size_ == 1 || !c.spatial()) return false;
  std::vector<std::uint64_t> w;
  for (std::size_t b = first_block(); b < end_block(); ++b) {
    const std::size_t lo = b * block_cells_, hi = std::min(cells_, lo + block_cells_);
    w.push_back(1 + s.cell_start[hi] - s.cell_start[lo]);
  }
  combine_in_order(w, true);  // all blocks in global order
  const auto steps = static_cast<std::uint64_t>(std::max<std::int64_t>(1, s.step - balanced_at_step_));
  for (std::size_t b = 0; b < blocks_; ++b) w[b] += work_[b] / steps;
  std::fill(work_.begin(), work_.end(), 0);
  balanced_at_step_ = s.step;
  const std::vector<std::size_t> next = balanced_boundaries(w);
  if (next == first_block_) return false;
  const std::vector<std::size_t> old = first_block_;
  first_block_ = next;
  move_cell_data(s, old);
  s.sort.cell_fresh = false;
  cells_of_all(s, c, nullptr);
  send_to_owners(s, c);
  note_particles(s.particles.size());
  ++rebalances_;
  return true;
}

State Decomposition::gather_cells(const State& s) const {
  State g;
  if (root()) {  // the values every rank shares, and one process's per-cell data
    g.step = s.step;
    g.bath_half_pending = s.bath_half_pending;
    g.counters = s.counters;
    g.series = s.series;
    g.fields = s.fields;
    g.remainder = s.remainder;
    g.initial_kinetic_energy = s.initial_kinetic_energy;
    g.particle_steps_run = s.particle_steps_run;
    g.collisions_before_run = s.collisions_before_run;
    // rough grains (homogeneous runs only: rank 0 holds every grain and its spin)
    g.wx = s.wx;
    g.wy = s.wy;
    g.wz = s.wz;
  }
  if (size_ == 1) return g;
#ifdef GRAINBATH_MPI
  const int root_rank = 0;
  // per-cell data: each rank's own cell range, in rank order = cell order
  std::vector<int> cc(size_), cd(size_);
  for (int r = 0; r < size_; ++r) {
    cc[r] = to_int(end_cell(r) - first_cell(r), "the cells of one rank");
    cd[r] = to_int(first_cell(r), "the cell grid");
  }
  const std::size_t lo = first_cell(rank_);
  MPI_Gatherv(s.remainder.data() + lo, cc[rank_], MPI_DOUBLE, g.remainder.data(), cc.data(), cd.data(), MPI_DOUBLE,
              root_rank, MPI_COMM_WORLD);
  const FieldAccumulator& f = s.fields;  // rank 0's copy: its own sums, the others' overwritten here
  if (f.cells > 0) {
    constexpr int K = FieldAccumulator::kSums;
    std::vector<int> fc(size_), fd(size_);
    for (int r = 0; r < size_; ++r) {
      fc[r] = to_int(static_cast<std::size_t>(cc[r]) * K, "the field sums of one rank");
      fd[r] = to_int(static_cast<std::size_t>(cd[r]) * K, "the field sums");
    }
    for (int b = 0; b < f.batches; ++b) {
      const std::size_t base = static_cast<std::size_t>(b) * f.cells * K;
      MPI_Gatherv(f.sums.data() + base + lo * K, fc[rank_], MPI_DOUBLE,
                  root() ? g.fields.sums.data() + base : nullptr, fc.data(), fd.data(), MPI_DOUBLE, root_rank,
                  MPI_COMM_WORLD);
    }
  }
  const double steps_run = sum(s.particle_steps_run);
  if (root()) g.particle_steps_run = steps_run;
#endif
  return g;
}

std::vector<unsigned char> Decomposition::in_rank_order(
    std::vector<unsigned char> token, const std::function<void(std::vector<unsigned char>&)>& turn) const {
#ifdef GRAINBATH_MPI
  if (size_ > 1) {
    constexpr int kTagTurn = 7003;
    const int n = to_int(token.size(), "a token");
    if (!root()) MPI_Recv(token.data(), n, MPI_BYTE, rank_ - 1, kTagTurn, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    turn(token);
    MPI_Send(token.data(), n, MPI_BYTE, (rank_ + 1) % size_, kTagTurn, MPI_COMM_WORLD);
    if (root()) MPI_Recv(token.data(), n, MPI_BYTE, size_ - 1, kTagTurn, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    return token;
  }
#endif
  turn(token);
  return token;
}

void Decomposition::offsets(const std::vector<std::uint64_t>& local, std::vector<std::uint64_t>& offset,
                            std::vector<std::uint64_t>& total) const {
  offset.assign(local.size(), 0);
  total = local;
#ifdef GRAINBATH_MPI
  if (size_ > 1 && !local.empty()) {
    const int n = to_int(local.size(), "the offsets");
    MPI_Exscan(local.data(), offset.data(), n, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    if (root()) std::fill(offset.begin(), offset.end(), 0);  // MPI_Exscan leaves rank 0's undefined
    MPI_Allreduce(local.data(), total.data(), n, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  }
#endif
}

std::string Decomposition::first_error(const std::string& mine) const {
#ifdef GRAINBATH_MPI
  if (size_ > 1) {
    const int candidate = mine.empty() ? size_ : rank_;
    int failed = size_;
    MPI_Allreduce(&candidate, &failed, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (failed == size_) return {};
    std::string text = "rank " + std::to_string(failed) + ": " + mine;
    int length = static_cast<int>(text.size());
    MPI_Bcast(&length, 1, MPI_INT, failed, MPI_COMM_WORLD);
    text.resize(static_cast<std::size_t>(length));
    MPI_Bcast(text.data(), length, MPI_CHAR, failed, MPI_COMM_WORLD);
    return text;
  }
#endif
  return mine;
}

void Decomposition::sum_counts(std::vector<double>& counts) const {
#ifdef GRAINBATH_MPI
  if (size_ > 1 && !counts.empty())
    MPI_Allreduce(MPI_IN_PLACE, counts.data(), to_int(counts.size(), "the counts"), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
#else
  (void)counts;
#endif
}

std::uint64_t Decomposition::sum_wrapping(std::uint64_t x) const {
#ifdef GRAINBATH_MPI
  if (size_ > 1) {
    std::uint64_t out = 0;
    MPI_Allreduce(&x, &out, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    return out;
  }
#endif
  return x;
}

namespace {
// Sums of the global blocks (src/dsmc/global_blocks.hpp): the local part, then the turns in
// rank order with the carry passed from rank to rank.
template <class Sums, class Blocks, class Range>
std::vector<Sums> sums_in_global_blocks(const Decomposition& dec, std::size_t n, std::uint64_t offset,
                                        const Blocks& blocks, const Range& range) {
  const RankInGlobalBlocks<Sums> part = split_into_global_blocks<Sums>(n, offset, blocks, range);
  std::vector<Sums> done;
  dec.in_rank_order<GlobalBlockCarry<Sums>>(GlobalBlockCarry<Sums>{}, [&](GlobalBlockCarry<Sums>& carry) {
    continue_global_blocks(part, dec.rank() == dec.size() - 1, range, carry, done);
  });
  return done;
}
}  // namespace

Moments Decomposition::moments_in_global_blocks(const Particles& p, double mass) const {
  std::vector<std::uint64_t> offset, total;
  offsets({p.size()}, offset, total);
  std::vector<RawMomentSums> raw = sums_in_global_blocks<RawMomentSums>(
      *this, p.size(), offset[0],
      [&](const std::vector<std::size_t>& bounds, std::vector<RawMomentSums>& out) { raw_moment_sums(p, bounds, out); },
      [&](std::size_t lo, std::size_t hi, RawMomentSums& s) { add_raw_moment_sums(p, lo, hi, s); });
  combine_in_order(raw);
  Moments m = moments_from_raw(raw, mass);
  const Vec3 u = m.mean_velocity;
  std::vector<CentralMomentSums> central = sums_in_global_blocks<CentralMomentSums>(
      *this, p.size(), offset[0],
      [&](const std::vector<std::size_t>& bounds, std::vector<CentralMomentSums>& out) {
        central_moment_sums(p, bounds, u, out);
      },
      [&](std::size_t lo, std::size_t hi, CentralMomentSums& s) { add_central_moment_sums(p, lo, hi, u, s); });
  combine_in_order(central);
  finish_moments(central, mass, m);
  return m;
}

}  // namespace grainbath::dsmc
