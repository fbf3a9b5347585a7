#include "dsmc/decomposition.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

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
}  // namespace mpi_env

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

// Boundaries that split the block weights into `size_` nearly equal contiguous parts:
// rank r starts at the first block where the running weight reaches r/size of the total.
std::vector<std::size_t> Decomposition::balanced_boundaries(const std::vector<std::uint64_t>& w) {
  std::vector<std::size_t> first(size_ + 1, blocks_);
  first[0] = 0;
  std::uint64_t total = 0;
  for (auto x : w) total += x;
  const auto n = static_cast<std::uint64_t>(size_);
  std::uint64_t run = 0;  // weight of the blocks before b
  int r = 1;
  for (std::size_t b = 0; b < blocks_; ++b) {
    while (r < size_ && run * n >= static_cast<std::uint64_t>(r) * total) {
      // cut before b, or before b - 1 if that is nearer the target r * total / size
      const std::uint64_t target = static_cast<std::uint64_t>(r) * total, before = (run - (b > 0 ? w[b - 1] : 0)) * n;
      const bool earlier = b > first[r - 1] && target - before < run * n - target;
      first[r] = earlier ? b - 1 : b;
      ++r;
    }
    run += w[b];
  }
  std::uint64_t worst = 0;
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

void Decomposition::distribute(State& s, const Config& c) {
  if (size_ == 1) return;
  Particles& p = s.particles;
  if (!c.spatial()) {  // one cell: rank 0 holds every grain, the others idle
    first_block_.assign(size_ + 1, blocks_);
    first_block_[0] = 0;
    if (!root()) p.resize(0, false);
    return;
  }
  cells_of_all(s, c, nullptr);
  // every rank holds the whole population here, so the weights are known everywhere
  std::vector<std::uint64_t> w(blocks_, 1);  // +1: empty regions are still spread out
  for (std::uint32_t k : s.sort.cell)
    if (k != kRemoved) ++w[k / block_cells_];
  first_block_ = balanced_boundaries(w);
  balanced_at_step_ = s.step;
  const std::uint32_t lo = static_cast<std::uint32_t>(first_cell(rank_)), hi = static_cast<std::uint32_t>(end_cell(rank_));
  for (auto& k : s.sort.cell)
    if (k < lo || k >= hi) k = kRemoved;
}

void Decomposition::send_to_owners(State& s, const Config& c) {
#ifdef GRAINBATH_MPI
  Particles& p = s.particles;
  const int dims = c.domain.dimensions;
  const bool hazard = !p.bath_hazard.empty();  // runs with a medium carry the bath residual
  const std::size_t width = 4 + static_cast<std::size_t>(dims) + (hazard ? 1 : 0);  // id, v (3), position (dims), residual
  std::vector<std::vector<double>> out(size_);
  std::vector<std::uint32_t>& cell = s.sort.cell;
  const std::uint32_t lo = static_cast<std::uint32_t>(first_cell(rank_)), hi = static_cast<std::uint32_t>(end_cell(rank_));
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t k = cell[i];
    if (k == kRemoved || (k >= lo && k < hi)) continue;
    auto& o = out[owner_of_block(k / block_cells_)];
    double id;
    std::memcpy(&id, &p.id[i], sizeof id);  // the 64-bit id travels bit for bit
    o.insert(o.end(), {id, p.vx[i], p.vy[i], p.vz[i], p.x[i]});
    if (dims > 1) o.push_back(p.y[i]);
    if (dims > 2) o.push_back(p.z[i]);
    if (hazard) o.push_back(p.bath_hazard[i]);
    cell[i] = kRemoved;  // dropped here by the next sort
  }
  const std::vector<double> in = exchange_doubles(out, size_);
  const std::size_t arrived = in.size() / width;
  p.resize(n + arrived, false);
  p.x.resize(n + arrived);
  if (dims > 1) p.y.resize(n + arrived);
  if (dims > 2) p.z.resize(n + arrived);
  if (hazard) p.bath_hazard.resize(n + arrived);
  cell.resize(n + arrived);
  const CellGrid grid(c.domain);
  for (std::size_t j = 0; j < arrived; ++j) {
    const double* r = in.data() + j * width;
    const std::size_t i = n + j;
    std::memcpy(&p.id[i], &r[0], sizeof(std::uint64_t));
    p.vx[i] = r[1];
    p.vy[i] = r[2];
    p.vz[i] = r[3];
    p.x[i] = r[4];
    if (dims > 1) p.y[i] = r[5];
    if (dims > 2) p.z[i] = r[6];
    if (hazard) p.bath_hazard[i] = r[4 + dims];
    cell[i] = grid(p.x[i], dims > 1 ? p.y[i] : 0.0, dims > 2 ? p.z[i] : 0.0);
  }
#else
  (void)s;
  (void)c;
#endif
}

void Decomposition::migrate(State& s, const Config& c, std::vector<std::uint8_t>& removed) {
  if (size_ == 1) return;
  cells_of_all(s, c, &removed);
  send_to_owners(s, c);
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
  ++rebalances_;
  return true;
}

void Decomposition::allgather_particles(const Particles& local, bool with_x, Particles& all) const {
#ifdef GRAINBATH_MPI
  std::vector<int> counts(size_);
  const int n = to_int(local.size(), "the particles of one rank");
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  const std::vector<int> d = displacements(counts);
  const std::size_t total = static_cast<std::size_t>(d.back()) + counts.back();
  all.vx.resize(total);
  all.vy.resize(total);
  all.vz.resize(total);
  all.id.resize(total);
  auto gather = [&](const std::vector<double>& a, std::vector<double>& b) {
    MPI_Allgatherv(a.data(), n, MPI_DOUBLE, b.data(), counts.data(), d.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  };
  gather(local.vx, all.vx);
  gather(local.vy, all.vy);
  gather(local.vz, all.vz);
  if (with_x) {
    all.x.resize(total);
    gather(local.x, all.x);
  }
#else
  (void)local;
  (void)with_x;
  (void)all;
#endif
}

State Decomposition::gather_state(const State& s, const Config& c) const {
  State g;
#ifdef GRAINBATH_MPI
  const int root_rank = 0;
  const Particles& p = s.particles;
  std::vector<int> counts(size_);
  const int n = to_int(p.size(), "the particles of one rank");
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, root_rank, MPI_COMM_WORLD);
  std::vector<int> d = root() ? displacements(counts) : std::vector<int>(size_, 0);
  const std::size_t total = root() ? static_cast<std::size_t>(d.back()) + counts.back() : 0;
  auto gather = [&](const std::vector<double>& a, std::vector<double>& b) {
    if (root()) b.resize(total);
    MPI_Gatherv(a.data(), n, MPI_DOUBLE, b.data(), counts.data(), d.data(), MPI_DOUBLE, root_rank, MPI_COMM_WORLD);
  };
  Particles& q = g.particles;
  gather(p.vx, q.vx);
  gather(p.vy, q.vy);
  gather(p.vz, q.vz);
  if (c.spatial()) gather(p.x, q.x);
  if (c.domain.dimensions > 1) gather(p.y, q.y);
  if (c.domain.dimensions > 2) gather(p.z, q.z);
  if (!p.bath_hazard.empty()) gather(p.bath_hazard, q.bath_hazard);
  if (root()) q.id.resize(total);
  MPI_Gatherv(p.id.data(), n, MPI_UINT64_T, q.id.data(), counts.data(), d.data(), MPI_UINT64_T, root_rank, MPI_COMM_WORLD);
  // per-cell data: each rank's own cell range, in rank order = cell order
  std::vector<int> cc(size_), cd(size_);
  for (int r = 0; r < size_; ++r) {
    cc[r] = to_int(end_cell(r) - first_cell(r), "the cells of one rank");
    cd[r] = to_int(first_cell(r), "the cell grid");
  }
  const std::size_t lo = first_cell(rank_);
  if (root()) g.remainder.resize(s.remainder.size());
  MPI_Gatherv(s.remainder.data() + lo, cc[rank_], MPI_DOUBLE, g.remainder.data(), cc.data(), cd.data(), MPI_DOUBLE,
              root_rank, MPI_COMM_WORLD);
  const FieldAccumulator& f = s.fields;
  g.fields = f;  // metadata (and rank 0's own sums, overwritten below)
  if (!root()) g.fields.sums.clear();
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
  double steps_run = sum(s.particle_steps_run);
  if (root()) {
    g.step = s.step;
    g.counters = s.counters;
    g.series = s.series;
    g.initial_kinetic_energy = s.initial_kinetic_energy;
    g.particle_steps_run = steps_run;
    g.collisions_before_run = s.collisions_before_run;
    // rough grains (homogeneous runs only: rank 0 holds every grain and its spin)
    g.wx = s.wx;
    g.wy = s.wy;
    g.wz = s.wz;
  }
#else
  (void)s;
  (void)c;
#endif
  return g;
}

}  // namespace grainbath::dsmc
