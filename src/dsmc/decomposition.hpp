#pragma once
// Spatial domain decomposition of the DSMC cell grid over MPI ranks (docs/dsmc.md, "MPI
// domain decomposition"). In the plain build (GRAINBATH_MPI off), or when a process runs
// alone, there is one rank and every operation here is the identity: the same driver code
// runs in both builds.
//
// Reproducibility across rank counts rests on three facts:
//  1. every random number is keyed on (seed, stream; particle id or cell id, step), and a
//     cell's particles are ordered by id, so what happens in a cell does not depend on which
//     rank holds it;
//  2. the cells are cut into fixed reduction blocks of B consecutive cells (linear index,
//     x fastest; B depends on the case only), rank boundaries fall on block boundaries, and
//     every floating-point counter is summed per block and the block sums are added in
//     block order (combine_in_order), the same at any rank and thread count;
//  3. moments of the whole population are summed in blocks of the global (cell, id) order,
//     i.e. of exactly the array a single process holds: a block split between ranks is
//     summed by its ranks in turn (moments_in_global_blocks). No rank ever gathers the
//     particles, not even for output (src/dsmc/checkpoint.hpp, output.hpp).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "dsmc/dsmc.hpp"
#include "dsmc/moments.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

// Cells per reduction block: the largest power of two <= 256 holding about 1024 particles
// (on average) or fewer: enough work per block for the threads, fine enough for the load
// balance between ranks. A function of the case alone.
std::size_t reduction_block_cells(const Config& c);

// A medium is present if [background] density > 0, or if a file supplies the fields; then
// every grain carries its bath residual (Particles::bath_hazard), also when it migrates.
// From the case alone, so that a rank that holds no grain still agrees on the layout.
bool medium_present(const Config& c);

namespace mpi_env {
// MPI is initialised only when the process was started by mpirun (or another launcher
// that sets the PMI/PMIx environment); a plain `grainbath run` of an MPI build does not
// touch MPI at all. In the plain build these report one rank.
void init(int* argc, char*** argv);
void finalize();
bool active();                 // MPI_Init was called
int world_rank();
int world_size();
[[noreturn]] void abort(int code);  // MPI_Abort when several ranks run, else std::_Exit
void barrier();
long long sum(long long x);    // over MPI_COMM_WORLD (a barrier too)
int node_ranks();              // ranks on this machine (sharing its memory), this one included
}  // namespace mpi_env

// The first block of each of `ranks` contiguous ranges (and the end, w.size(), last) that
// share the block weights `w` (grains + 1 per block) about equally: rank r's range starts
// at the block boundary nearest to r/ranks of the total weight.
std::vector<std::size_t> balanced_block_boundaries(const std::vector<std::uint64_t>& w, int ranks);

class Decomposition {
 public:
  // use_world: split the cells over MPI_COMM_WORLD (false: this process alone).
  Decomposition(const Config& c, bool use_world);

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }
  std::size_t block_cells() const { return block_cells_; }
  std::size_t first_block() const { return first_block_[rank_]; }
  std::size_t end_block() const { return first_block_[rank_ + 1]; }
  std::size_t first_cell(int r) const;
  std::size_t end_cell(int r) const;
  int owner_of_block(std::size_t b) const;

  // Particle-index bounds of this rank's reduction blocks (needs s.cell_start): spatial
  // runs, one block per B cells; homogeneous runs (one cell, rank 0), fixed blocks of
  // 4096 particles as in the single-process code.
  void block_bounds(const State& s, const Config& c, std::vector<std::size_t>& bounds) const;

  // Every rank gets the concatenation of all ranks' per-block partials in rank order,
  // i.e. in global block order. T must be trivially copyable. per_block: one entry per
  // reduction block of this rank (spatial runs), so the sizes are known everywhere and one
  // collective suffices instead of two.
  template <class T>
  void combine_in_order(std::vector<T>& partials, bool per_block = false) const {
    if (size_ == 1) return;
    std::vector<unsigned char> mine(partials.size() * sizeof(T));
    if (!mine.empty()) std::memcpy(mine.data(), partials.data(), mine.size());
    std::vector<unsigned char> all = allgather_bytes(mine, per_block && spatial_ ? sizeof(T) : 0);
    partials.resize(all.size() / sizeof(T));
    if (!all.empty()) std::memcpy(partials.data(), all.data(), all.size());
  }

  // Start of a run: choose balanced boundaries and send every particle to its owner.
  // read_own: each rank holds its own cells' grains, read from a checkpoint after
  // plan_restart chose the boundaries; otherwise each rank holds a disjoint part of the
  // population (initialise() on this rank's share of the ids), the block weights are summed
  // over the ranks and the particles move to their owners in one all-to-all. Leaves the cell
  // of every particle (kRemoved: not this rank's) in s.sort.cell for sort_by_cell.
  void distribute(State& s, const Config& c, bool read_own);
  // Restart (spatial runs): the boundaries from the grains per reduction block of the whole
  // checkpoint (every rank counts them alike from the positions), chosen as a fresh start
  // chooses them; [first, end) receives this rank's grains in the checkpoint's global
  // (cell, id) order, where its blocks' grains are contiguous.
  void plan_restart(const std::vector<std::uint64_t>& grains_per_block, std::uint64_t& first, std::uint64_t& end);
  // After streaming: send particles that left this rank's cells to their owners, receive
  // those that arrived. Neighbour exchanges only: the ranks form a ring in cell order, a
  // migrant goes the shorter way round and is forwarded one neighbour per round until it
  // reaches its owner (several rounds only when some grain crossed more than one rank's
  // cells in a step). Leaves the cell of every particle (kRemoved: gone) in s.sort.cell.
  void migrate(State& s, const Config& c, std::vector<std::uint8_t>& removed);
  // The same exchange for the fused step (src/dsmc/fused.cpp), which finds
  // the grains that left while it streams and packs them itself: `leaving` holds their
  // records (migrant_width(c) doubles each: the id's 64 bits, vx, vy, vz, the streamed
  // position, one per dimension, and the bath residual if a medium is present), `staying`
  // the number of grains this rank keeps. Returns the records that arrived here, in the
  // order migrate() appends them. Collective (every rank calls it every step).
  std::vector<double> migrate_records(const Config& c, const std::vector<double>& leaving, std::size_t staying);
  static std::size_t migrant_width(const Config& c);
  // One record of `leaving` / of the result, in migrate()'s own layout (unused components:
  // y, z beyond the dimensions and the residual without a medium, are left out / read as 0).
  static void pack_migrant(const Config& c, std::uint64_t id, const double (&v)[3], const double (&r)[3],
                           double residual, std::vector<double>& out);
  static void unpack_migrant(const Config& c, const double* record, std::uint64_t& id, double (&v)[3], double (&r)[3],
                             double& residual);
  void note_particles(std::size_t n) { peak_particles_ = std::max(peak_particles_, n); }
  // Share [lo, hi) of `count` items (ids at start-up) for this rank: contiguous, in rank
  // order, cut at multiples of `granule` (the moment blocks of measure_moments).
  void share(std::size_t count, std::size_t granule, std::size_t& lo, std::size_t& hi) const;
  // Measured work: the collision candidates (background and grain-grain) of every
  // reduction block, from the per-block counters after combine_in_order, hence the same on
  // every rank; summed until the next rebalance.
  template <class Counters>
  void add_work(const std::vector<Counters>& combined) {
    if (size_ == 1 || !spatial_ || combined.size() != blocks_) return;
    for (std::size_t b = 0; b < blocks_; ++b) work_[b] += combined[b].candidates;
  }
  // Load balance: block weight = particles + collision candidates per step since the last
  // balance (a candidate costs about as much as a particle-step). Moves particles and
  // per-cell data (NTC remainders, field sums) of cells that change owner. True if
  // anything moved (the caller sorts again).
  bool rebalance(State& s, const Config& c);
  // Moments of the whole population from this rank's particles: per block
  // [bounds[b], bounds[b+1]) sums, combined over the ranks in block order (two small
  // all-gathers, no particle leaves its rank), so every rank gets the same numbers, the
  // ones a single process gets with the same blocks. per_block: bounds are this rank's
  // reduction blocks (block_bounds of a spatial run).
  Moments moments(const Particles& p, const std::vector<std::size_t>& bounds, double mass, bool per_block) const;
  // Moments of the whole population summed exactly as measure_moments sums the array one
  // process holds (blocks of 4096 particles of the global order, src/dsmc/moments.cpp):
  // the output's final moments, bitwise those of a single process at any rank count.
  Moments moments_in_global_blocks(const Particles& p, double mass) const;
  // Everything but the particles on rank 0: counters, series and scalars as rank 0 has them
  // (the same on every rank), the per-cell data (NTC remainders, field sums: O(cells)) from
  // each cell's owner, and the spins (homogeneous rough runs: rank 0 holds every grain).
  // Other ranks get an empty State. Collective.
  State gather_cells(const State& s) const;

  // Output in rank order (serial HDF5: one process at a time in a file). Rank 0 calls
  // `turn` with `token`, sends the result to rank 1, which calls `turn` on it and sends it
  // on, ..., the last rank sends the result back to rank 0, where it is returned (other
  // ranks return what they sent). One process: turn(token).
  std::vector<unsigned char> in_rank_order(std::vector<unsigned char> token,
                                           const std::function<void(std::vector<unsigned char>&)>& turn) const;
  template <class T>
  T in_rank_order(T token, const std::function<void(T&)>& turn) const {
    std::vector<unsigned char> bytes(sizeof(T));
    std::memcpy(bytes.data(), &token, sizeof(T));
    bytes = in_rank_order(std::move(bytes), [&](std::vector<unsigned char>& b) {
      T t;
      std::memcpy(&t, b.data(), sizeof(T));
      turn(t);
      std::memcpy(b.data(), &t, sizeof(T));
    });
    std::memcpy(&token, bytes.data(), sizeof(T));
    return token;
  }
  // Offsets of this rank's parts in arrays spread over the ranks in rank order: offset[k] is
  // the sum of local[k] over the ranks before this one, total[k] over all ranks.
  void offsets(const std::vector<std::uint64_t>& local, std::vector<std::uint64_t>& offset,
               std::vector<std::uint64_t>& total) const;
  // Collective error agreement after a step that may fail on some ranks: empty if `mine` is
  // empty on every rank, else the message of the lowest failing rank ("rank r: ..."), on
  // every rank, so that all of them stop with the same clear message instead of hanging.
  std::string first_error(const std::string& mine) const;
  // Sums over the ranks that are exact in any order: integer-valued doubles (histogram
  // counts below 2^53), and 64-bit integers modulo 2^64.
  void sum_counts(std::vector<double>& counts) const;
  std::uint64_t sum_wrapping(std::uint64_t x) const;

  bool any(bool flag) const { return any_bits(flag ? 1 : 0) != 0; }  // logical OR over the ranks
  int any_bits(int bits) const;     // bitwise OR over the ranks (several flags, one collective)
  double sum(double x) const;       // sum over the ranks (rank order)
  long long max(long long x) const; // maximum over the ranks
  double imbalance() const { return imbalance_; }  // max/mean particles per rank at the last balance
  int rebalances() const { return rebalances_; }

  // Communication of migrate() on this rank since the start (docs/performance/mpi.md):
  // neighbour rounds, messages and bytes sent, collectives, the most ranks one grain crossed,
  // the steps after which this rank held no grain (its cells empty or it owns none: the
  // tests of tiny cases check that they test such a rank, tests/mpi/mpi_tiny.sh), and the
  // refills, steps after which it holds grains again having held none after the step before
  // (the fused step then rebuilds its arrays from nothing: tests/mpi/cases/refillslab).
  struct MigrationStats {
    long long steps = 0, rounds = 0, messages = 0, bytes = 0, collectives = 0, migrants = 0, empty_steps = 0,
              refills = 0;
    int max_hops = 0;
    bool empty_after_last_step = false;
  };
  const MigrationStats& migration_stats() const { return stats_; }
  // The most grains this rank has held at once in its particle arrays (from the start, or
  // from reading a checkpoint, through the start-up distribution and every migration and
  // rebalance): about N/size after a fresh start or a resume (each rank reads its own
  // grains of the checkpoint). Output gathers no grain.
  std::size_t peak_particles() const { return peak_particles_; }

 private:
  std::vector<unsigned char> allgather_bytes(const std::vector<unsigned char>& mine, std::size_t bytes_per_block) const;
  std::vector<std::size_t> balanced_boundaries(const std::vector<std::uint64_t>& weights);
  void cells_of_all(State& s, const Config& c, const std::vector<std::uint8_t>* removed) const;
  void send_to_owners(State& s, const Config& c);  // uses s.sort.cell; all-to-all
  int ring_offset(int to) const;  // signed ring distance to rank `to` (shorter way; > 0: rightwards)
  void move_cell_data(State& s, const std::vector<std::size_t>& old_first);

  int rank_ = 0, size_ = 1;
  bool world_ = false, spatial_ = false;
  std::vector<std::uint64_t> work_;       // candidates per block since the last balance
  std::int64_t balanced_at_step_ = 0;
  std::size_t cells_ = 1, block_cells_ = 1, blocks_ = 1;
  std::vector<std::size_t> first_block_;  // [size + 1]
  double imbalance_ = 1.0;
  int rebalances_ = 0;
  MigrationStats stats_;
  std::size_t peak_particles_ = 0;
};

}  // namespace grainbath::dsmc
