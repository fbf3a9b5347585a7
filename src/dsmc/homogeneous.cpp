// Homogeneous DSMC driver: one spatial cell holding all grains.
//
// Time step (Strang splitting of the two collision operators, second order in dt):
//   background collisions over dt/2  ->  grain-grain collisions over dt  ->  background dt/2.
// The background substeps are exact in distribution for each grain (thinning with a
// per-grain majorant, operators/background.hpp); grain-grain collisions use NTC.
// Every random number is keyed on (seed, stream; particle or cell id, step), so a run is a
// pure function of (case, seed), independent of the thread count, and a restart from a
// checkpoint at step k continues bitwise.
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "core/h5.hpp"
#include "core/run_support.hpp"
#include "dsmc/collide.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/moments.hpp"
#include "dsmc/theory.hpp"

namespace grainbath::dsmc {

Config read_config(CaseReader& r) {
  Config c;
  c.grains.density = r.real("grains", "density", 1.0, Bounds::positive(), "grains per volume");
  c.grains.mass = r.real("grains", "mass", 1.0, Bounds::positive(), "mass");
  c.grains.temperature = r.real("grains", "temperature", 1.0, Bounds::positive(), "energy");
  c.grains.drift = r.vec3("grains", "drift", {});
  c.background = read_background(r);
  c.restitution = read_restitution(r);
  c.particles = r.integer("dsmc", "particles", 100000, 2, 2'000'000'000);
  c.dt = r.real("dsmc", "dt", 0.01, Bounds::positive(), "time");
  c.t_end = r.real("dsmc", "t_end", 10.0, Bounds::positive(), "time");
  c.sample_every = r.real("sampling", "every", c.dt * 10, Bounds::positive(), "time");
  c.steady_from = r.real("sampling", "steady_from", 0.5 * c.t_end, Bounds::non_negative(), "time");
  c.histogram_bins = static_cast<int>(r.integer("sampling", "histogram_bins", 100, 4, 100000));
  c.histogram_range = r.real("sampling", "histogram_range", 6.0, Bounds::positive(), "thermal speeds");
  c.relaxation_theory = r.boolean("sampling", "relaxation_theory", true);
  if (c.dt > c.t_end) r.problem("dsmc", "dt", "expected dt <= t_end");
  c.steps = static_cast<std::int64_t>(std::ceil(c.t_end / c.dt - 1e-9));
  c.sample_every_steps = std::max<std::int64_t>(1, std::llround(c.sample_every / c.dt));
  if (c.steady_from >= c.t_end)
    r.problem("sampling", "steady_from", "expected a time before t_end, so the averaging window is not empty");
  if (c.steps > 2'000'000'000) r.problem("dsmc", "dt", "t_end / dt is more than 2e9 steps");
  return c;
}

namespace {

// Initial state: Maxwellian velocities at the case's temperature and drift, each grain
// from its own counter-based stream, then shifted and scaled so that the sample mean and
// temperature are exactly the requested ones (removes O(N^-1/2) noise from t = 0).
void initialise(Particles& p, const Config& c, std::uint64_t seed) {
  const std::size_t n = static_cast<std::size_t>(c.particles);
  p.resize(n, false);
  const double s = std::sqrt(c.grains.temperature / c.grains.mass);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = i;
    CounterRng rng(seed, Stream::initial_velocities, i, 0);
    p.set_velocity(i, s * rng.normal3());
  }
  const Moments m = measure_moments(p, 0, n, c.grains.mass);
  const double scale = std::sqrt(c.grains.temperature / m.temperature);
  for (std::size_t i = 0; i < n; ++i)
    p.set_velocity(i, scale * (p.velocity(i) - m.mean_velocity) + c.grains.drift);
}

struct BathTotals {
  std::uint64_t candidates = 0, collisions = 0;
  double energy_gain = 0;
};

// Background substep for every grain, in fixed blocks (deterministic reduction).
BathTotals bath_substep(Particles& p, const BackgroundState& b, double mass, double duration,
                        std::uint64_t seed, Stream stream, std::uint64_t step) {
  constexpr std::size_t kBlock = 4096;
  const std::size_t n = p.size();
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<BackgroundCounters> partial(blocks);
#pragma omp parallel for schedule(dynamic, 4)
  for (std::size_t blk = 0; blk < blocks; ++blk) {
    BackgroundCounters cnt;
    const std::size_t lo = blk * kBlock, hi = std::min(n, lo + kBlock);
    for (std::size_t i = lo; i < hi; ++i) {
      CounterRng rng(seed, stream, p.id[i], step);
      Vec3 v = p.velocity(i);
      evolve_in_background(v, b, mass, duration, rng, cnt);
      p.set_velocity(i, v);
    }
    partial[blk] = cnt;
  }
  BathTotals t;
  for (const auto& c : partial) {
    t.candidates += c.candidates;
    t.collisions += c.collisions;
    t.energy_gain += c.energy_gain;
  }
  return t;
}

struct Series {
  std::vector<double> t, T, a2, ux, uy, uz, ke, energy_in, energy_loss;
  std::vector<double> pressure;  // 6 per sample
  std::vector<double> heat_flux; // 3 per sample
  std::vector<std::uint64_t> bath_collisions, grain_collisions;
};


}  // namespace

void run(const Config& c, const RunContext& ctx, Summary& summary) {
  const auto wall_start = std::chrono::steady_clock::now();
  if (ctx.threads > 0) omp_set_num_threads(ctx.threads);
  const double m = c.grains.mass;
  const std::size_t n = static_cast<std::size_t>(c.particles);
  Particles p;
  initialise(p, c, ctx.seed);

  const BackgroundParameters& bg = c.background;
  const BackgroundState bath =
      BackgroundState::make(bg.density, bg.knudsen, bg.velocity, bg.temperature, bg.mass_ratio, m);

  Series s;
  BathTotals bath_total;
  GrainCounters grain_total;
  double remainder = 0.0;
  auto sample = [&](double t) {
    const Moments mo = measure_moments(p, 0, n, m);
    s.t.push_back(t);
    s.T.push_back(mo.temperature);
    s.a2.push_back(mo.a2);
    s.ux.push_back(mo.mean_velocity.x);
    s.uy.push_back(mo.mean_velocity.y);
    s.uz.push_back(mo.mean_velocity.z);
    s.ke.push_back(mo.kinetic_energy / mo.count);
    s.energy_in.push_back(bath_total.energy_gain / mo.count);
    s.energy_loss.push_back(grain_total.energy_loss / mo.count);
    for (double x : mo.pressure) s.pressure.push_back(c.grains.density * x);
    s.heat_flux.push_back(c.grains.density * mo.heat_flux.x);
    s.heat_flux.push_back(c.grains.density * mo.heat_flux.y);
    s.heat_flux.push_back(c.grains.density * mo.heat_flux.z);
    s.bath_collisions.push_back(bath_total.collisions);
    s.grain_collisions.push_back(grain_total.collisions);
    if (!std::isfinite(mo.temperature) || !std::isfinite(mo.a2))
      throw std::runtime_error("non-finite temperature or a2 at t = " + std::to_string(t) +
                               ": the time step is probably far too large");
  };
  const double initial_ke = measure_moments(p, 0, n, m).kinetic_energy;
  sample(0.0);

  Progress progress("dsmc", static_cast<double>(c.steps), ctx.quiet);
  for (std::int64_t step = 0; step < c.steps; ++step) {
    const auto ustep = static_cast<std::uint64_t>(step);
    if (bg.present()) {
      const BathTotals b1 = bath_substep(p, bath, m, 0.5 * c.dt, ctx.seed, Stream::background_first_half, ustep);
      bath_total.candidates += b1.candidates;
      bath_total.collisions += b1.collisions;
      bath_total.energy_gain += b1.energy_gain;
    }
    {
      CounterRng rng(ctx.seed, Stream::grain_collisions, /*cell*/ 0, ustep);
      GrainCounters gc;
      std::visit([&](const auto& law) { collide_cell(p, 0, n, c.grains.density, c.dt, m, law, rng, remainder, gc); },
                 c.restitution);
      grain_total.add(gc);
    }
    if (bg.present()) {
      const BathTotals b2 = bath_substep(p, bath, m, 0.5 * c.dt, ctx.seed, Stream::background_second_half, ustep);
      bath_total.candidates += b2.candidates;
      bath_total.collisions += b2.collisions;
      bath_total.energy_gain += b2.energy_gain;
    }
    if ((step + 1) % c.sample_every_steps == 0 || step + 1 == c.steps) {
      sample(static_cast<double>(step + 1) * c.dt);
      char extra[96];
      std::snprintf(extra, sizeof extra, "t=%.4g T=%.5g", s.t.back(), s.T.back());
      progress.update(static_cast<double>(step + 1), extra);
    }
    if (ctx.stop_requested && ctx.stop_requested->load())
      throw std::runtime_error("interrupted at step " + std::to_string(step + 1));
  }
  progress.finish();
  const double wall = wall_seconds_since(wall_start);

  // ---- statistics over the steady window
  std::vector<double> Tw, a2w;
  for (std::size_t k = 0; k < s.t.size(); ++k)
    if (s.t[k] >= c.steady_from) {
      Tw.push_back(s.T[k]);
      a2w.push_back(s.a2[k]);
    }
  const MeanError Tm = block_average(Tw), a2m = block_average(a2w);

  // ---- final velocity histograms in units of the thermal speed sqrt(T/m)
  const Moments fin = measure_moments(p, 0, n, m);
  const double vth = std::sqrt(fin.temperature / m);
  const int nb = c.histogram_bins;
  const double range = c.histogram_range;
  std::vector<double> edges(nb + 1), hist_comp(3 * nb, 0.0), hist_speed(nb, 0.0), speed_edges(nb + 1);
  for (int k = 0; k <= nb; ++k) {
    edges[k] = -range + 2 * range * k / nb;
    speed_edges[k] = range * k / nb;
  }
  const double wcomp = nb / (2 * range), wspeed = nb / range;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 cvec = (1.0 / vth) * (p.velocity(i) - fin.mean_velocity);
    const double comp[3] = {cvec.x, cvec.y, cvec.z};
    for (int d = 0; d < 3; ++d) {
      const int b = static_cast<int>(std::floor((comp[d] + range) * wcomp));
      if (b >= 0 && b < nb) hist_comp[d * nb + b] += 1;
    }
    const int bs = static_cast<int>(std::floor(norm(cvec) * wspeed));
    if (bs >= 0 && bs < nb) hist_speed[bs] += 1;
  }
  // normalise to probability densities
  for (auto& h : hist_comp) h *= wcomp / static_cast<double>(n);
  for (auto& h : hist_speed) h *= wspeed / static_cast<double>(n);

  // ---- energy budget: KE(t) - KE(0) = bath input - inelastic loss (Issue #8 monitor)
  const double budget_residual = (fin.kinetic_energy - initial_ke) - (bath_total.energy_gain - grain_total.energy_loss);
  const double budget_scale = std::max({std::abs(initial_ke), std::abs(bath_total.energy_gain),
                                        std::abs(grain_total.energy_loss), 1e-300});

  // ---- theory on the same parameters
  const auto theory = theory_values(c);
  std::vector<std::pair<std::string, std::vector<double>>> theory_series;
  if (c.relaxation_theory) theory_series = relaxation_series(c, s.t);

  // ---- results.h5
  {
    H5File f((ctx.out_dir / "results.h5").string(), H5File::Mode::create);
    write_provenance(f, ctx, "dsmc");
    f.write("/timeseries/t", s.t);
    f.write("/timeseries/temperature", s.T);
    f.write("/timeseries/a2", s.a2);
    f.write("/timeseries/velocity", [&] {
      std::vector<double> v;
      for (std::size_t k = 0; k < s.t.size(); ++k) {
        v.push_back(s.ux[k]);
        v.push_back(s.uy[k]);
        v.push_back(s.uz[k]);
      }
      return v;
    }(), {s.t.size(), 3});
    f.write("/timeseries/pressure_tensor", s.pressure, {s.t.size(), 6});
    f.write("/timeseries/heat_flux", s.heat_flux, {s.t.size(), 3});
    f.write("/timeseries/kinetic_energy_per_grain", s.ke);
    f.write("/timeseries/bath_energy_input_per_grain", s.energy_in);
    f.write("/timeseries/inelastic_loss_per_grain", s.energy_loss);
    f.write("/timeseries/bath_collisions", s.bath_collisions);
    f.write("/timeseries/grain_collisions", s.grain_collisions);
    f.attribute("/timeseries/pressure_tensor", "components", std::string("xx yy zz xy xz yz"));
    f.attribute("/timeseries", "units", std::string("t: time; temperature: energy; velocity: sqrt(energy/mass)"));
    f.write("/histogram/component_edges", edges);
    f.write("/histogram/components", hist_comp, {3, static_cast<hsize_t>(nb)});
    f.write("/histogram/speed_edges", speed_edges);
    f.write("/histogram/speed", hist_speed);
    f.attribute("/histogram", "units", std::string("velocities in units of sqrt(T/m) about the mean; densities normalised to 1"));
    f.write_scalar("/histogram/temperature", fin.temperature);
    for (const auto& [name, values] : theory_series) f.write("/theory/" + name, values);
  }

  // ---- summary.json
  summary.set("solver", std::string("dsmc"));
  summary.set("temperature.mean", Tm.mean);
  summary.set("temperature.stderr", Tm.stderr_);
  summary.set("temperature.samples", static_cast<std::int64_t>(Tm.samples));
  summary.set("temperature.final", fin.temperature);
  summary.set("a2.mean", a2m.mean);
  summary.set("a2.stderr", a2m.stderr_);
  summary.set("a2.final", fin.a2);
  summary.set("velocity.final", norm(fin.mean_velocity - bg.velocity));
  summary.set("counters.bath_candidates", static_cast<std::int64_t>(bath_total.candidates));
  summary.set("counters.bath_collisions", static_cast<std::int64_t>(bath_total.collisions));
  summary.set("counters.grain_candidates", static_cast<std::int64_t>(grain_total.candidates));
  summary.set("counters.grain_collisions", static_cast<std::int64_t>(grain_total.collisions));
  summary.set("counters.restitution_clamped", static_cast<std::int64_t>(grain_total.clamped));
  summary.set("counters.majorant_exceeded", static_cast<std::int64_t>(grain_total.bound_exceeded));
  summary.set("energy.bath_input_per_grain", bath_total.energy_gain / n);
  summary.set("energy.inelastic_loss_per_grain", grain_total.energy_loss / n);
  summary.set("energy.budget_relative_residual", budget_residual / budget_scale);
  summary.set_all("theory", theory);
  const double collisions = static_cast<double>(bath_total.collisions + grain_total.collisions);
  summary.set("performance.wall_seconds", wall);
  summary.set("performance.particle_steps_per_second", static_cast<double>(n) * c.steps / wall);
  summary.set("performance.collisions_per_second", collisions / wall);
  summary.set("performance.threads", static_cast<std::int64_t>(omp_get_max_threads()));

  if (grain_total.collisions > 0 && grain_total.clamped > 1e-4 * grain_total.collisions)
    std::fprintf(stderr, "warning: the power law gave e < 0 (clamped to 0) in %.3g%% of grain collisions\n",
                 100.0 * grain_total.clamped / grain_total.collisions);
  if (grain_total.bound_exceeded > 1e-4 * std::max<std::uint64_t>(1, grain_total.candidates))
    std::fprintf(stderr, "warning: the grain-collision majorant was exceeded %llu times\n",
                 static_cast<unsigned long long>(grain_total.bound_exceeded));
}

}  // namespace grainbath::dsmc
