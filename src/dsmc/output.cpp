#include "dsmc/output.hpp"

#include <omp.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>

#include "core/h5.hpp"
#include "core/run_support.hpp"
#include "core/state_hash.hpp"
#include "dsmc/collision_groups.hpp"
#include "dsmc/decomposition.hpp"
#include "dsmc/mode_fit.hpp"
#include "dsmc/moments.hpp"
#include "dsmc/rough.hpp"
#include "dsmc/spatial.hpp"
#include "dsmc/theory.hpp"
#include "hydro/transport.hpp"

namespace grainbath::dsmc {

namespace {

struct LineFit {
  double slope = NAN, slope_stderr = NAN, intercept = NAN;
  std::size_t points = 0;
};

// Weighted least squares y = a + b x (weights 1/sigma^2; sigma empty: unweighted). The slope
// error is scaled by sqrt(reduced chi^2) when that exceeds 1. (A branch for correlated
// residuals lost its one caller in 1653ada and went with the output audit, 2026-12-06.)
LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& sigma) {
  LineFit f;
  const std::size_t n = x.size();
  f.points = n;
  if (n < 3) return f;
  double S = 0, Sx = 0, Sy = 0, Sxx = 0, Sxy = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double w = sigma.empty() ? 1.0 : 1.0 / (sigma[k] * sigma[k]);
    S += w;
    Sx += w * x[k];
    Sy += w * y[k];
    Sxx += w * x[k] * x[k];
    Sxy += w * x[k] * y[k];
  }
  const double D = S * Sxx - Sx * Sx;
  f.slope = (S * Sxy - Sx * Sy) / D;
  f.intercept = (Sxx * Sy - Sx * Sxy) / D;
  double chi2 = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double res = y[k] - f.intercept - f.slope * x[k];
    const double w = sigma.empty() ? 1.0 : 1.0 / (sigma[k] * sigma[k]);
    chi2 += w * res * res;
  }
  const double red = chi2 / static_cast<double>(n - 2);
  double var = S / D;  // slope variance for known sigmas
  if (sigma.empty()) var *= red;
  else if (red > 1) var *= red;
  f.slope_stderr = std::sqrt(var);
  return f;
}

void write_xdmf(const std::filesystem::path& path, const Domain& d, const std::vector<std::string>& scalars,
                const std::vector<std::string>& vectors) {
  // 3D CoRectMesh: node counts are cells + 1 (z, y, x order in XDMF)
  const int nx = d.cells[0], ny = d.cells[1], nz = d.cells[2];
  std::ofstream o(path);
  o << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"dsmc_fields\" GridType=\"Uniform\">\n";
  o << "   <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << nz + 1 << " " << ny + 1 << " " << nx + 1 << "\"/>\n";
  o << "   <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n";
  o << "    <DataItem Dimensions=\"3\" Format=\"XML\">0 0 0</DataItem>\n";
  o << "    <DataItem Dimensions=\"3\" Format=\"XML\">" << d.length[2] / nz << " " << d.length[1] / ny << " "
    << d.length[0] / nx << "</DataItem>\n   </Geometry>\n";
  for (const auto& s : scalars)
    o << "   <Attribute Name=\"" << s << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n    <DataItem Dimensions=\"" << nz
      << " " << ny << " " << nx << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">results.h5:/fields/" << s
      << "</DataItem>\n   </Attribute>\n";
  for (const auto& v : vectors)
    o << "   <Attribute Name=\"" << v << "\" AttributeType=\"Vector\" Center=\"Cell\">\n    <DataItem Dimensions=\"" << nz
      << " " << ny << " " << nx << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">results.h5:/fields/" << v
      << "</DataItem>\n   </Attribute>\n";
  o << "  </Grid>\n </Domain>\n</Xdmf>\n";
  if (!o) throw std::runtime_error(path.string() + ": cannot write the XDMF file");
}

// summary.json `state.hash` (src/core/state_hash.hpp): every stored per-particle value of the
// final state — positions (none in homogeneous runs), velocities, the bath residual of runs
// with a medium, the spins of rough grains — keyed on the particle id, independent of the
// storage order, so runs that must agree bitwise (threads, ranks, SIMD paths, restarts) can be
// compared to the last bit.
// This process's grains; FinalGrains adds the ranks' partial hashes.
StateHash final_state_hash(const State& s) {
  const Particles& p = s.particles;
  // positions are stored per dimension in use (none for homogeneous runs)
  const std::size_t n = p.size();
  const bool px = p.x.size() == n, py = p.y.size() == n, pz = p.z.size() == n;
  const bool hazard = p.bath_hazard.size() == n, spins = s.wx.size() == n;
  StateHash h;
  double v[10];
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t k = 0;
    if (px) v[k++] = p.x[i];
    if (py) v[k++] = p.y[i];
    if (pz) v[k++] = p.z[i];
    v[k++] = p.vx[i];
    v[k++] = p.vy[i];
    v[k++] = p.vz[i];
    if (hazard) v[k++] = p.bath_hazard[i];
    if (spins) {
      v[k++] = s.wx[i];
      v[k++] = s.wy[i];
      v[k++] = s.wz[i];
    }
    h.add(p.id[i], std::span<const double>(v, k));
  }
  return h;
}


// The fields of one cell from its sums (FieldAccumulator) over `samples` samples: density,
// and, from two grain visits on, mean velocity, pressure tensor, temperature and heat flux.
struct CellField {
  double density = 0.0, temperature = 0.0;
  double velocity[3] = {0, 0, 0}, pressure[6] = {0, 0, 0, 0, 0, 0}, heat_flux[3] = {0, 0, 0};
  bool kinetic = false;  // at least two grain visits: velocity, P, T and q are set
};

CellField cell_field(const double* a, double samples, double weight, double cell_volume, double m) {
  CellField f;
  const double count = a[0];
  if (samples <= 0.0) return f;
  f.density = count * weight / cell_volume / samples;
  if (count < 2) return f;
  f.kinetic = true;
  const double dens = f.density;
  const double* u = f.velocity;
  for (int i = 0; i < 3; ++i) f.velocity[i] = a[1 + i] / count;
  const double vv[6] = {a[4] / count, a[5] / count, a[6] / count, a[7] / count, a[8] / count, a[9] / count};
  const int ij[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
  for (int q = 0; q < 6; ++q) f.pressure[q] = dens * m * (vv[q] - u[ij[q][0]] * u[ij[q][1]]);
  f.temperature = (f.pressure[0] + f.pressure[1] + f.pressure[2]) / (3 * dens);
  const double v2 = a[13] / count, u2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  const double full[3][3] = {{vv[0], vv[3], vv[4]}, {vv[3], vv[1], vv[5]}, {vv[4], vv[5], vv[2]}};
  for (int i = 0; i < 3; ++i) {
    // <|c|^2 c_i> = <|v|^2 v_i> - u_i <|v|^2> - 2 u_j <v_j v_i> + 2 u_i |u|^2
    double ujvv = 0;
    for (int j = 0; j < 3; ++j) ujvv += u[j] * full[j][i];
    const double c3 = a[10 + i] / count - u[i] * v2 - 2 * ujvv + 2 * u[i] * u2;
    f.heat_flux[i] = 0.5 * m * dens * c3;
  }
  return f;
}

// The jackknife standard error of an estimate from the leave-one-batch-out values x_(-b):
// sqrt((B - 1)/B sum (x_(-b) - mean)^2) (Efron 1982, eq. 3.5).
double jackknife_stderr(const std::vector<double>& left_out) {
  const std::size_t B = left_out.size();
  if (B < 2) return NAN;
  double mean = 0;
  for (double x : left_out) mean += x;
  mean /= static_cast<double>(B);
  double ss = 0;
  for (double x : left_out) ss += (x - mean) * (x - mean);
  return std::sqrt(ss * static_cast<double>(B - 1) / static_cast<double>(B));
}

}  // namespace

FinalGrains final_grains(const Config& c, const State& s, const Decomposition& dec) {
  const Particles& p = s.particles;
  const std::size_t n = p.size();  // this rank's grains
  const double m = c.grains.mass;
  FinalGrains g;
  g.moments = dec.moments_in_global_blocks(p, m);
  g.count = static_cast<std::uint64_t>(g.moments.count);
  // ---- final velocity histograms in units of the thermal speed sqrt(T/m): counts per rank,
  // summed over the ranks (integers: exact), then normalised
  const Moments& fin = g.moments;
  const double vth = std::sqrt(fin.temperature / m);
  const int nb = c.histogram_bins;
  const double range = c.histogram_range;
  g.edges.resize(nb + 1);
  g.speed_edges.resize(nb + 1);
  g.components.assign(3 * nb, 0.0);
  g.speed.assign(nb, 0.0);
  for (int k = 0; k <= nb; ++k) {
    g.edges[k] = -range + 2 * range * k / nb;
    g.speed_edges[k] = range * k / nb;
  }
  const double wcomp = nb / (2 * range), wspeed = nb / range;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 cv = (1.0 / vth) * (p.velocity(i) - fin.mean_velocity);
    const double comp[3] = {cv.x, cv.y, cv.z};
    for (int d = 0; d < 3; ++d) {
      const int b = static_cast<int>(std::floor((comp[d] + range) * wcomp));
      if (b >= 0 && b < nb) g.components[d * nb + b] += 1;
    }
    const int bs = static_cast<int>(std::floor(norm(cv) * wspeed));
    if (bs >= 0 && bs < nb) g.speed[bs] += 1;
  }
  dec.sum_counts(g.components);
  dec.sum_counts(g.speed);
  for (auto& h : g.components) h *= wcomp / static_cast<double>(g.count);
  for (auto& h : g.speed) h *= wspeed / static_cast<double>(g.count);
  const StateHash mine = final_state_hash(s);
  StateHash all;
  all.add_partial(dec.sum_wrapping(mine.partial_sum()), dec.sum_wrapping(mine.partial_count()));
  g.hash = all.hex();
  return g;
}

void write_results(const Config& c, const RunContext& ctx, const State& s, const FinalGrains& grains,
                   const RunTimes& times, Summary& summary) {
  const double wall = times.wall;
  const std::uint64_t n = grains.count;
  const double m = c.grains.mass;
  const TimeSeries& ts = s.series;
  const std::size_t samples = ts.t.size();

  // ---- statistics over the steady window
  // Blocked in the collision clock, the collisions per grain (2 per grain-grain collision, 1
  // per bath collision) since the first sample: the velocity distribution relaxes in
  // collisions, so a2 is correlated over a fixed number of them (about 1.5-2 per grain in
  // cases/free-cooling, measured over 32 seeds on 2026-12-05), while in free cooling the
  // collision rate falls as sqrt(T) and samples at equal times get ever more correlated; in a
  // steady state the clock runs at a constant rate and the blocks are those in t.
  std::vector<double> Tw, a2w, clock_w, a3w, a3clock;
  double clock = 0.0;
  for (std::size_t k = 0; k < samples; ++k) {
    if (k > 0 && ts.count[k] > 0)
      clock += (static_cast<double>(ts.bath_collisions[k] - ts.bath_collisions[k - 1]) +
                2.0 * static_cast<double>(ts.grain_collisions[k] - ts.grain_collisions[k - 1])) /
               static_cast<double>(ts.count[k]);
    if (ts.t[k] >= c.steady_from - 1e-12) {
      Tw.push_back(ts.T[k]);
      a2w.push_back(ts.a2[k]);
      clock_w.push_back(clock);
      // a3 (docs/closures.md eq. H2) like a2; NaN in the samples of a run resumed from a
      // checkpoint written before a3 was sampled (dsmc/checkpoint.cpp): those are left out
      if (k < ts.a3.size() && std::isfinite(ts.a3[k])) a3w.push_back(ts.a3[k]), a3clock.push_back(clock);
    }
  }
  const MeanError Tm = block_average(Tw, clock_w), a2m = block_average(a2w, clock_w);
  const MeanError a3m = block_average(a3w, a3clock);
  // A gas that only cools (no medium, no diffuse walls) has no steady temperature: a window
  // mean of its decaying T and a blocked error of that trend describe nothing (the error was
  // 0.026 against a seed-to-seed scatter of the mean of 0.0011 in cases/free-cooling), so
  // temperature.mean/stderr are not written; temperature.final and /timeseries/temperature
  // compare with Haff's law (theory.haff.*).
  // Elastic smooth grains in the same box keep their T: a steady state (rough grains with
  // Walton's rule are counted as cooling, their translational T relaxes even at e = 1).
  bool diffuse_walls = false;
  for (int f = 0; f < 2 * c.domain.dimensions; ++f) diffuse_walls = diffuse_walls || c.domain.faces[f] == Boundary::diffuse;
  const auto* constant = std::get_if<ConstantRestitution>(&c.restitution);
  const auto* power = std::get_if<PowerLawRestitution>(&c.restitution);
  const bool elastic = !c.rough && (std::holds_alternative<ElasticRestitution>(c.restitution) ||
                                    (constant && constant->e == 1.0) || (power && power->beta == 0.0));
  const bool cooling_only = !medium_present(c) && !diffuse_walls && !elastic;
  // a blocked error that did not reach a plateau is unreliable (a lower bound for a series
  // correlated over the window; a drifting series has no steady mean): flagged in summary.json
  // (`*.stderr_plateau`) and said on stderr (the run's log)
  const double span = clock_w.empty() ? 0.0 : clock_w.back() - clock_w.front();
  std::string unchecked;  // the errors too short to judge: one note for all, after the last
  std::size_t unchecked_samples = 0;
  std::string no_error;  // fewer than 2 samples in the window: no error at all (null)
  std::size_t no_error_samples = 0;
  auto warn_no_plateau = [&](const char* key, const MeanError& e) {
    if (e.samples < 2) {
      no_error += (no_error.empty() ? "" : ", ") + std::string(key);
      no_error_samples = e.samples;
      return;
    }
    if (e.plateau || !std::isfinite(e.stderr_)) return;
    if (!e.plateau_judged) {  // too few samples to tell: a note, and no flag in summary.json
      unchecked += (unchecked.empty() ? "" : ", ") + std::string(key);
      unchecked_samples = e.samples;
      return;
    }
    std::fprintf(stderr,
                 "warning: %s = %.3g is unreliable: block averaging over the window (%zu samples, %.3g collisions "
                 "per grain) reached no plateau: the series is correlated over a good part of it (then the "
                 "error is a lower bound) or drifts through it (a transient in the window: see "
                 "sampling.steady_from) "
                 "(%s_plateau = false); take the error from independent replicas: grainbath sweep CASE --set "
                 "run.seed=1,2,...,8\n",
                 key, e.stderr_, e.samples, span, key);
  };
  auto note_unchecked = [&] {
    if (!no_error.empty())
      std::fprintf(stderr,
                   "note: %s: the window holds %zu sample%s: no error bar (sampling.every = %.6g, the window "
                   "t_end - steady_from = %.6g); a sampling.every of at most a sixteenth of the window gives a "
                   "blocked error, replicas give one without: grainbath sweep CASE --set run.seed=1,2,...,8\n",
                   no_error.c_str(), no_error_samples, no_error_samples == 1 ? "" : "s",
                   c.sample_every, c.t_end - c.steady_from);
    if (unchecked.empty()) return;
    std::fprintf(stderr,
                 "note: %s: the window holds %zu samples, too few to check the blocking for a plateau (about 91 "
                 "needed); the errors assume correlations shorter than the longest blocks (%.2g collisions per "
                 "grain). A smaller sampling.every gives more samples; replicas give an error that assumes "
                 "nothing: grainbath sweep CASE --set run.seed=1,2,...,8\n",
                 unchecked.c_str(), unchecked_samples, unchecked_samples >= 16 ? span / 16.0 : span);
  };
  // true / false; absent where the window is too short to tell (MeanError::plateau_judged)
  auto set_plateau = [&](const char* key, const MeanError& e) {
    if (e.plateau_judged) summary.set(key, e.plateau);
  };
  if (!cooling_only) warn_no_plateau("temperature.stderr", Tm);
  warn_no_plateau("a2.stderr", a2m);
  warn_no_plateau("a3.stderr", a3m);
  const Moments& fin = grains.moments;
  const int nb = c.histogram_bins;

  // ---- energy budget: KE(t) - KE(0) = bath + walls - inelastic loss - carried out
  const RunCounters& rc = s.counters;
  const double rot_energy = c.rough ? rotational_energy(s, c) : 0.0;  // rough grains: spins (rough.hpp)
  const double budget_residual = (fin.kinetic_energy + rot_energy - s.initial_kinetic_energy) -
                                 (rc.bath_energy + rc.wall_energy - rc.grain.energy_loss - rc.removed_energy);
  const double budget_scale = std::max({std::abs(s.initial_kinetic_energy), std::abs(rc.bath_energy),
                                        std::abs(rc.grain.energy_loss), std::abs(rc.wall_energy), 1e-300});

  // ---- theory
  const auto theory = theory_values(c);
  std::vector<std::pair<std::string, std::vector<double>>> theory_series;
  if (c.relaxation_theory && !c.spatial() && !c.rough) theory_series = relaxation_series(c, ts.t);
  // rough grains: models A-E (closures/rough) from the first sample, no driving (none of the
  // models has the background medium: only without one)
  if (c.rough && c.relaxation_theory && !c.background.present() && ts.T.front() > 0.0)
    theory_series = rough_model_series(c, ts.t, ts.T.front(), ts.Trot.front());

  H5File f((ctx.out_dir / "results.h5").string(), H5File::Mode::create);
  write_provenance(f, ctx, "dsmc");
  f.write("/timeseries/t", ts.t);
  f.write("/timeseries/temperature", ts.T);
  f.write("/timeseries/a2", ts.a2);
  f.write("/timeseries/a3", ts.a3);
  f.write("/timeseries/velocity", ts.velocity, {samples, 3});
  f.write("/timeseries/pressure_tensor", ts.pressure, {samples, 6});
  f.write("/timeseries/heat_flux", ts.heat_flux, {samples, 3});
  f.write("/timeseries/kinetic_energy_per_grain", ts.ke);
  f.write("/timeseries/bath_energy_input_per_grain", ts.bath_in);
  f.write("/timeseries/inelastic_loss_per_grain", ts.loss);
  f.write("/timeseries/wall_energy_input_per_grain", ts.wall_in);
  f.write("/timeseries/outflow_energy_per_grain", ts.removed_out);
  f.write("/timeseries/particles", ts.count);
  f.write("/timeseries/bath_collisions", ts.bath_collisions);
  f.write("/timeseries/grain_collisions", ts.grain_collisions);
  if (c.rough) f.write("/timeseries/rotational_temperature", ts.Trot);
  f.attribute("/timeseries/pressure_tensor", "components", std::string("xx yy zz xy xz yz"));
  f.attribute("/timeseries", "units",
              std::string("t: time; temperature, rotational_temperature: energy; a2, a3: 1; velocity: sqrt(energy/mass); "
                          "pressure_tensor: energy/length^3; heat_flux: energy sqrt(energy/mass)/length^3; "
                          "*_per_grain: energy per initial grain; particles, bath_collisions, grain_collisions: count"));
  f.write("/histogram/component_edges", grains.edges);
  f.write("/histogram/components", grains.components, {3, static_cast<hsize_t>(nb)});
  f.write("/histogram/speed_edges", grains.speed_edges);
  f.write("/histogram/speed", grains.speed);
  f.attribute("/histogram", "units", std::string("velocities in units of sqrt(T/m) about the mean; densities normalised to 1"));
  f.write_scalar("/histogram/temperature", fin.temperature);
  for (const auto& [name, values] : theory_series) f.write("/theory/" + name, values);

  summary.set("solver", std::string("dsmc"));
  if (!cooling_only) {
    summary.set("temperature.mean", Tm.mean);
    summary.set("temperature.stderr", Tm.stderr_);
    set_plateau("temperature.stderr_plateau", Tm);
  }
  summary.set("temperature.samples", static_cast<std::int64_t>(Tm.samples));
  summary.set("temperature.final", fin.temperature);
  summary.set("a2.mean", a2m.mean);
  summary.set("a2.stderr", a2m.stderr_);
  set_plateau("a2.stderr_plateau", a2m);
  summary.set("a2.final", fin.a2);
  if (a3m.samples > 0) {
    summary.set("a3.mean", a3m.mean);
    summary.set("a3.stderr", a3m.stderr_);
    set_plateau("a3.stderr_plateau", a3m);
  }
  summary.set("a3.final", fin.a3);
  summary.set("velocity.final", norm(fin.mean_velocity - c.background.velocity));
  if (c.rough) {
    // Trot = q m <|a omega|^2> / 3; R = Trot/Ttr over the steady window (blocked) and at the end
    std::vector<double> Rw, Rclock;
    for (std::size_t k = 0, w = 0; k < samples; ++k)
      if (ts.t[k] >= c.steady_from - 1e-12) {
        if (ts.T[k] > 0.0) Rw.push_back(ts.Trot[k] / ts.T[k]), Rclock.push_back(clock_w[w]);
        ++w;
      }
    const MeanError Rm = block_average(Rw, Rclock);
    warn_no_plateau("rotation.R_stderr", Rm);
    summary.set("rotation.R", Rm.mean);
    summary.set("rotation.R_stderr", Rm.stderr_);
    set_plateau("rotation.R_stderr_plateau", Rm);
    summary.set("rotation.Trot_final", ts.Trot.back());
    summary.set("rotation.R_final", ts.Trot.back() / ts.T.back());
    summary.set("rotation.moment_of_inertia_q", c.rough->q);
  }
  note_unchecked();

  // ---- spatial: density mode decay
  if (c.spatial() && !ts.mode_amplitude.empty()) {
    f.write("/mode/t", ts.t);
    f.write("/mode/amplitude", ts.mode_amplitude);
    f.write_scalar("/mode/wavenumber", c.wavenumber());
    // A_k = B exp(-Gamma t_k) + noise by least squares of A itself, with the error from the
    // mode's own correlated fluctuations (src/dsmc/mode_fit.hpp says why: the fit of ln A used
    // until 2026-12-05 was biased by -0.35 % of Gamma and its blocked error was 2-3 times low).
    // The noise of the projection: variance 2/N (that of 2 cos kx for uniform x).
    const double noise_variance = 2.0 / static_cast<double>(c.particles);
    const ModeDecayFit mf = fit_mode_decay(ts.t, ts.mode_amplitude, noise_variance, c.mode_fit_from, c.mode_fit_to);
    // a rate that applies but could not be measured is null in summary.json: say why
    if (!std::isfinite(mf.rate))
      std::fprintf(stderr,
                   "warning: no density-mode decay rate: %zu sample(s) in the fit window [%.4g, %.4g]%s: widen "
                   "sampling.mode_fit_from / mode_fit_to, sample more often (sampling.every) or use more grains\n",
                   mf.points, c.mode_fit_from, c.mode_fit_to,
                   mf.points < 3 ? ", at least 3 needed" : " and the fit of B exp(-Gamma t) did not converge");
    summary.set("mode.decay_rate", mf.rate);
    summary.set("mode.decay_rate_stderr", mf.rate_stderr);
    summary.set("mode.fit_points", static_cast<std::int64_t>(mf.points));
    summary.set("mode.initial_amplitude", ts.mode_amplitude.front());
    f.write_scalar("/mode/decay_rate", mf.rate);
    f.write_scalar("/mode/decay_rate_stderr", mf.rate_stderr);
    f.write_scalar("/mode/fit_intercept", std::log(mf.amplitude));
    f.write("/mode/fit_window", std::vector<double>{c.mode_fit_from, c.mode_fit_to});
  }

  // ---- spatial: per-cell time-averaged fields with batch standard errors
  // Each field is the ratio of the window's totals (the mean of n |v|^2 over the mean of n,
  // and so on), not the mean of per-batch ratios: a batch's temperature subtracts its own
  // mean velocity, estimated from its M grain visits, which biases it by about -T g/M (g the
  // correlation of successive samples), so the old mean over batches depended on how many
  // batches there were (-23 % at 2 grains per cell and the default 16 batches; docs/dsmc.md
  // "Fields"). The window's own estimate keeps -T g/M_window. Standard errors: jackknife
  // over the batches, leaving one out at a time (for the density: the batch-mean spread).
  const FieldAccumulator& fa = s.fields;
  if (c.spatial() && fa.cells > 0 && fa.taken > 0) {
    const std::size_t cells = fa.cells;
    const double weight = c.grains.density * c.domain.volume() / static_cast<double>(c.particles);
    const double vcell = c.domain.cell_volume();
    std::vector<double> nmean(cells, 0), nerr(cells, 0), Tmean(cells, 0), Terr(cells, 0), umean(3 * cells, 0),
        Pmean(6 * cells, 0), qmean(3 * cells, 0);
    std::vector<int> used;  // batches with samples
    double samples = 0;
    for (int b = 0; b < fa.batches; ++b)
      if (fa.batch_samples[b] > 0) {
        used.push_back(b);
        samples += static_cast<double>(fa.batch_samples[b]);
      }
    const int used_batches = static_cast<int>(used.size());
    constexpr int K = FieldAccumulator::kSums;
    std::vector<double> left_n, left_T;
    for (std::size_t k = 0; k < cells; ++k) {
      double total[K] = {};
      for (int b : used) {
        const double* a = fa.sums.data() + (static_cast<std::size_t>(b) * cells + k) * K;
        for (int q = 0; q < K; ++q) total[q] += a[q];
      }
      const CellField whole = cell_field(total, samples, weight, vcell, m);
      nmean[k] = whole.density;
      left_n.clear();
      left_T.clear();
      bool T_err = whole.kinetic;
      for (int b : used) {
        const double* a = fa.sums.data() + (static_cast<std::size_t>(b) * cells + k) * K;
        double rest[K];
        for (int q = 0; q < K; ++q) rest[q] = total[q] - a[q];
        const CellField f = cell_field(rest, samples - static_cast<double>(fa.batch_samples[b]), weight, vcell, m);
        left_n.push_back(f.density);
        if (f.kinetic)
          left_T.push_back(f.temperature);
        else
          T_err = false;
      }
      nerr[k] = jackknife_stderr(left_n);
      if (!whole.kinetic) continue;
      Tmean[k] = whole.temperature;
      Terr[k] = T_err ? jackknife_stderr(left_T) : NAN;
      for (int i = 0; i < 3; ++i) {
        umean[3 * k + i] = whole.velocity[i];
        qmean[3 * k + i] = whole.heat_flux[i];
      }
      for (int q = 0; q < 6; ++q) Pmean[6 * k + q] = whole.pressure[q];
    }
    const hsize_t nx = c.domain.cells[0], ny = c.domain.cells[1], nz = c.domain.cells[2];
    f.write("/fields/density", nmean, {nz, ny, nx});
    f.write("/fields/density_stderr", nerr, {nz, ny, nx});
    f.write("/fields/temperature", Tmean, {nz, ny, nx});
    f.write("/fields/temperature_stderr", Terr, {nz, ny, nx});
    f.write("/fields/velocity", umean, {nz, ny, nx, 3});
    f.write("/fields/pressure_tensor", Pmean, {nz, ny, nx, 6});
    f.write("/fields/heat_flux", qmean, {nz, ny, nx, 3});
    std::vector<double> xc(nx), bgT(cells), bgn(cells);
    for (hsize_t i = 0; i < nx; ++i) xc[i] = (i + 0.5) * c.domain.cell_size(0);
    f.write("/fields/x", xc);
    if (c.domain.dimensions > 1) {
      std::vector<double> yc(ny);
      for (hsize_t i = 0; i < ny; ++i) yc[i] = (i + 0.5) * c.domain.cell_size(1);
      f.write("/fields/y", yc);
    }
    if (c.domain.dimensions > 2) {
      std::vector<double> zc(nz);
      for (hsize_t i = 0; i < nz; ++i) zc[i] = (i + 0.5) * c.domain.cell_size(2);
      f.write("/fields/z", zc);
    }
    for (std::size_t k = 0; k < cells; ++k) {
      const std::size_t ix = k % nx, iy = (k / nx) % ny, iz = k / (nx * ny);
      const double x = (ix + 0.5) * c.domain.cell_size(0), y = (iy + 0.5) * c.domain.cell_size(1),
                   z = (iz + 0.5) * c.domain.cell_size(2);
      const BackgroundState b = local_background(c, x, y, z, static_cast<std::uint32_t>(k));
      const double mB = background_mass(c.background.mass_ratio, m);
      bgT[k] = b.sigma * b.sigma * mB;
      bgn[k] = b.rate_scale * c.background.knudsen;
    }
    f.write("/fields/background_temperature", bgT, {nz, ny, nx});
    f.write("/fields/background_density", bgn, {nz, ny, nx});
    f.attribute("/fields", "window", std::string("time averages over t >= steady_from, standard errors from ") +
                                         std::to_string(used_batches) + " batches");
    f.attribute("/fields", "units", std::string("density: grains per volume; temperature: energy; cell-centred, "
                                                "arrays indexed [z][y][x]"));
    write_xdmf(ctx.out_dir / "fields.xdmf", c.domain,
               {"density", "density_stderr", "temperature", "temperature_stderr", "background_temperature",
                "background_density"},
               {"velocity", "heat_flux"});
    // steady n(x) against TB(x): n ~ TB^-p (isobaric background)
    if (c.field.profile == BackgroundProfile::isobaric_sine) {
      std::vector<double> lx, ly, ls;
      for (std::size_t k = 0; k < cells; ++k)
        if (nmean[k] > 0 && nerr[k] > 0) {
          // ln TB averaged over the cell, not at its centre (which biased p by -0.0013 in
          // cases/thermal-gradient; cell_mean_log_background_temperature)
          lx.push_back(cell_mean_log_background_temperature(c, k));
          ly.push_back(std::log(nmean[k]));
          ls.push_back(nerr[k] / nmean[k]);
        }
      const LineFit lf = fit_line(lx, ly, ls);
      if (!std::isfinite(lf.slope))
        std::fprintf(stderr, "warning: no density-profile exponent: %zu cell(s) with a density and its error, at "
                             "least 3 needed\n", lx.size());
      // The fit's error treats the cells as independent; the slow density modes move them
      // together (slow_mode_error, dsmc/mode_fit.hpp): their part, added in quadrature. The
      // slope is sum_i w_i ln n_i with the least-squares weights w_i; D is the kinetic one
      // averaged over the cells (local nB, TB); the window is the fields' (steady_from on).
      double mode_err = NAN;
      if (std::isfinite(lf.slope)) {
        std::vector<double> xs, ws, rs;
        double S = 0, Sx = 0, nbar = 0, Dsum = 0;
        for (std::size_t k = 0; k < cells; ++k) nbar += nmean[k] / static_cast<double>(cells);
        for (std::size_t i = 0; i < lx.size(); ++i) S += 1.0 / (ls[i] * ls[i]), Sx += lx[i] / (ls[i] * ls[i]);
        const double xbar = Sx / S;
        double Sxx = 0;
        for (std::size_t i = 0; i < lx.size(); ++i) Sxx += (lx[i] - xbar) * (lx[i] - xbar) / (ls[i] * ls[i]);
        for (std::size_t k = 0, i = 0; k < cells; ++k) {
          Dsum += hydro::diffusion_coefficient_kinetic(c.background.mass_ratio, m, bgn[k], bgT[k], c.background.knudsen);
          if (!(nmean[k] > 0 && nerr[k] > 0)) continue;
          xs.push_back((static_cast<double>(k % nx) + 0.5) * c.domain.cell_size(0));
          ws.push_back((lx[i] - xbar) / (ls[i] * ls[i]) / Sxx);
          rs.push_back(nmean[k] / nbar);
          ++i;
        }
        const double window = ts.t.empty() ? 0.0 : ts.t.back() - c.steady_from;
        mode_err = slow_mode_error(xs, ws, rs, c.domain.length[0], c.domain.cell_size(0), static_cast<double>(c.particles),
                                   Dsum / static_cast<double>(cells), window);
      }
      summary.set("profile.exponent", -lf.slope);
      summary.set("profile.exponent_stderr", std::isfinite(mode_err) ? std::hypot(lf.slope_stderr, mode_err) : lf.slope_stderr);
      summary.set("profile.exponent_stderr_fit", lf.slope_stderr);
      summary.set("profile.exponent_stderr_modes", mode_err);
    }
  }

  summary.set("counters.bath_candidates", static_cast<std::int64_t>(rc.bath_candidates));
  summary.set("counters.bath_collisions", static_cast<std::int64_t>(rc.bath_collisions));
  summary.set("counters.grain_candidates", static_cast<std::int64_t>(rc.grain.candidates));
  summary.set("counters.grain_collisions", static_cast<std::int64_t>(rc.grain.collisions));
  summary.set("counters.restitution_clamped", static_cast<std::int64_t>(rc.grain.clamped));
  summary.set("counters.majorant_exceeded", static_cast<std::int64_t>(rc.grain.bound_exceeded));
  summary.set("counters.particles_final", static_cast<std::int64_t>(n));
  summary.set("counters.particles_removed", static_cast<std::int64_t>(rc.removed));
  if (!c.spatial()) {  // homogeneous: the collision groups of every step (0: one cell)
    const auto grains = static_cast<std::size_t>(c.particles), group = static_cast<std::size_t>(c.collision_group);
    summary.set("counters.collision_groups",
                static_cast<std::int64_t>(CollisionGroups::apply(grains, group) ? CollisionGroups::group_count(grains, group) : 0));
  }
  summary.set("state.hash", grains.hash);
  const double per = 1.0 / static_cast<double>(c.particles);
  summary.set("energy.bath_input_per_grain", rc.bath_energy * per);
  summary.set("energy.wall_input_per_grain", rc.wall_energy * per);
  summary.set("energy.inelastic_loss_per_grain", rc.grain.energy_loss * per);
  summary.set("energy.budget_relative_residual", budget_residual / budget_scale);
  summary.set_all("theory", theory);
  // Whether the homogeneous theories (T#, a2, the eps expansion) predict the whole domain's
  // means: not with a background profile or with faces that exchange energy or grains
  // (diffuse, open), whose layers make the gas inhomogeneous (cases/hot-walls: the bulk is
  // T# at its own density, the box mean is not; run-table audit 2026-12-06: "+94 sigma").
  // The run's table and the report give distances in sigma only where it is true.
  bool homogeneous = c.field.profile == BackgroundProfile::uniform;
  if (c.spatial())
    for (const Boundary b : c.domain.faces) homogeneous = homogeneous && b != Boundary::diffuse && b != Boundary::open;
  if (!theory.empty()) summary.set("theory.homogeneous", homogeneous);
  const double collisions = static_cast<double>(rc.bath_collisions + rc.grain.collisions);
  summary.set("performance.wall_seconds", wall);
  // steps advanced by this process (a resumed run counts only its own part)
  summary.set("performance.particle_steps_per_second", s.particle_steps_run / wall);
  summary.set("performance.collisions_per_second", (collisions - static_cast<double>(s.collisions_before_run)) / wall);
  // the step loop alone (RunTimes): the rates to compare with other codes' per-step figures
  summary.set("performance.setup_seconds", times.setup);
  summary.set("performance.loop_seconds", times.loop);
  if (times.loop > 0.0) {
    summary.set("performance.loop_particle_steps_per_second", s.particle_steps_run / times.loop);
    summary.set("performance.loop_collisions_per_second",
                (collisions - static_cast<double>(s.collisions_before_run)) / times.loop);
  }
  summary.set("performance.threads", static_cast<std::int64_t>(omp_get_max_threads()));

  // dt and the cells against the collisions and the mean free path the run itself measured
  // (the grains present, sampled: open faces let them leave)
  double mean_T = 0.0, mean_N = 0.0;
  for (double T : s.series.T) mean_T += T;
  for (double N : s.series.count) mean_N += N;
  if (!s.series.T.empty()) mean_T /= static_cast<double>(s.series.T.size());
  mean_N = s.series.count.empty() ? static_cast<double>(c.particles) : mean_N / static_cast<double>(s.series.count.size());
  const Resolution res = resolution(c, rc.grain.collisions, c.steps, mean_N, mean_T);
  summary.set("resolution.grain_collisions_per_grain_step", res.collisions_per_grain_step);
  if (res.mean_free_path > 0.0) summary.set("resolution.mean_free_path", res.mean_free_path);
  if (c.spatial()) {
    summary.set("resolution.cell_size", res.cell_size);
    summary.set("resolution.travel_per_step_in_cells", res.travel_per_step);
  }
  // (printed by the driver at the first sample, src/dsmc/driver.cpp)
  for (std::size_t k = 0; k < res.warnings.size(); ++k)
    summary.set("resolution.warning_" + std::to_string(k + 1), res.warnings[k]);

  f.close();  // a failed write (disk full) surfaces here, before the output is committed

  if (rc.grain.collisions > 0 && rc.grain.clamped > 1e-4 * rc.grain.collisions)
    std::fprintf(stderr, "warning: the power law gave e < 0 (clamped to 0) in %.3g%% of grain collisions\n",
                 100.0 * rc.grain.clamped / rc.grain.collisions);
  // Bird's bound (`[dsmc] bound = "bird"`) under-samples the pairs a collision lifted over it;
  // the exact bound raises itself (the count is then how often, not a bias)
  if (!c.exact_bound && rc.grain.bound_exceeded > 1e-4 * std::max<std::uint64_t>(1, rc.grain.candidates))
    std::fprintf(stderr,
                 "warning: the grain-collision majorant was exceeded %llu times (Bird's bound under-samples those "
                 "pairs until drawn; [dsmc] bound = \"exact\" keeps the rate exact)\n",
                 static_cast<unsigned long long>(rc.grain.bound_exceeded));
  if (std::abs(budget_residual / budget_scale) > 1e-8)
    std::fprintf(stderr, "warning: the energy budget does not close: relative residual %.3g\n",
                 budget_residual / budget_scale);
}

Resolution resolution(const Config& c, std::uint64_t grain_collisions, std::int64_t steps, double grains,
                      double temperature) {
  Resolution r;
  if (steps <= 0 || grains <= 0.0) return r;
  // a collision involves two grains
  r.collisions_per_grain_step = 2.0 * static_cast<double>(grain_collisions) / (grains * static_cast<double>(steps));
  r.mean_speed = temperature > 0.0 ? std::sqrt(8.0 * temperature / (std::numbers::pi * c.grains.mass)) : 0.0;
  const double rate = r.collisions_per_grain_step / c.dt;  // per grain and unit time
  if (rate > 0.0) r.mean_free_path = r.mean_speed / rate;
  char b[400];
  // NTC's candidates follow each other within a step; at more than about one collision per
  // grain per step the splitting with streaming and the medium (Strang) is no longer resolved
  constexpr double kMaxCollisions = 0.5;
  if (r.collisions_per_grain_step > kMaxCollisions) {
    std::snprintf(b, sizeof b,
                  "dsmc.dt = %.4g: each grain took part in %.3g grain-grain collisions per step (more than %.1g); the "
                  "time step does not resolve them and results depend on dt: use dt <= %.3g (0.2 collisions per step)",
                  c.dt, r.collisions_per_grain_step, kMaxCollisions, c.dt * 0.2 / r.collisions_per_grain_step);
    r.warnings.push_back(b);
  }
  if (c.spatial()) {
    for (int a = 0; a < c.domain.dimensions; ++a) r.cell_size = std::max(r.cell_size, c.domain.cell_size(a));
    r.travel_per_step = r.mean_speed * c.dt / r.cell_size;
    // collision partners are drawn in a cell: it must be smaller than the distance between
    // collisions, and a grain should not cross it in one step
    if (r.mean_free_path > 0.0 && r.cell_size > r.mean_free_path) {
      std::snprintf(b, sizeof b,
                    "domain.cells: the largest cell side, %.4g, exceeds the grains' mean free path, %.4g (mean speed "
                    "%.4g over the measured collision rate); collision partners are drawn from too far apart: use "
                    "cells smaller than the mean free path",
                    r.cell_size, r.mean_free_path, r.mean_speed);
      r.warnings.push_back(b);
    }
    if (r.travel_per_step > 1.0) {
      std::snprintf(b, sizeof b,
                    "dsmc.dt = %.4g: a grain at the mean speed %.4g crosses %.3g cells per step; use dt <= %.3g (half a "
                    "cell per step)",
                    c.dt, r.mean_speed, r.travel_per_step, 0.5 * r.cell_size / r.mean_speed);
      r.warnings.push_back(b);
    }
  }
  return r;
}

}  // namespace grainbath::dsmc
