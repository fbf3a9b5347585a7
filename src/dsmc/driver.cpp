// The DSMC driver: one loop for homogeneous (one cell, no positions) and spatial runs.
//
// Time step (Strang splitting of the collision operators, second order in dt):
//   background collisions over dt/2 -> [stream over dt, sort into cells] -> grain-grain
//   collisions over dt in every cell -> background collisions over dt/2.
// Between two steps nothing else acts on the grains' velocities, so the second half of one
// step and the first half of the next are one substep over dt (the bath process is Markov
// and its thinning exact: two halves with the residual carried and one whole substep are the
// same process in law): a pass over the grains and its per-grain set-up saved per step (the
// random words differ, keyed on their own stream). The halves stay apart where the state is
// observed: before every sample and at the end (State::bath_half_pending, checkpointed, so a
// checkpoint written between samples resumes bitwise and where checkpoints fall never
// changes the numbers).
// Background substeps are exact in distribution for each grain (thinning with a per-grain
// majorant, operators/background.hpp); grain-grain collisions use NTC per cell.
// Every random number is keyed on (seed, stream; particle or cell id, step) and particles
// are ordered by id inside each cell, so a run is a pure function of (case, seed): the
// same at any thread count, and bitwise the same after a restart from a checkpoint.
#include <omp.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "core/h5.hpp"
#include "core/run_support.hpp"
#include "dsmc/checkpoint.hpp"
#include "dsmc/collide.hpp"
#include "dsmc/collision_groups.hpp"
#include "dsmc/decomposition.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/fused.hpp"
#include "dsmc/moments.hpp"
#include "dsmc/output.hpp"
#include "dsmc/rough.hpp"
#include "dsmc/spatial.hpp"
#include "dsmc/theory.hpp"

namespace grainbath::dsmc {

namespace {

// Initial state: positions from the density profile and Maxwellian velocities, each grain
// from its own counter-based stream; then velocities are shifted and scaled so that the
// sample mean and temperature are exactly the requested ones (no O(N^-1/2) noise at t = 0).
// MPI, spatial runs: each rank generates only its share of the ids (contiguous, cut at the
// 4096-id moment blocks), and Decomposition::distribute sends every grain to the owner of
// its cell: no rank ever holds the whole population. Who generates a grain does not matter
// (its streams are keyed on its id), and the moments for the shift and scale are summed per
// id block and the blocks added in id order on every rank, as measure_moments does in one
// process: the state is bitwise the same at any rank count. Homogeneous runs: rank 0
// generates every grain (the others idle).
void initialise(State& s, const Config& c, std::uint64_t seed, bool bath_on, const Decomposition& dec) {
  constexpr std::size_t kMomentBlock = 4096;  // measure_moments' block (src/dsmc/moments.cpp)
  Particles& p = s.particles;
  std::size_t first = 0, end = static_cast<std::size_t>(c.particles);
  if (c.spatial())
    dec.share(end, kMomentBlock, first, end);
  else if (!dec.root())
    end = 0;
  const std::size_t n = end - first;
  const Domain& d = c.domain;
  // not zero-filled (core/no_fill_vector.hpp): the parallel loop below writes every element,
  // and its threads take the page faults of the fresh arrays
  p.resize(n, false);
  if (bath_on) p.bath_hazard.resize(n);
  if (c.spatial()) {
    p.x.resize(n);
    if (d.dimensions > 1) p.y.resize(n);
    if (d.dimensions > 2) p.z.resize(n);
  }
  const double sig = std::sqrt(c.grains.temperature / c.grains.mass);
  const double k = c.spatial() ? c.wavenumber() : 0.0;
  const double A = c.grains.profile == GrainProfile::mode ? c.grains.amplitude : 0.0;
#pragma omp parallel for schedule(static)
  for (std::size_t j = 0; j < n; ++j) {
    const std::uint64_t i = first + j;  // the grain's id
    p.id[j] = i;
    CounterRng rng(seed, Stream::initial_velocities, i, 0);
    p.set_velocity(j, sig * rng.normal3());
    if (bath_on) p.bath_hazard[j] = CounterRng(seed, Stream::background_clock, i, 0).exponential_ziggurat();
    if (c.spatial()) {
      CounterRng pr(seed, Stream::initial_positions, i, 0);
      // n0 (1 + A cos kx) by rejection
      double x;
      do {
        x = pr.uniform() * d.length[0];
      } while (A != 0.0 && pr.uniform() * (1.0 + std::abs(A)) > 1.0 + A * std::cos(k * x));
      p.x[j] = x;
      if (d.dimensions > 1) p.y[j] = pr.uniform() * d.length[1];
      if (d.dimensions > 2) p.z[j] = pr.uniform() * d.length[2];
    }
  }
  std::vector<std::size_t> id_blocks;  // this rank's moment blocks (first is a multiple of 4096)
  for (std::size_t lo = 0; lo < n; lo += kMomentBlock) id_blocks.push_back(lo);
  id_blocks.push_back(n);
  const Moments m = dec.moments(p, id_blocks, c.grains.mass, false);
  const double scale = std::sqrt(c.grains.temperature / m.temperature);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i)  // grain by grain: the same bits on any number of threads
    p.set_velocity(i, scale * (p.velocity(i) - m.mean_velocity) + c.grains.drift);
  // The fractional NTC candidate each cell carries (collide_cell) starts uniform on (0, 1),
  // its steady distribution (the fractional part of a sum of continuous increments), not
  // at 0: from 0 a cell with K candidates per step draws none for its first ~1/K steps,
  // half a candidate per cell too few in all, which at 2 grains per cell (K ~ 0.02) was
  // 3 % of the collisions of the first 5 time units
  // (DsmcSpatial.CellCollisionRateIsBoltzmannsAtFewGrainsPerCell). Keyed on the cell: the same
  // on every rank.
  s.remainder.resize(c.spatial() ? d.cell_count() : 1);
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < s.remainder.size(); ++k)
    s.remainder[k] = CounterRng(seed, Stream::ntc_initial_remainder, k, 0).uniform();
  s.initial_kinetic_energy = dec.moments(p, id_blocks, c.grains.mass, false).kinetic_energy;
  if (c.rough) initialise_spins(s, c, seed);
}

// The medium at each grain of a non-uniform background, kept from the second half-substep
// of a step for the first half-substep of the next: nothing moves a grain or reorders the
// arrays in between (streaming and sorting come after the first half), so the values are
// those a fresh local_background() would give, bit for bit. That evaluation (a sine and two
// square roots per grain for the isobaric profile) was a third of a 1D thermal-gradient run;
// the cache halves it, for 56 bytes per grain in runs with a non-uniform medium only.
// Not checkpointed: a resumed run starts with step = -1 and evaluates afresh.
struct LocalBathCache {
  std::vector<BackgroundState> at;  // per grain, in the particle order of the arrays
  std::int64_t step = -1;           // the step whose first half-substep may use `at`
};

// Background substep for every grain, in fixed reduction blocks (deterministic reduction at
// any thread or rank count: src/dsmc/decomposition.hpp).
void bath_substep(State& s, const Config& c, const BackgroundState& uniform_bath, double duration,
                  std::uint64_t seed, Stream stream, Decomposition& dec, std::vector<std::size_t>& bounds,
                  LocalBathCache& cache) {
  Particles& p = s.particles;
  dec.block_bounds(s, c, bounds);
  const std::size_t blocks = bounds.size() - 1;
  const bool local = c.field.profile != BackgroundProfile::uniform;
  const double m = c.grains.mass;
  const auto step = static_cast<std::uint64_t>(s.step);
  std::vector<BackgroundCounters> partial(blocks);
  const BathKey key{seed, stream, step};
  // the bath kernel's Philox4x32 counters hold the id in 56 bits and the step in 32
  // (operators/background.hpp, bath_ctr0/bath_ctr1)
  if (step >> 32 != 0 || static_cast<std::uint64_t>(c.particles) >> 56 != 0)
    throw std::runtime_error("bath substep: step or grain ids beyond the bath kernel's counter range");
  const bool second_half = stream == Stream::background_second_half;
  const bool cached = local && !second_half && cache.step == s.step && cache.at.size() == p.size();
  if (local && second_half) cache.at.resize(p.size());
  // The fixed random budget per test (operators/background.hpp, bath_evolve_batch): the
  // interleaved kernel over the block, with one medium (uniform) or each grain's own (local:
  // bath_evolve_batch_local); bitwise the per-grain kernel's results either way.
#pragma omp parallel for schedule(dynamic, 4)
  for (std::size_t blk = 0; blk < blocks; ++blk) {
    BackgroundCounters cnt;
    const std::size_t lo = bounds[blk], hi = bounds[blk + 1];
    if (local) {
      // each grain's medium at its position (the second half's are kept for the next step's
      // first, the grains not having moved), then the batch kernel with a medium per grain
      const BackgroundState* media = cached ? cache.at.data() + lo : nullptr;
      if (!cached) {
        thread_local std::vector<BackgroundState> block_media;
        BackgroundState* at = second_half ? cache.at.data() + lo : nullptr;
        if (at == nullptr) {
          if (block_media.size() < hi - lo) block_media.resize(hi - lo);
          at = block_media.data();
        }
        // the cell only for a medium given per cell (profile "file"); the analytic profiles
        // read the position alone
        const bool per_cell = c.field.profile == BackgroundProfile::file;
        const CellGrid grid(c.domain);
        for (std::size_t i = lo; i < hi; ++i) {
          const double x = p.x[i], y = p.y.empty() ? 0.0 : p.y[i], z = p.z.empty() ? 0.0 : p.z[i];
          at[i - lo] = local_background(c, x, y, z, per_cell ? grid(x, y, z) : 0u);
        }
        media = at;
      }
      bath_evolve_batch_local(hi - lo, p.id.data() + lo, p.vx.data() + lo, p.vy.data() + lo, p.vz.data() + lo,
                              p.bath_hazard.data() + lo, media, m, duration, key, cnt);
    } else {
      bath_evolve_batch(hi - lo, p.id.data() + lo, p.vx.data() + lo, p.vy.data() + lo, p.vz.data() + lo,
                        p.bath_hazard.data() + lo, uniform_bath, m, duration, key, cnt);
    }
    partial[blk] = cnt;
  }
  if (local) cache.step = second_half ? s.step + 1 : -1;  // valid until the grains move
  dec.combine_in_order(partial, true);
  dec.add_work(partial);  // load-balance weights
  for (const auto& c2 : partial) {
    s.counters.bath_candidates += c2.candidates;
    s.counters.bath_collisions += c2.collisions;
    s.counters.bath_energy += c2.energy_gain;
  }
}

// Homogeneous runs with enough grains: the step's collision groups (src/dsmc/collision_groups.hpp)
// in parallel, each with its own generator (seed, Stream::grain_collisions; group, step) and
// counters, summed in group order: the same bits at any thread count.
struct GroupedCollisions {
  CollisionGroups groups;
  std::vector<GrainCounters> per_group;
};

// Grain-grain collisions in every cell; each cell has its own random stream (cell id, step)
// and its own counters, summed in cell order afterwards.
// Counters are summed per fixed block of cells (then blocks in order): the floating-point
// sum of the inelastic loss is the same at any thread count. MPI: each rank does its own
// blocks; the partials are combined in block order on every rank.
void grain_step(State& s, const Config& c, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                Decomposition& dec, GroupedCollisions& grouped) {
  const std::size_t kCellBlock = dec.block_cells();  // this rank's blocks of cells
  if (c.rough)  // homogeneous rough grains (src/dsmc/rough.hpp; collision groups or one cell, rank 0)
    return rough_grain_step(s, c, seed, grouped.groups, grouped.per_group);
  const std::size_t cells = s.cell_start.size() - 1;
  const std::size_t first = dec.first_block(), blocks = dec.end_block() - first;
  per_block.assign(blocks, GrainCounters{});
  const double weight = c.grains.density * (c.spatial() ? c.domain.volume() : 1.0) / static_cast<double>(c.particles);
  const double cell_volume = c.spatial() ? c.domain.cell_volume() : 1.0;
  const auto step = static_cast<std::uint64_t>(s.step);
  const std::size_t grains = s.particles.size();
  if (!c.spatial() && CollisionGroups::apply(grains, c.collision_group)) {
    if (blocks > 0) {  // the rank that holds the one cell (rank 0)
      grouped.groups.deal(grains, c.collision_group, seed, step);
      const std::size_t groups = grouped.groups.count();
      grouped.per_group.assign(groups, GrainCounters{});
      std::visit(
          [&](const auto& law) {
#pragma omp parallel for schedule(static)
            for (std::size_t g = 0; g < groups; ++g) {
              CellCollisionRng rng(seed, Stream::grain_collisions, g, step);
              GrainCounters cnt;  // local: neighbouring groups' counters share cache lines
              collide_group(s.particles, grouped.groups.tiles(g), grouped.groups.tile_count(g), grouped.groups.grains(g),
                            c.grains.density, c.dt, c.grains.mass, law, rng, cnt, c.exact_bound);
              grouped.per_group[g] = cnt;
            }
          },
          c.restitution);
      for (const auto& g : grouped.per_group) per_block[0].add(g);
    }
  } else {
    std::visit(
        [&](const auto& law) {
#pragma omp parallel for schedule(static)
          for (std::size_t blk = 0; blk < blocks; ++blk) {
            GrainCounters cnt;
            for (std::size_t k = (first + blk) * kCellBlock; k < std::min(cells, (first + blk + 1) * kCellBlock); ++k) {
              const std::size_t b = s.cell_start[k], e = s.cell_start[k + 1];
              if (e - b < 2) continue;
              // homogeneous: the case density (N fixed); spatial: the density of a grain's
              // partners in the cell (cell_partner_density: N fluctuates)
              const double density = c.spatial() ? cell_partner_density(e - b, weight, cell_volume) : c.grains.density;
              CellCollisionRng rng(seed, Stream::grain_collisions, k, step);
              collide_cell(s.particles, b, e, density, c.dt, c.grains.mass, law, rng, s.remainder[k], cnt, c.exact_bound);
            }
            per_block[blk] = cnt;
          }
        },
        c.restitution);
  }
  dec.combine_in_order(per_block, true);
  dec.add_work(per_block);  // load-balance weights
  for (const auto& g : per_block) s.counters.grain.add(g);
}

// Moments of the whole population, summed per reduction block (src/dsmc/decomposition.hpp)
// and combined in block order: each rank sums its own particles, and every rank gets the
// same numbers as one process (no particle is gathered).
// Samples of the fields' averaging window: the sample points of steps 0..c.steps at t >= steady_from.
std::int64_t field_window_samples(const Config& c) {
  std::int64_t n = 0;
  for (std::int64_t st = 0; st <= c.steps; ++st)
    if (c.sampled_after(st) && static_cast<double>(st) * c.dt >= c.steady_from - 1e-12) ++n;
  return n;
}

// A fresh window: [sampling] field_batches batches (at most one per sample) over one segment.
void plan_field_window(FieldAccumulator& f, const Config& c) {
  f.window_samples = field_window_samples(c);
  f.taken = 0;
  f.batches = static_cast<int>(std::min<std::int64_t>(c.field_batches, std::max<std::int64_t>(1, f.window_samples)));
  f.segments.clear();
  if (f.window_samples > 0) f.segments.push_back({0, f.window_samples, 0, f.batches});
  f.sums.assign(static_cast<std::size_t>(f.batches) * f.cells * FieldAccumulator::kSums, 0.0);
  f.batch_samples.assign(f.batches, 0);
}

// --resume with a later dsmc.t_end: the window grows; the samples added get batches of about
// the length the window's batches had, appended after them (FieldBatchSegment), so the
// samples already summed stay in their batches. A window that took no sample yet is planned
// afresh. Every rank does the same (each holds the sums of all cells).
void extend_field_window(FieldAccumulator& f, const Config& c) {
  const std::int64_t window = field_window_samples(c);
  if (window <= f.window_samples) return;  // same run (or a shorter one: its last batches stay short)
  if (f.taken == 0) {
    plan_field_window(f, c);
    return;
  }
  const std::int64_t added = window - f.window_samples;
  const double per_batch = static_cast<double>(f.window_samples) / f.batches;
  const int batches = static_cast<int>(
      std::clamp<std::int64_t>(std::llround(static_cast<double>(added) / per_batch), 1, added));
  f.segments.push_back({f.window_samples, window, f.batches, batches});
  f.batches += batches;
  f.window_samples = window;
  f.sums.resize(static_cast<std::size_t>(f.batches) * f.cells * FieldAccumulator::kSums, 0.0);
  f.batch_samples.resize(f.batches, 0);
}

void sample(State& s, const Config& c, double t, const Decomposition& dec, std::vector<std::size_t>& bounds) {
  const Particles& p = s.particles;
  dec.block_bounds(s, c, bounds);
  Moments mo = dec.moments(p, bounds, c.grains.mass, c.spatial());
  const double n = mo.count;
  TimeSeries& ts = s.series;
  if (static_cast<std::int64_t>(ts.t.size()) == fault_nonfinite_sample()) mo.temperature = std::nan("");  // test hook
  // grain density of the sampled population (spatial: mean over the box)
  const double density = c.grains.density * n / static_cast<double>(c.particles);
  ts.t.push_back(t);
  ts.T.push_back(mo.temperature);
  ts.a2.push_back(mo.a2);
  ts.a3.push_back(mo.a3);
  ts.velocity.insert(ts.velocity.end(), {mo.mean_velocity.x, mo.mean_velocity.y, mo.mean_velocity.z});
  for (double x : mo.pressure) ts.pressure.push_back(density * x);
  ts.heat_flux.insert(ts.heat_flux.end(),
                      {density * mo.heat_flux.x, density * mo.heat_flux.y, density * mo.heat_flux.z});
  const double per = 1.0 / static_cast<double>(c.particles);
  ts.ke.push_back(mo.kinetic_energy * per);
  ts.bath_in.push_back(s.counters.bath_energy * per);
  ts.loss.push_back(s.counters.grain.energy_loss * per);
  ts.wall_in.push_back(s.counters.wall_energy * per);
  ts.removed_out.push_back(s.counters.removed_energy * per);
  ts.count.push_back(n);
  if (c.rough) ts.Trot.push_back(rotational_temperature(s, c));
  ts.bath_collisions.push_back(s.counters.bath_collisions);
  ts.grain_collisions.push_back(s.counters.grain.collisions);
  if (c.spatial() && c.grains.profile == GrainProfile::mode) {
    // projection on the mode advected with the background drift, A(t) = 2 Re <exp(ik(x - uB_x t))>:
    // unbiased (unlike |<exp(ikx)>|, which has a noise floor) and free of the phase drift
    const double k = c.wavenumber();
    const double phase = k * c.background.velocity.x * t;
    const double cp = std::cos(phase), sp = std::sin(phase);
    // a sincos per grain at every sample (a seventh of a 1D mode run): the blocks in parallel,
    // each summed in particle order as before, so the same bits at any thread count
    const std::size_t blocks = bounds.size() - 1;
    std::vector<double> per_block(blocks, 0.0);
#pragma omp parallel for schedule(static)
    for (std::size_t b = 0; b < blocks; ++b) {
      double sum = 0.0;
      for (std::size_t i = bounds[b]; i < bounds[b + 1]; ++i) sum += std::cos(k * p.x[i]) * cp + std::sin(k * p.x[i]) * sp;
      per_block[b] = sum;
    }
    dec.combine_in_order(per_block, true);
    double a = 0;
    for (double x : per_block) a += x;
    ts.mode_amplitude.push_back(2.0 * a / n);
  }
  if (!std::isfinite(mo.temperature) || !std::isfinite(mo.a2))
    throw std::runtime_error("non-finite temperature or a2 at t = " + std::to_string(t) +
                             ": stopping (is dt far too large?)");
  // per-cell sums for the time-averaged fields
  FieldAccumulator& f = s.fields;
  if (f.cells > 0 && t >= c.steady_from - 1e-12 && f.taken < f.window_samples) {
    const int batch = f.batch_of(f.taken);
    double* base = f.sums.data() + static_cast<std::size_t>(batch) * f.cells * FieldAccumulator::kSums;
#pragma omp parallel for schedule(dynamic, 256)
    for (std::size_t k = 0; k < f.cells; ++k) {
      double* a = base + k * FieldAccumulator::kSums;
      for (std::size_t i = s.cell_start[k]; i < s.cell_start[k + 1]; ++i) {
        const double vx = p.vx[i], vy = p.vy[i], vz = p.vz[i], v2 = vx * vx + vy * vy + vz * vz;
        a[0] += 1;
        a[1] += vx;
        a[2] += vy;
        a[3] += vz;
        a[4] += vx * vx;
        a[5] += vy * vy;
        a[6] += vz * vz;
        a[7] += vx * vy;
        a[8] += vx * vz;
        a[9] += vy * vz;
        a[10] += v2 * vx;
        a[11] += v2 * vy;
        a[12] += v2 * vz;
        a[13] += v2;
      }
    }
    f.batch_samples[batch] += 1;
    f.taken += 1;
  }
}

// The most resident memory this process has had (the kernel's high-water mark, in bytes).
long long peak_resident_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<long long>(u.ru_maxrss) * 1024;  // Linux: kB
}

}  // namespace

void run(const Config& c, const RunContext& ctx, Summary& summary) {
  const auto wall_start = std::chrono::steady_clock::now();
  if (ctx.threads > 0) omp_set_num_threads(ctx.threads);
  const BackgroundParameters& bg = c.background;
  const BackgroundState uniform_bath =
      BackgroundState::make(bg.density, bg.knudsen, bg.velocity, bg.temperature, bg.mass_ratio, c.grains.mass);

  // a medium is present if [background] density > 0, or if a file supplies the fields
  const bool bath_on = medium_present(c);
  Decomposition dec(c, ctx.decompose);  // MPI: this rank's share of the cells
  if (dec.size() > 1 && !c.spatial() && dec.root())
    std::fprintf(stderr, "note: a homogeneous run is not split over ranks (its collision groups mix all grains "
                         "every step): rank 0 runs it and the other %d rank(s) idle; "
                         "replicas go on ranks with `mpirun grainbath sweep CASE --set run.seed=1,2,...`\n",
                 dec.size() - 1);
  State s;
  bool resumed = false;
  std::uint64_t checkpoint_read_bytes = 0;  // performance.checkpoint_read_bytes_* (docs/OUTPUT.md)
  if (ctx.resume) {
    std::string warning;
    // MPI: this rank's grains
    std::string saved_t_end;
    auto restored =
        read_newest_checkpoint(ctx.checkpoint_dir, ctx, warning, c, dec, checkpoint_read_bytes, &saved_t_end);
    if (!warning.empty() && dec.root()) std::fprintf(stderr, "warning: %s\n", warning.c_str());
    if (!restored) throw std::runtime_error("--resume: no valid checkpoint in " + ctx.checkpoint_dir.string());
    s = std::move(*restored);
    resumed = true;
    // dsmc.t_end may change on --resume (to extend a run), but not to before the checkpoint:
    // the run would do no step and report the checkpoint's state as the one at t_end. A
    // checkpoint at the new last step finishes with no step if its state was sampled there
    // (a sample point, or the last step of the run that wrote it, interrupted there);
    // otherwise the end sample (and, with a medium, the bath's second half step) is missing.
    // std::invalid_argument: bad input, the checkpoints stay (src/cli/commands.cpp).
    bool sampled_at_checkpoint = s.step % c.sample_every_steps == 0;
    if (!saved_t_end.empty()) {
      try {  // the run that wrote it ended at the checkpoint's step (interrupted at its last step)
        sampled_at_checkpoint |= std::ceil(std::stod(saved_t_end) / c.dt - 1e-9) == static_cast<double>(s.step);
      } catch (const std::exception&) {
      }
    }
    if (s.step > c.steps || (s.step == c.steps && !sampled_at_checkpoint)) {
      const double t_ck = static_cast<double>(s.step) * c.dt;
      const bool at_end = s.step == c.steps;
      std::string least;  // the shortest printed t_end that reaches the checkpoint's step
      for (int digits = 6; digits <= 17; ++digits) {
        char b[40];
        std::snprintf(b, sizeof b, "%.*g", digits, t_ck);
        least = b;
        if (std::ceil(std::stod(least) / c.dt - 1e-9) >= static_cast<double>(s.step)) break;
      }
      char now[40];
      std::snprintf(now, sizeof now, "%.10g", c.t_end);
      throw std::invalid_argument(
          "--resume: dsmc.t_end = " + std::string(now) +
          (at_end ? " ends at the checkpoint (t = " + least + ", step " + std::to_string(s.step) +
                        "), which is not a sample point: give dsmc.t_end > " + least
                  : " is before the checkpoint (t = " + least + ", step " + std::to_string(s.step) +
                        "): give dsmc.t_end " + (sampled_at_checkpoint ? ">= " : "> ") + least) +
          (saved_t_end.empty() ? std::string()
                               : " (the run that wrote the checkpoint had dsmc.t_end = " + saved_t_end +
                                     ": --set dsmc.t_end=" + saved_t_end + " continues it)") +
          "; the checkpoints in " + ctx.checkpoint_dir.string() + " are kept");
    }
    if (bath_on && s.particles.bath_hazard.size() != s.particles.size())
      throw std::runtime_error("--resume: the checkpoint has no particles/bath_hazard for its " +
                               std::to_string(s.particles.size()) + " grains (written before the carried bath residual)");
    if (s.fields.cells > 0) extend_field_window(s.fields, c);
    if (dec.root()) std::fprintf(stderr, "resuming from step %lld (t = %.6g)\n", static_cast<long long>(s.step), s.step * c.dt);
  } else {
    initialise(s, c, ctx.seed, bath_on, dec);
    if (c.spatial() && c.sample_fields) {
      s.fields.cells = c.domain.cell_count();
      plan_field_window(s.fields, c);
    }
  }
  std::vector<std::uint8_t> removed;
  auto rebuild_cells = [&] {
    if (c.spatial()) {
      removed.clear();
      sort_by_cell(s, c, removed);
    } else {
      s.cell_start = {0, s.particles.size()};
    }
  };
  // MPI: each rank now keeps its own cells' grains (from a checkpoint, each rank has read
  // only its own; from initialise(), each rank made its share of the ids)
  dec.distribute(s, c, resumed);
  if (dec.size() > 1 && c.spatial() && dec.root()) {
    // the cells are dealt out in reduction blocks: with fewer blocks than ranks, some idle
    int idle = 0;
    for (int r = 0; r < dec.size(); ++r) idle += dec.first_cell(r) == dec.end_cell(r);
    if (idle > 0)
      std::fprintf(stderr, "note: %d of %d ranks own no cells (%zu cells in blocks of %zu) and idle; fewer ranks "
                           "would run as fast\n",
                   idle, dec.size(), c.domain.cell_count(), dec.block_cells());
  }
  rebuild_cells();
  std::vector<std::size_t> bounds;
  LocalBathCache local_bath;
  // checkpoints: every rank writes its own grains in turn (no gather: src/dsmc/checkpoint.hpp)
  double checkpoint_seconds = 0.0;  // performance.checkpoint_seconds (docs/performance/mpi.md)
  auto checkpoint = [&] {
    const auto started = std::chrono::steady_clock::now();
    write_checkpoint(ctx.checkpoint_dir, s, ctx, dec);
    checkpoint_seconds += wall_seconds_since(started);
  };
  if (!resumed) sample(s, c, 0.0, dec, bounds);
  s.collisions_before_run = s.counters.bath_collisions + s.counters.grain.collisions;

  std::vector<GrainCounters> per_cell;
  GroupedCollisions grouped;  // homogeneous runs: the step's collision groups
  // stream, sort and collide in one pass over the grains (MPI ranks too: the migration sits
  // between its streaming pass and its scatter, src/dsmc/fused.cpp)
  const bool fused = fused_step_applies(c);
  Progress progress("dsmc", static_cast<double>(c.steps), ctx.quiet || !dec.root());
  std::vector<StreamCounters> walls;
  const bool walls_counted = c.spatial() && !fully_periodic(c.domain);
  // the step's wall exchanges, per block, combined in block order over the ranks
  auto add_wall_counters = [&] {
    dec.combine_in_order(walls, true);
    for (const auto& w : walls) {
      s.counters.wall_energy += w.wall_energy;
      s.counters.removed_energy += w.removed_energy;
      s.counters.removed += w.removed;
    }
  };
  auto last_checkpoint_wall = std::chrono::steady_clock::now();
  const std::int64_t checkpoint_steps =
      c.checkpoint.every > 0 ? std::max<std::int64_t>(1, std::llround(c.checkpoint.every / c.dt)) : 0;
  const auto loop_start = std::chrono::steady_clock::now();
  const double setup_seconds = wall_seconds_since(wall_start);
  // dt and the cells are checked against the collisions of this run's first sample interval
  // (Resolution, src/dsmc/output.hpp), so that a long run warns early; the whole run's
  // figures go to summary.json
  const std::int64_t first_step = s.step;
  const std::uint64_t first_grain_collisions = s.counters.grain.collisions;
  bool resolution_checked = false;
  // Anything added to this loop that moves grains or reorders the arrays between two steps
  // must also set local_bath.step = -1 (LocalBathCache). Anything that changes x or v between
  // two fused steps must also set s.sort.next_cell_step = -1: without a medium the fused step reuses the cells it computed
  // after the previous step's collisions (src/dsmc/fused.cpp, SortScratch::next_cell).
  for (; s.step < c.steps;) {
    if (bath_on) {
      if (s.bath_half_pending)  // the previous step's second half and this step's first half, joined
        bath_substep(s, c, uniform_bath, c.dt, ctx.seed, Stream::background_joined_halves, dec, bounds, local_bath);
      else
        bath_substep(s, c, uniform_bath, 0.5 * c.dt, ctx.seed, Stream::background_first_half, dec, bounds, local_bath);
      s.bath_half_pending = false;
    }
    if (fused) {
      // stream, sort and collide in one pass (MPI: with the migration inside); counters per
      // block of dec.block_cells() cells, combined as grain_step combines them (bitwise the
      // same at any rank count); the wall exchanges as the separate pass gives them
      fused_spatial_step(s, c, ctx.seed, per_cell, dec, bounds, walls);
      if (walls_counted) add_wall_counters();
    } else {
      if (c.spatial()) {
        dec.block_bounds(s, c, bounds);
        stream(s, c, ctx.seed, removed, bounds, walls);
        if (walls_counted) add_wall_counters();
        dec.migrate(s, c, removed);  // MPI: particles that left this rank's cells
        sort_by_cell(s, c, removed);
      }
      grain_step(s, c, ctx.seed, per_cell, dec, grouped);
    }
    if (bath_on) {
      // the second half now only before a sample and at the end; otherwise it is joined to the
      // next step's first half (see the top of this file)
      if (c.sampled_after(s.step + 1))
        bath_substep(s, c, uniform_bath, 0.5 * c.dt, ctx.seed, Stream::background_second_half, dec, bounds, local_bath);
      else
        s.bath_half_pending = true;
    }
    ++s.step;
    s.particle_steps_run += static_cast<double>(s.particles.size());
    if (c.rebalance_every > 0 && s.step % c.rebalance_every == 0) {
      local_bath.step = -1;  // grains may change rank and order
      if (dec.rebalance(s, c)) rebuild_cells();
    }
    if (c.sampled_after(s.step)) {
      try {
        sample(s, c, static_cast<double>(s.step) * c.dt, dec, bounds);
      } catch (const std::runtime_error& e) {
        // NaN/Inf in the sampled moments (seen by every rank alike): keep the state for a
        // post-mortem, then stop
        if (!ctx.checkpoint_dir.empty()) checkpoint();
        throw std::runtime_error(std::string(e.what()) + "; the state was checkpointed to " +
                                 ctx.checkpoint_dir.string());
      }
      if (!resolution_checked && s.step > first_step) {
        resolution_checked = true;
        // the grains present now (open faces let them leave)
        const Resolution res = resolution(c, s.counters.grain.collisions - first_grain_collisions, s.step - first_step,
                                          s.series.count.back(), s.series.T.back());
        if (dec.root())
          for (const auto& w : res.warnings) std::fprintf(stderr, "%swarning: %s\n", ctx.quiet ? "" : "\n", w.c_str());
      }
      // conservation monitors: particle count, momentum per grain, kinetic energy per grain,
      // and the cumulative bath input and inelastic loss per grain
      const TimeSeries& ts = s.series;
      const std::size_t k = ts.t.size() - 1;
      char extra[160];
      std::snprintf(extra, sizeof extra, "t=%.4g N=%.0f T=%.5g |u|=%.3g E=%.5g in=%.4g loss=%.4g", ts.t[k], ts.count[k],
                    ts.T[k], std::sqrt(ts.velocity[3 * k] * ts.velocity[3 * k] + ts.velocity[3 * k + 1] * ts.velocity[3 * k + 1] +
                                       ts.velocity[3 * k + 2] * ts.velocity[3 * k + 2]),
                    ts.ke[k], ts.bath_in[k], ts.loss[k]);
      progress.update(static_cast<double>(s.step), extra);
    }
    // the ranks agree on a stop request and on wall-clock checkpoints (one collective)
    const int raised = dec.any_bits((ctx.stop_requested && ctx.stop_requested->load() ? 1 : 0) |
                                    (c.checkpoint.every_minutes > 0 &&
                                             wall_seconds_since(last_checkpoint_wall) > 60.0 * c.checkpoint.every_minutes
                                         ? 2
                                         : 0));
    const bool stop = raised & 1, due_wall = raised & 2;
    const bool due_sim = checkpoint_steps > 0 && s.step % checkpoint_steps == 0;
    // [checkpoint] keep = true also keeps the end: a longer t_end then continues from there
    // instead of re-running from the last periodic checkpoint (review 2, B5)
    const bool final_kept = c.checkpoint.keep && s.step == c.steps;
    if (!ctx.checkpoint_dir.empty() && (stop || ((due_sim || due_wall) && s.step < c.steps) || final_kept)) {
      checkpoint();
      last_checkpoint_wall = std::chrono::steady_clock::now();
    }
    if (stop) {
      progress.finish();
      throw RunInterrupted("interrupted at step " + std::to_string(s.step) + " (t = " +
                               std::to_string(s.step * c.dt) + "); a checkpoint was written to " +
                               ctx.checkpoint_dir.string() + "; continue with: " +
                               (ctx.resume_command.empty() ? "grainbath run " + ctx.case_dir.string() + " --resume"
                                                           : ctx.resume_command));
    }
  }
  progress.finish();
  const double loop_seconds = wall_seconds_since(loop_start);
  // results: the grains' part is reduced where they are, rank 0 writes the file from sums and
  // per-cell data; a failure there stops every rank with rank 0's message
  const FinalGrains grains = final_grains(c, s, dec);
  const State rest = dec.gather_cells(s);
  std::string error;
  if (dec.root()) {
    try {
      write_results(c, ctx, rest, grains, RunTimes{wall_seconds_since(wall_start), setup_seconds, loop_seconds},
                    summary);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  if (dec.size() == 1 && !error.empty()) throw std::runtime_error(error);
  error = dec.first_error(error);
  if (!error.empty()) throw std::runtime_error("writing the results failed on " + error);
  summary.set("performance.ranks", static_cast<std::int64_t>(dec.size()));
  summary.set("performance.checkpoint_seconds", checkpoint_seconds);  // rank 0's time in writing checkpoints
  summary.set("performance.rank_load_imbalance", dec.imbalance());
  summary.set("performance.rank_rebalances", static_cast<std::int64_t>(dec.rebalances()));
  if (ctx.resume) {  // each rank reads about its share of the checkpoint (docs/performance/mpi.md)
    summary.set("performance.checkpoint_read_bytes_total",
                static_cast<std::int64_t>(dec.sum(static_cast<double>(checkpoint_read_bytes))));
    summary.set("performance.checkpoint_read_bytes_rank_max",
                static_cast<std::int64_t>(dec.max(static_cast<long long>(checkpoint_read_bytes))));
  }
  if (dec.size() > 1 && c.spatial()) {  // migration traffic over all ranks (docs/performance/mpi.md)
    const Decomposition::MigrationStats& m = dec.migration_stats();
    summary.set("performance.migration_steps", static_cast<std::int64_t>(m.steps));
    summary.set("performance.migration_rounds", static_cast<std::int64_t>(dec.sum(static_cast<double>(m.rounds))));
    summary.set("performance.migration_messages", static_cast<std::int64_t>(dec.sum(static_cast<double>(m.messages))));
    summary.set("performance.migration_bytes", static_cast<std::int64_t>(dec.sum(static_cast<double>(m.bytes))));
    summary.set("performance.migration_collectives", static_cast<std::int64_t>(dec.sum(static_cast<double>(m.collectives))));
    summary.set("performance.migrants", static_cast<std::int64_t>(dec.sum(static_cast<double>(m.migrants))));
    summary.set("performance.migration_max_hops", static_cast<std::int64_t>(dec.max(m.max_hops)));
    summary.set("performance.rank_empty_steps", static_cast<std::int64_t>(dec.max(m.empty_steps)));
    summary.set("performance.rank_refills", static_cast<std::int64_t>(dec.max(m.refills)));
    summary.set("performance.rank_peak_particles",
                static_cast<std::int64_t>(dec.max(static_cast<long long>(dec.peak_particles()))));
    // rank 0 against the largest of the others: no gather for output makes them alike
    // (tests/mpi/mpi_output.sh; docs/performance/mpi.md)
    const long long rss = peak_resident_bytes();
    summary.set("performance.rank0_peak_rss_bytes", static_cast<std::int64_t>(dec.max(dec.root() ? rss : 0)));
    summary.set("performance.other_ranks_peak_rss_bytes", static_cast<std::int64_t>(dec.max(dec.root() ? 0 : rss)));
  }
}

}  // namespace grainbath::dsmc
