// EDMD driver: case keys -> Config, the run loop with its measurements, results.h5 and
// summary.json, the theory values and the model list.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <omp.h>

#include "closures/closures.hpp"
#include "closures/rough.hpp"
#include "core/h5.hpp"
#include "core/run_support.hpp"
#include "core/state_hash.hpp"
#include "edmd/checkpoint.hpp"
#include "edmd/edmd.hpp"
#include "edmd/measure.hpp"
#include "edmd/profile.hpp"
#include "edmd/theory.hpp"
#include "edmd/transport.hpp"

namespace grainbath::edmd {

namespace {
inline double& comp(Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
}  // namespace

double Config::box_length() const {
  const double n = theory::number_density(dims, packing_fraction);
  return std::pow(static_cast<double>(particles) / n, 1.0 / dims);
}

Vec3 Config::box() const {
  // edges proportional to `aspect`, volume N/n
  const double a[3] = {aspect.x, aspect.y, dims == 3 ? aspect.z : 1.0};
  double prod = 1.0;
  for (int d = 0; d < dims; ++d) prod *= a[d];
  const double s = box_length() / std::pow(prod, 1.0 / dims);
  return {s * a[0], s * a[1], dims == 3 ? s * a[2] : 1.0};
}

namespace {
// Lattice sites per direction for the start: about proportional to the edges, product >= N.
std::array<int, 3> lattice_counts(const Config& c) {
  const Vec3 L = c.box();
  const double l[3] = {L.x, L.y, L.z};
  const double a0 = c.box_length() / std::pow(static_cast<double>(c.particles), 1.0 / c.dims);
  std::array<int, 3> n{1, 1, 1};
  for (int d = 0; d < c.dims; ++d) n[d] = std::max(1, static_cast<int>(std::ceil(l[d] / a0 - 1e-9)));
  auto product = [&]() { return static_cast<double>(n[0]) * n[1] * n[2]; };
  while (product() < static_cast<double>(c.particles)) {
    int best = 0;
    for (int d = 1; d < c.dims; ++d)
      if (l[d] / n[d] > l[best] / n[best]) best = d;
    ++n[best];
  }
  return n;
}
double lattice_spacing(const Config& c) {
  const auto n = lattice_counts(c);
  const Vec3 L = c.box();
  const double l[3] = {L.x, L.y, L.z};
  double a = 1e300;
  for (int d = 0; d < c.dims; ++d) a = std::min(a, l[d] / n[d]);
  return a;
}
}  // namespace

const std::vector<ModelDescription>& edmd_models() {
  static const std::vector<ModelDescription> models = {
      {"heating", "none", "No driving: elastic equilibrium or free cooling (Haff's law)", {}},
      {"heating", "white_noise",
       "Bizon Sec. III A, eqs. 20-21: at every grain collision, `rate` pairs of random grains get opposite kicks of size `kick` "
       "in a random direction (momentum conserved)",
       {"rate (1, integer >= 1): kicked pairs per collision (r_v)", "kick (required, > 0, velocity): |dv| of each kick"}},
      {"heating", "air_table",
       "Bizon Sec. III B, eq. 22: every grain accelerates uniformly between collisions (|a| = `acceleration`), paired grains "
       "have opposite accelerations; at every collision `rate` grains get a new random direction (partner: the opposite)",
       {"rate (1, integer >= 1): accelerations redrawn per collision (r_a)",
        "acceleration (required, > 0, velocity/time): a0",
        "profile (uniform | tent | shear): Bizon Sec. V; tent = eq. 34, |a| = a0 (1 - |z - L/2|/(L/2)) at the redrawn "
        "grain; shear = eqs. 35-36, a = a0 (psi + bias sin(2 pi z/L) e_component), psi standard Gaussian",
        "axis (y, x | y | z): z of eqs. 34-36 (periodic)", "bias (0.01, > 0): eq. 35 amplitude (shear)",
        "component (x, or y if axis = x): the biased component (shear)"}},
      {"transport", "slabs",
       "[transport] slabs = S: Bizon Sec. V bookkeeping through S slab planes along the heating axis: exact per-slab "
       "energy / momentum balances, kinetic + collisional fluxes, kappa (tent) or mu (shear) vs Enskog",
       {"slabs (32, integer >= 4)", "fit_inner (0.2), fit_outer (0.8): planes whose distance from z = L/2, in L/2, "
        "lies between them give the summary kappa/kappa_Enskog (tent)"}},
      {"heating", "boltzmann",
       "Bizon Sec. III C: at every collision `rate` random grains get a new velocity drawn from a Maxwellian at `temperature`",
       {"rate (1, integer >= 1): thermalised grains per collision (r_b)", "temperature (1, > 0, energy): bath temperature"}},
      {"background", "medium",
       "Bisi-Spiga background medium as Poisson-timed events (same operator as DSMC; 2D variant for disks, docs/edmd.md)",
       {"density (0, >= 0): nB", "knudsen (1, > 0): eps; rate per unit relative speed K = nB/eps", "temperature (1, > 0)",
        "mass_ratio (0.5, (0, 1)): alpha", "velocity ([0,0,0]): uB"}},
      {"boundary", "walls",
       "[walls] directions = [\"x\", ...]: flat hard walls at 0 and L (centres kept sigma/2 away); others periodic",
       {"directions ([], subset of x, y, z)", "restitution (1, (0, 1]): wall restitution",
        "driving_speed (0, >= 0, velocity): v_dr of both walls: a grain leaves with normal speed alpha_w |v_n| + v_dr",
        "driving_speed_low / driving_speed_high (driving_speed): per wall (at 0 / at L)",
        "restitution_low / restitution_high (restitution): per wall"}},
      {"profiles", "slabs",
       "[profiles] slabs = S: slab profiles of density, T components, full stress tensor and heat flux (kinetic + "
       "collisional), loss rate, velocity histograms per slab",
       {"slabs (20, integer >= 1)", "axis (the wall direction, else x)", "velocity_bins (400)",
        "velocity_range (12, in sqrt(T) at the start of the measurement)"}},
  };
  return models;
}

Config read_config(CaseReader& r) {
  Config c;
  name_other_solver_keys(r, "edmd");
  c.dims = static_cast<int>(r.integer("edmd", "dimensions", 3, 2, 3));
  c.particles = r.integer("edmd", "particles", 1000, 2, std::int64_t{1} << 31);
  c.packing_fraction = r.real_required("edmd", "packing_fraction", Bounds::open(0.0, 1.0), "nu (2D) or phi (3D)");
  c.temperature = r.real("edmd", "temperature", 1.0, Bounds::positive(), "energy");
  c.equilibrate = r.real("edmd", "equilibrate", 50.0, Bounds::non_negative(), "collisions per particle");
  c.collisions = r.real("edmd", "collisions", 200.0, Bounds::positive(), "collisions per particle");
  c.initial = r.choice("edmd", "initial", "lattice", {"lattice"});
  {
    const auto asp = r.reals("edmd", "aspect", std::vector<double>(c.dims, 1.0), c.dims, c.dims, Bounds::positive());
    if (asp.size() == static_cast<std::size_t>(c.dims)) c.aspect = {asp[0], asp[1], c.dims == 3 ? asp[2] : 1.0};
  }
  if (names_walton(r)) {
    c.rough = read_rough(r, c.dims == 2 ? 0.5 : 0.4, "edmd");  // default q: the grain the engine moves
  } else {
    c.restitution = read_restitution(r, "edmd");
  }
  const bool inelastic_constant = std::holds_alternative<ConstantRestitution>(c.restitution) ||
                                  std::holds_alternative<PowerLawRestitution>(c.restitution) || c.rough.has_value();
  c.contact_time = r.real("edmd", "contact_time", inelastic_constant ? 1e-6 : 0.0, Bounds::non_negative(), "time");
  // the guard against inelastic collapse has nothing to guard with elastic grains: a note, not
  // an error (a sweep may switch the law to "elastic" with --set)
  if (!c.rough && std::holds_alternative<ElasticRestitution>(c.restitution) && r.has("edmd", "contact_time"))
    r.ignore("edmd", "contact_time", "no effect: elastic grains cannot collapse (the TC guard acts on inelastic laws)");
  const double cp = theory::close_packing(c.dims);
  if (c.packing_fraction >= cp) {
    std::ostringstream m;
    m << "packing fraction " << c.packing_fraction << " is at or above close packing " << cp << " for "
      << (c.dims == 2 ? "disks" : "spheres");
    r.problem("edmd", "packing_fraction", m.str());
  } else {
    const double lattice_max = c.dims == 2 ? std::numbers::pi / 4.0 : std::numbers::pi / 6.0;
    // lattice start: sites of spacing L_d / n_d (n_d sites along d, product >= N) must be >= sigma
    const double spacing = lattice_spacing(c);
    if (spacing < 1.0) {
      // the spacing scales as packing^(-1/D): the largest packing this N starts at (review 4:
      // the message said neither what was expected nor what was found)
      const double most = c.packing_fraction * std::pow(spacing, c.dims);
      std::ostringstream m;
      m << "expected packing_fraction <= " << most << " for " << c.particles << " grains, found " << c.packing_fraction
        << ": the grains start on a " << (c.dims == 2 ? "square" : "simple cubic") << " lattice, whose spacing would be "
        << spacing << " sigma (they would overlap); the lattice holds up to " << lattice_max << " with N = k^" << c.dims;
      r.problem("edmd", "packing_fraction", m.str());
    }
  }
  // walls
  const auto dirs = r.texts("walls", "directions", {});
  for (const auto& d : dirs) {
    const int k = d == "x" ? 0 : d == "y" ? 1 : d == "z" ? 2 : -1;
    if (k < 0) r.problem("walls", "directions", "unknown direction '" + d + "'; expected x, y or z");
    else if (k >= c.dims) r.problem("walls", "directions", "a wall in " + d + " cuts a 2D box (disks move in x, y)");
    else if (c.walls[k]) r.problem("walls", "directions", "direction " + d + " given twice");
    else c.walls[k] = true;
  }
  c.wall_restitution = r.real("walls", "restitution", 1.0, Bounds::half_open(0.0, 1.0));
  c.wall_restitution_side[0] = r.real("walls", "restitution_low", c.wall_restitution, Bounds::half_open(0.0, 1.0));
  c.wall_restitution_side[1] = r.real("walls", "restitution_high", c.wall_restitution, Bounds::half_open(0.0, 1.0));
  {
    const double both = r.real("walls", "driving_speed", 0.0, Bounds::non_negative(), "velocity");
    c.wall_driving[0] = r.real("walls", "driving_speed_low", both, Bounds::non_negative(), "velocity");
    c.wall_driving[1] = r.real("walls", "driving_speed_high", both, Bounds::non_negative(), "velocity");
    if (r.has("walls", "driving_speed") && (r.has("walls", "driving_speed_low") || r.has("walls", "driving_speed_high")))
      r.problem("walls", "driving_speed", "give either driving_speed (both walls) or driving_speed_low/_high, not both");
  }
  const int n_wall_dirs = static_cast<int>(c.walls[0]) + c.walls[1] + c.walls[2];
  if (c.driving_walls() && n_wall_dirs != 1) {
    // named by a key the case gives, with its line: a per-wall restitution alone also makes
    // driving walls (until 2026-12-06 the error named walls.driving_speed, without a line,
    // whichever key it was; mutation audit of the EDMD reader)
    const char* key = "driving_speed";
    for (const char* k : {"driving_speed", "driving_speed_low", "driving_speed_high", "restitution_low", "restitution_high"})
      if (r.has("walls", k)) {
        key = k;
        break;
      }
    r.problem("walls", key,
              "driving walls (or per-wall restitution) need exactly one wall direction in [walls] directions, found " +
                  std::to_string(n_wall_dirs));
  }
  if (n_wall_dirs == 0 && !c.driving_walls())  // (driving walls without a direction: the error above)
    for (const char* key : {"restitution", "restitution_low", "restitution_high", "driving_speed", "driving_speed_low",
                            "driving_speed_high"})
      if (r.has("walls", key))
        r.problem("walls", key,
                  "there are no walls to apply it to: [walls] directions is " +
                      std::string(r.has("walls", "directions") ? "empty" : "not given") +
                      " (every direction periodic); add directions = [\"x\"] (or y, z) or remove the key");
  {
    const Vec3 b = c.box();
    const double e[3] = {b.x, b.y, b.z};
    for (int d = 0; d < c.dims; ++d)
      if (e[d] < 3.0) {
        std::ostringstream m;
        m << "the box edge in " << "xyz"[d] << " is " << e[d] << " < 3 sigma; use more particles or change [edmd] aspect";
        r.problem("edmd", c.box_length() < 3.0 ? "particles" : "aspect", m.str());
      }
  }
  // heating
  const std::string model = r.choice("heating", "model", "none", {"none", "white_noise", "air_table", "boltzmann"});
  if (model == "white_noise") {
    c.heating.kind = HeatingKind::white_noise;
    c.heating.rate = static_cast<int>(r.integer("heating", "rate", 1, 1, 1000));
    c.heating.kick = r.real_required("heating", "kick", Bounds::positive(), "velocity");
  } else if (model == "air_table") {
    c.heating.kind = HeatingKind::air_table;
    c.heating.rate = static_cast<int>(r.integer("heating", "rate", 1, 1, 1000));
    c.heating.acceleration = r.real_required("heating", "acceleration", Bounds::positive(), "velocity/time");
    // Bizon Sec. V: position-dependent accelerations (docs/edmd.md "Transport coefficients")
    const std::string prof = r.choice("heating", "profile", "uniform", {"uniform", "tent", "shear"});
    if (prof != "uniform") {
      c.heating.profile = prof == "tent" ? ForcingProfile::tent : ForcingProfile::shear;
      const std::string ax = r.choice("heating", "axis", "y", {"x", "y", "z"});
      c.heating.profile_axis = ax == "x" ? 0 : ax == "y" ? 1 : 2;
      if (c.heating.profile_axis >= c.dims) r.problem("heating", "axis", "axis " + ax + " is not a direction of a 2D box");
      if (c.walls[c.heating.profile_axis])
        r.problem("heating", "axis", "the forcing profile needs a periodic axis, found walls in " + ax);
    }
    if (prof == "shear") {
      c.heating.bias = r.real("heating", "bias", 0.01, Bounds::positive(), "fraction of a0 (eq. 35)");
      const std::string cm = r.choice("heating", "component", c.heating.profile_axis == 0 ? "y" : "x", {"x", "y", "z"});
      c.heating.bias_component = cm == "x" ? 0 : cm == "y" ? 1 : 2;
      if (c.heating.bias_component >= c.dims || c.heating.bias_component == c.heating.profile_axis)
        r.problem("heating", "component",
                  "the biased component must be a box direction other than the axis, found " + cm);
    }
  } else if (model == "boltzmann") {
    c.heating.kind = HeatingKind::boltzmann;
    c.heating.rate = static_cast<int>(r.integer("heating", "rate", 1, 1, 1000));
    c.heating.temperature = r.real("heating", "temperature", 1.0, Bounds::positive(), "energy");
  }
  const auto named_model = r.resolved().find("heating.model");
  // (a model that is no model, already reported, says nothing about which keys are right)
  if (named_model == r.resolved().end() || named_model->second == "\"" + model + "\"") {
    // a key of another heating model (or profile) is not "unknown": say whose key it is
    const std::string prof = c.heating.profile == ForcingProfile::tent    ? "tent"
                             : c.heating.profile == ForcingProfile::shear ? "shear"
                                                                          : "uniform";
    // which models take a key: the registry's key lists (edmd_models(), what list-models
    // prints), as law_keys() does for the restitution laws
    std::map<std::string, std::vector<std::string>> owners;  // key -> the heating models taking it
    for (const auto& m : edmd_models())
      if (m.kind == "heating")
        for (const auto& k : m.keys) owners[k.substr(0, k.find(' '))].push_back(m.name);
    // air-table keys that only a forcing profile reads (Bizon Sec. V)
    const std::map<std::string, std::string> profile_keys{{"axis", "tent or shear"}, {"bias", "shear"}, {"component", "shear"}};
    const std::string file_model = r.overridden("heating", "model") ? r.file_string("heating", "model") : "";
    for (const auto& [key, models] : owners) {
      const bool mine = std::find(models.begin(), models.end(), model) != models.end();
      const auto need = profile_keys.find(key);
      if (mine && (need == profile_keys.end() || (prof != "uniform" && need->second.find(prof) != std::string::npos)))
        continue;
      std::string message;
      if (mine)
        message = std::string("used only with profile = ") +
                  (need->second == "shear" ? "\"shear\"" : "\"tent\" or \"shear\"") + ", found profile = \"" + prof + "\"";
      else {
        std::string list;
        for (const auto& m : models) list += (list.empty() ? "" : " or ") + ("\"" + m + "\"");
        message = "not used by model = \"" + model + "\" (a key of model = " + list + ")";
      }
      // --set heating.model switched the model (a sweep over baths): the file's keys of the
      // model it replaced are ignored with a note, as for restitution laws
      if (!file_model.empty() && file_model != model && r.has("heating", key) && !r.overridden("heating", key) &&
          std::find(models.begin(), models.end(), file_model) != models.end())
        r.ignore("heating", key,
                 "ignored: a key of the file's model = \"" + file_model + "\", which --set heating.model = \"" + model +
                     "\" replaces");
      else
        r.used_elsewhere("heating", key, message);
    }
  }
  c.background = read_background(r);
  if (c.dims == 2 && c.background.velocity.z != 0.0)
    r.problem("background", "velocity", "a 2D medium cannot drift in z");
  // sampling
  c.sample_interval = r.real("sampling", "interval", 1.0, Bounds::positive(), "collisions per particle");
  // a longer interval than the measurement leaves one sample (at its end): no mean, no error bar
  if (r.has("sampling", "interval") && c.sample_interval > c.collisions)
    r.problem("sampling", "interval",
              "expected interval <= collisions (both per particle; the measurement), found interval = " +
                  format_real(c.sample_interval) + " (" + r.origin("sampling", "interval") + ") > collisions = " +
                  format_real(c.collisions) + " (" + r.origin("edmd", "collisions") + ")",
              "edmd", "collisions");
  c.gr_max = r.real("sampling", "gr_max", 5.0, Bounds::positive(), "sigma");
  c.gr_bin = r.real("sampling", "gr_bin", 0.02, Bounds::positive(), "sigma");
  c.corr_max = r.real("sampling", "corr_max", 0.0, Bounds::non_negative(), "sigma");
  c.corr_bin = r.real("sampling", "corr_bin", 0.1, Bounds::positive(), "sigma");
  c.trajectory_interval = r.real("sampling", "trajectory_interval", 0.0, Bounds::non_negative(), "collisions per particle");
  c.free_cooling = r.boolean("sampling", "free_cooling", false);
  if (c.free_cooling && (c.heating.kind != HeatingKind::none || c.background.present() || c.driving_walls()))
    r.problem("sampling", "free_cooling", "free cooling needs [heating] model = \"none\", no background medium and no driving walls");
  // slab profiles
  c.profiles = r.has_section("profiles");
  if (c.profiles) {
    c.profile_slabs = static_cast<int>(r.integer("profiles", "slabs", 20, 1, 100000));
    int def = 0;
    for (int d = 0; d < c.dims; ++d)
      if (c.walls[d]) def = d;
    const std::string ax = r.choice("profiles", "axis", std::string(1, "xyz"[def]), {"x", "y", "z"});
    c.profile_axis = ax == "x" ? 0 : ax == "y" ? 1 : 2;
    if (c.profile_axis >= c.dims) r.problem("profiles", "axis", "axis " + ax + " is not a direction of a 2D box");
    c.tail_bins = static_cast<int>(r.integer("profiles", "velocity_bins", 400, 2, 100000));
    c.tail_range = r.real("profiles", "velocity_range", 12.0, Bounds::positive(), "sqrt(T)");
    if (c.free_cooling) r.problem("profiles", "slabs", "profiles need a steady state (not free_cooling)");
  }
  // transport bookkeeping (Bizon Sec. V)
  c.transport = r.has_section("transport");
  // A grain accelerated into a static lossy wall bounces infinitely often in finite time
  // (each flight 2 alpha_w |v_n| / a_n, a geometric series: inelastic collapse at the wall),
  // and the air table redraws an acceleration only at grain collisions, which then never
  // come: the event loop stalls (found 2026-12-05; it hung past any time limit). A driving
  // speed v_dr > 0 keeps each flight at least 2 v_dr / a_n.
  if (c.heating.kind == HeatingKind::air_table && n_wall_dirs > 0)
    for (int side = 0; side < 2; ++side)
      if (c.wall_restitution_side[side] < 1.0 && c.wall_driving[side] <= 0.0) {
        const char* key = r.has("walls", side == 0 ? "restitution_low" : "restitution_high")
                              ? (side == 0 ? "restitution_low" : "restitution_high")
                              : "restitution";
        r.problem("walls", key,
                  "the air table with a static wall of restitution < 1 collapses: a grain accelerated into the wall "
                  "bounces infinitely often in finite time; use restitution = 1, a driving speed "
                  "(walls.driving_speed) or another [heating] model");
        break;
      }
  if (c.transport) {
    c.transport_slabs = static_cast<int>(r.integer("transport", "slabs", 32, 4, 100000));
    c.transport_fit_inner = r.real("transport", "fit_inner", 0.2, Bounds::closed(0.0, 1.0), "fraction of L/2");
    c.transport_fit_outer = r.real("transport", "fit_outer", 0.8, Bounds::closed(0.0, 1.0), "fraction of L/2");
    if (c.transport_fit_outer <= c.transport_fit_inner)
      r.problem("transport", "fit_outer", "must exceed fit_inner");
    if (c.heating.kind != HeatingKind::air_table || c.heating.profile == ForcingProfile::uniform)
      r.problem("transport", "slabs",
                "[transport] needs [heating] model = \"air_table\" with profile = \"tent\" (conductivity) or \"shear\" "
                "(viscosity)");
    if (c.background.present()) r.problem("transport", "slabs", "[transport] does not book a background medium");
  }
  c.checkpoint = read_checkpoint_settings(r, "collisions per particle");
  // an interval longer than the run writes no periodic checkpoint (SIGINT still writes one)
  if (c.checkpoint.every > 0 && c.checkpoint.every >= c.equilibrate + c.collisions)
    r.note("checkpoint", "every",
           "every = " + format_real(c.checkpoint.every) + " >= equilibrate + collisions = " +
               format_real(c.equilibrate + c.collisions) +
               " collisions per particle: no periodic checkpoint is written in this run (an interruption still "
               "writes one; keep = true writes one near the end)");
  return c;
}

EngineSetup make_setup(const Config& c, std::uint64_t seed) {
  EngineSetup s;
  s.dims = c.dims;
  s.length = c.box();
  s.walls = c.walls;
  s.wall_restitution = c.wall_restitution;
  s.wall_driving = c.wall_driving;
  s.wall_restitution_side = c.wall_restitution_side;
  s.contact_time = c.contact_time;
  if (c.rough) s.inertia_q = c.rough->q;
  s.heating = c.heating;
  s.seed = seed;
  if (c.background.present()) {
    s.background = BackgroundState::make(c.background.density, c.background.knudsen, c.background.velocity,
                                         c.background.temperature, c.background.mass_ratio, 1.0);
  }
  const double tscale = std::sqrt(std::max({c.temperature, c.heating.temperature, c.background.temperature,
                                            c.wall_driving[0] * c.wall_driving[0], c.wall_driving[1] * c.wall_driving[1]}));
  s.vn_bin_width = 0.02 * tscale;
  s.vn_bins = 600;
  return s;
}

InitialState make_initial_state(const Config& c, std::uint64_t seed) {
  InitialState st;
  const std::size_t n = static_cast<std::size_t>(c.particles);
  const Vec3 L = c.box();
  const auto nl = lattice_counts(c);
  const double ax = L.x / nl[0], ay = L.y / nl[1], az = L.z / nl[2];
  if (lattice_spacing(c) < 1.0)
    throw std::invalid_argument("edmd: lattice spacing below sigma (packing fraction too high for a lattice start)");
  st.positions.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t ix = k % nl[0], iy = (k / nl[0]) % nl[1], iz = k / (static_cast<std::size_t>(nl[0]) * nl[1]);
    st.positions.push_back({(ix + 0.5) * ax, (iy + 0.5) * ay, c.dims == 3 ? (iz + 0.5) * az : 0.5});
  }
  Vec3 p;
  st.velocities.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    CounterRng rng(seed, Stream::initial_velocities, i, 0);
    Vec3 v = rng.normal3();
    if (c.dims == 2) v.z = 0.0;
    st.velocities[i] = v;
    p += v;
  }
  p = (1.0 / n) * p;
  double ke = 0.0;
  for (auto& v : st.velocities) v -= p, ke += norm2(v);
  const double s = std::sqrt(c.temperature * c.dims * n / ke);
  for (auto& v : st.velocities) v *= s;
  if (c.rough) {
    // Gaussian spins at exactly Trot = I <|omega|^2> / d_rot (2D: omega_z only, d_rot = 1)
    st.omega.assign(n, Vec3{});
    const double Trot = c.rough->rotational_temperature;
    if (Trot > 0.0) {
      const int d_rot = c.dims == 2 ? 1 : 3;
      double w2 = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        CounterRng rng(seed, Stream::initial_angular_velocities, i, 0);
        Vec3 w = rng.normal3();
        if (c.dims == 2) w.x = w.y = 0.0;
        st.omega[i] = w;
        w2 += norm2(w);
      }
      const double I = 0.25 * c.rough->q;
      const double sw = std::sqrt(Trot * d_rot * n / (I * w2));
      for (auto& w : st.omega) w *= sw;
    }
  }
  return st;
}

namespace {
using rough_model = closures::rough::Model;
// the run's restitution law, rough or not, to a generic lambda (resolved once, outside the loop)
template <class F>
decltype(auto) visit_law(const Config& c, F&& f) {
  if (c.rough) return f(c.rough->law);
  return std::visit(f, c.restitution);
}
// The grains exchange energy only among themselves and with the medium (if any): no [heating],
// no walls, smooth grains. Then the gas is homogeneous and undriven, and two predictions are
// this run's own (run-table audit 2026-12-06, docs/reviews/run-table-audit.md: both were printed for every run, e.g. the medium's T of
// 0.2 beside the 1.33 of an air-table run, "+321.8 sigma"): the medium's steady temperature
// (theory::steady_temperature_medium balances the medium's heating against the grain-grain
// losses alone) and Enskog's pressure with the equilibrium contact value. Driving changes the
// contact value itself (docs/edmd.md, the contact table: at nu = 0.5 the collisions' g(sigma+)
// is 4.66-6.34 under the three heat baths against 3.11 for elastic grains).
bool homogeneous_and_undriven(const Config& c) {
  return c.heating.kind == HeatingKind::none && !c.walls[0] && !c.walls[1] && !c.walls[2] && !c.rough;
}
// A homogeneous gas whose only energy source is a heat bath acting at the collisions (white
// noise or the Boltzmann bath; no walls, no medium, smooth grains): its steady temperature
// balances the bath against the collisional loss per collision (theory.hpp,
// collision_heating_balance_temperature), NaN for other runs. Molecular chaos: in dense
// driven gases velocity correlations lower the loss per collision (Bizon Fig. 8b), so there
// it is a reference; dilute, it predicts T (tests/edmd/physics_test.cpp).
double heating_balance_temperature(const Config& c) {
  const bool bath = c.heating.kind == HeatingKind::white_noise || c.heating.kind == HeatingKind::boltzmann;
  if (!bath || c.walls[0] || c.walls[1] || c.walls[2] || c.background.present() || c.rough) return std::nan("");
  return std::visit(
      [&](const auto& law) {
        return c.heating.kind == HeatingKind::white_noise
                   ? theory::white_noise_balance_temperature(law, c.heating.rate, c.heating.kick)
                   : theory::boltzmann_bath_balance_temperature(law, c.dims, c.heating.rate, c.heating.temperature);
      },
      c.restitution);
}
// closures/rough parameters of the case (docs/rough.md R1, R15): Enskog collision prefactor
// G (Henderson chi in 2D, Carnahan-Starling in 3D) in engine units, and the collision-keyed
// white noise as H_per_collision: each collision adds rate * kick^2 to the kinetic energy on
// average (two opposite kicks of size kick in a random direction), i.e. per particle
// dTtr/dt = nu rate kick^2 / D.
closures::rough::Parameters rough_parameters(const Config& c) {
  closures::rough::Parameters p = closures::rough::parameters_of(c.rough->law, c.rough->q, c.dims);
  p.G = c.dims == 2 ? closures::rough::collision_prefactor_2d(c.packing_fraction)
                    : closures::rough::collision_prefactor_3d(c.packing_fraction);
  if (c.heating.kind == HeatingKind::white_noise) p.H_per_collision = c.heating.rate * c.heating.kick * c.heating.kick / c.dims;
  return p;
}
// Steady R (R11) and, with a driving, Ttr (R12) of models A-E as "model_X.R", "model_X.Ttr".
// A model without a steady state (smooth grains: beta0 = -1 or mu = 0; no dissipation) is
// left out rather than failing the run.
std::vector<std::pair<std::string, double>> rough_steady_theory(const Config& c) {
  std::vector<std::pair<std::string, double>> out;
  const auto p = rough_parameters(c);
  for (auto m : {rough_model::A, rough_model::B, rough_model::C, rough_model::D, rough_model::E}) {
    const std::string key = std::string("model_") + closures::rough::to_string(m);
    try {
      out.emplace_back(key + ".R", closures::rough::steady_ratio(m, p));
      if (p.H_per_collision > 0.0) out.emplace_back(key + ".Ttr", closures::rough::steady_state(m, p).Ttr);
    } catch (const closures::ClosureError&) {
    }
  }
  return out;
}
}  // namespace

std::vector<std::pair<std::string, double>> theory_values(const Config& c) {
  std::vector<std::pair<std::string, double>> out;
  const int D = c.dims;
  const double nu = c.packing_fraction;
  const double n = theory::number_density(D, nu);
  out.emplace_back("edmd.number_density", n);
  // the box's edges, aspect applied (review 5: a single "box_length", the edge of the square of
  // the same area, read 32.36 for cases/static-lossy-walls, whose box is 16.18 x 64.72)
  const Vec3 edges = c.box();
  out.emplace_back("edmd.box.x", edges.x);
  out.emplace_back("edmd.box.y", edges.y);
  if (D == 3) out.emplace_back("edmd.box.z", edges.z);
  if (D == 2) {
    out.emplace_back("edmd.Z_henderson", theory::z_henderson(nu));
    out.emplace_back("edmd.Z_kolafa_rottner_fit", theory::z_disk_kr(nu));
    out.emplace_back("edmd.g_contact_cs_bizon_eq5", theory::g_contact_disk_cs(nu));
  } else {
    out.emplace_back("edmd.Z_carnahan_starling", theory::z_carnahan_starling(nu));
    out.emplace_back("edmd.Z_kolafa_labik_malijevsky", theory::z_sphere_klm(nu));
    out.emplace_back("edmd.g_contact_cs", theory::g_contact_sphere_cs(nu));
  }
  const double g = theory::g_contact_reference(D, nu);
  out.emplace_back("edmd.g_contact", g);
  // Enskog's Z as the run writes it (theory.Z_enskog), where e does not depend on the impact
  // speed (otherwise the run weights it with its own collisions)
  if (homogeneous_and_undriven(c) && !std::holds_alternative<BizonRestitution>(c.restitution) &&
      !std::holds_alternative<PowerLawRestitution>(c.restitution)) {
    const double e_const = visit_law(c, [](const auto& law) { return restitution(law, 1.0).e; });
    out.emplace_back("edmd.Z_enskog", 1.0 + 0.5 * (1.0 + e_const) * (theory::z_reference(D, nu) - 1.0));
  }
  out.emplace_back("edmd.enskog_frequency", theory::enskog_frequency(D, nu, g, c.temperature));
  const double e = visit_law(c, [&](const auto& law) { return restitution(law, std::sqrt(std::numbers::pi * c.temperature)).e; });
  out.emplace_back("edmd.gamma0", theory::gamma0(D, nu, g, e, c.temperature));
  out.emplace_back("edmd.gamma_e",
                   visit_law(c, [&](const auto& law) { return theory::gamma_e(law, D, nu, g, c.temperature); }));
  if (c.background.present()) {
    const double K = c.background.density / c.background.knudsen;
    if (homogeneous_and_undriven(c))
      out.emplace_back("edmd.medium_steady_temperature", visit_law(c, [&](const auto& law) {
        return theory::steady_temperature_medium(law, D, nu, c.background.temperature, K, c.background.mass_ratio);
      }));
    // DSMC of the same physics: grain-grain cross-section 1 in DSMC units corresponds to
    // pi sigma^2 g(sigma) here, so [grains] density = pi n g(sigma). 3D only: the DSMC's
    // grains and medium have 3D velocities, so a 2D disk case has no DSMC counterpart (its
    // collision rate, medium kernel and temperature are those of disks).
    if (D == 3) out.emplace_back("edmd.dsmc_equivalent_grain_density", std::numbers::pi * n * g);
  }
  if (c.driving_walls()) {
    const int wd = c.walls[0] ? 0 : c.walls[1] ? 1 : 2;
    const Vec3 b = c.box();
    const theory::WallDriving drive{c.wall_driving[0], c.wall_driving[1], c.wall_restitution_side[0],
                                    c.wall_restitution_side[1], wd == 0 ? b.x : wd == 1 ? b.y : b.z};
    visit_law(c, [&](const auto& law) {
      out.emplace_back("edmd.wall_balance_temperature", theory::wall_balance_temperature(law, D, nu, drive, true));
      out.emplace_back("edmd.wall_balance_temperature_dilute", theory::wall_balance_temperature(law, D, nu, drive, false));
      out.emplace_back("edmd.wall_balance_temperature_thesis_reading",
                       theory::wall_balance_temperature(law, D, nu, drive, false, true));
    });
  }
  if (const double T_heat = heating_balance_temperature(c); std::isfinite(T_heat))
    out.emplace_back("edmd.heating_balance_temperature", T_heat);
  if (c.rough)
    for (const auto& [k, v] : rough_steady_theory(c)) out.emplace_back("edmd.rough." + k, v);
  if (std::holds_alternative<ConstantRestitution>(c.restitution)) {
    const double ec = std::get<ConstantRestitution>(c.restitution).e;
    out.emplace_back("edmd.a2_van_noije_ernst", theory::a2_van_noije_ernst(D, ec));
    out.emplace_back("edmd.haff_t0", theory::haff_time(D, nu, g, ec, c.temperature, true));
  }
  return out;
}

namespace {

template <class Law>
void run_with(const Law& law, const Config& c, const RunContext& ctx, Summary& summary) {
  const std::uint64_t seed = ctx.seed;
  const int D = c.dims;
  const std::size_t N = static_cast<std::size_t>(c.particles);
  const InitialState init = make_initial_state(c, seed);
  Engine eng(make_setup(c, seed), init.positions, init.velocities);
  // rough grains (docs/rough.md): spins, Trot = I <|omega|^2> / d_rot, energies incl. rotation
  constexpr bool rough = std::is_same_v<Law, WaltonRestitution>;
  if (!init.omega.empty()) eng.set_angular_velocities(init.omega);
  auto rotational_temperature = [&]() {
    double w2 = 0.0;
    for (std::size_t i = 0; i < N; ++i) w2 += norm2(eng.angular_velocity(i));
    return eng.moment_of_inertia() * w2 / ((D == 2 ? 1.0 : 3.0) * N);
  };
  auto total_energy = [&]() { return eng.kinetic_energy() + (rough ? eng.rotational_energy() : 0.0); };
  const Vec3 box = c.box();
  const double volume = D == 3 ? box.x * box.y * box.z : box.x * box.y;
  const double n = N / volume;
  const bool driving = c.driving_walls();
  std::vector<Vec3> x(N), v(N);
  auto snapshot = [&]() {
    eng.synchronize();
    Vec3 mean;
    for (std::size_t i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i), mean += v[i];
    mean = (1.0 / N) * mean;
    double ke = 0.0;
    for (auto& u : v) {
      if (c.heating.kind != HeatingKind::none || c.background.present() || driving) u -= mean;  // fluctuations
      ke += norm2(u);
    }
    return ke / (D * N);  // granular temperature (Bizon eq. 3)
  };

  // Run state carried across the loop (checkpointed with the engine); the measurement
  // bins come from the case.
  const double L = std::min({box.x, box.y, D == 3 ? box.z : box.y});  // shortest edge
  // range of the pair statistics: corr_max, or L/2 (Bizon Fig. 7) while all pairs are
  // affordable (N <= 4000), else 10 sigma searched on a grid
  const double corr_range = c.corr_max > 0 ? c.corr_max : (N <= 4000 ? 0.5 * L : std::min(10.0, L / 3.0));
  RunState rs;
  rs.pairs.init(D, box, c.walls, std::max(c.gr_max, corr_range), c.gr_bin, c.corr_bin);
  rs.vhist.init(5.0, 100);
  // slab profiles (docs/edmd.md "Slab profiles"); the tails' range is set from the
  // temperature when the measurements start (or restored from the checkpoint)
  if (c.profiles) {
    rs.profiles.init({D, box, c.profile_axis, c.profile_slabs, !c.walls[c.profile_axis]});
    rs.tails.init(D, c.profile_slabs, c.tail_bins, 1.0);
  }
  if (c.transport) {
    rs.transport_on = true;
    rs.transport.init({D, box, c.heating.profile_axis,
                       c.heating.profile == ForcingProfile::shear ? c.heating.bias_component
                                                                   : (c.heating.profile_axis == 0 ? 1 : 0),
                       c.transport_slabs},
                      N);
  }
  if (ctx.resume) {
    std::string warning;
    std::string saved_collisions;
    const bool ok = read_newest_checkpoint(ctx.checkpoint_dir, ctx, eng, rs, warning, &saved_collisions);
    if (!warning.empty()) std::fprintf(stderr, "warning: %s\n", warning.c_str());
    if (!ok) throw std::runtime_error("--resume: no valid checkpoint in " + ctx.checkpoint_dir.string());
    // edmd.collisions may change on --resume (to extend a run), but not to before the
    // checkpoint: the run would do no collision and report the checkpoint's state as the
    // end. A checkpoint exactly at the new end finishes if the last sample was taken there
    // (otherwise the last sample interval would be missing). Measuring collisions count
    // from the end of the equilibration (edmd.equilibrate, which may not change).
    // std::invalid_argument: bad input, the checkpoints stay (src/cli/commands.cpp).
    const std::uint64_t measured = rs.phase == RunState::measuring ? eng.counters().collisions : 0;
    const std::uint64_t n_end = static_cast<std::uint64_t>(c.collisions * N);
    if (measured > n_end || (measured == n_end && measured > 0 && rs.prev.collisions != measured)) {
      const bool at_end = measured == n_end;
      std::string least;  // the shortest printed edmd.collisions that reaches the checkpoint
      for (int digits = 6; digits <= 17; ++digits) {
        char b[40];
        std::snprintf(b, sizeof b, "%.*g", digits, static_cast<double>(measured) / N);
        least = b;
        if (static_cast<std::uint64_t>(std::stod(least) * N) >= measured) break;
      }
      char now[40], total[64];
      std::snprintf(now, sizeof now, "%.10g", c.collisions);
      std::snprintf(total, sizeof total, "%.6g collisions per particle, %s",
                    static_cast<double>(eng.total_collisions()) / N, least.c_str());
      throw std::invalid_argument(
          "--resume: edmd.collisions = " + std::string(now) +
          (at_end ? " ends at the checkpoint (" + std::string(total) +
                        " of them after the equilibration), between two samples: give edmd.collisions > " + least
                  : " is before the checkpoint (" + std::string(total) +
                        " of them after the equilibration): give edmd.collisions " +
                        (rs.prev.collisions == measured ? ">= " : "> ") + least) +
          (saved_collisions.empty() ? std::string()
                                    : " (the run that wrote the checkpoint had edmd.collisions = " + saved_collisions +
                                          ": --set edmd.collisions=" + saved_collisions + " continues it)") +
          "; the checkpoints in " + ctx.checkpoint_dir.string() + " are kept");
    }
    std::fprintf(stderr, "resuming at %.6g collisions per particle (%s, t = %.6g)\n",
                 static_cast<double>(eng.total_collisions()) / N,
                 rs.phase == RunState::equilibrating ? "equilibrating" : "measuring", eng.time());
  }
  PairStatistics& pairs = rs.pairs;
  VelocityHistogram& vhist = rs.vhist;
  Series& s = rs.series;
  Counters& prev = rs.prev;
  double& t_prev = rs.t_prev;
  double& T_prev = rs.T_prev;
  std::vector<double>& traj_pos = rs.traj_pos;
  std::vector<double>& traj_time = rs.traj_time;
  std::vector<std::int64_t>& traj_step = rs.traj_step;

  const auto wall0 = std::chrono::steady_clock::now();
  const std::uint64_t total_at_start = eng.total_collisions();  // after a resume: the checkpoint's
  Progress progress("edmd", c.equilibrate + c.collisions, ctx.quiet);
  const std::uint64_t n_eq = static_cast<std::uint64_t>(c.equilibrate * N);
  double& engine_seconds = rs.engine_seconds;
  auto timed_advance = [&](double t_end, std::uint64_t max_coll) {
    const auto t_a = std::chrono::steady_clock::now();
    eng.advance(law, t_end, max_coll);
    engine_seconds += wall_seconds_since(t_a);
  };
  // Checkpoints (issue #8) are taken at the engine's scheduled rebuilds (every
  // rebuild_interval = 10 collisions per particle), the points from which the state
  // restores bitwise: `every` collisions per particle (the first rebuild at or after each
  // multiple of every * N collisions, counted from the start of the run), `every_minutes`
  // of wall clock, and on SIGINT/SIGTERM (which therefore wait for the next rebuild).
  const double every_coll = c.checkpoint.every * static_cast<double>(N);
  auto next_multiple = [&](std::uint64_t total) -> std::uint64_t {
    if (!(every_coll >= 1.0)) return c.checkpoint.every > 0 ? total + 1 : UINT64_MAX;
    const double k = std::floor(static_cast<double>(total) / every_coll) + 1.0;
    return static_cast<std::uint64_t>(std::ceil(k * every_coll));
  };
  std::uint64_t next_checkpoint = next_multiple(eng.total_collisions());
  auto last_checkpoint_wall = std::chrono::steady_clock::now();
  // checkpoint.keep (docs/CASE_FILE.md): the engine cannot be saved at the end of the run,
  // only at a scheduled rebuild, so the last rebuild point before the end is saved; --resume
  // with a larger edmd.collisions continues from it. Collisions left to the end of the run:
  // the counters restart at the end of the equilibration, the rebuild schedule does not.
  const std::uint64_t n_eq_total = static_cast<std::uint64_t>(c.equilibrate * N);
  const std::uint64_t n_prod_total = static_cast<std::uint64_t>(c.collisions * N);
  auto collisions_left = [&]() -> std::uint64_t {
    const std::uint64_t done = eng.counters().collisions;
    if (rs.phase == RunState::measuring) return n_prod_total > done ? n_prod_total - done : 0;
    return (n_eq_total > done ? n_eq_total - done : 0) + n_prod_total;
  };
  auto at_rebuild_point = [&]() {
    const bool stop = ctx.stop_requested && ctx.stop_requested->load();
    const bool due_coll = eng.total_collisions() >= next_checkpoint;
    const bool due_wall = c.checkpoint.every_minutes > 0 &&
                          wall_seconds_since(last_checkpoint_wall) > 60.0 * c.checkpoint.every_minutes;
    // no scheduled rebuild before the end: advance_checked() stops at the end without one
    const bool last_for_keep = c.checkpoint.keep && eng.collisions_until_rebuild() >= collisions_left();
    if (!ctx.checkpoint_dir.empty() && (stop || due_coll || due_wall || last_for_keep)) {
      write_checkpoint(ctx.checkpoint_dir, eng, rs, ctx);
      last_checkpoint_wall = std::chrono::steady_clock::now();
      next_checkpoint = next_multiple(eng.total_collisions());
    }
    if (stop) {
      progress.finish();
      char where[96];
      std::snprintf(where, sizeof where, "%.6g collisions per particle (t = %.6g)",
                    static_cast<double>(eng.total_collisions()) / N, eng.time());
      throw RunInterrupted(std::string("interrupted at ") + where +
                               (ctx.checkpoint_dir.empty() ? std::string("; no checkpoint directory, nothing saved")
                                                           : "; a checkpoint was written to " + ctx.checkpoint_dir.string() +
                                                                 "; continue with: " +
                                                                 (ctx.resume_command.empty()
                                                                      ? "grainbath run " + ctx.case_dir.string() + " --resume"
                                                                      : ctx.resume_command)));
    }
  };
  // advance() split at the scheduled rebuilds: it stops just before one, the rebuild is
  // done exactly as advance() would have done it, then the state may be checkpointed.
  // The event sequence is the same as one advance(t_end, max_coll) call.
  auto advance_checked = [&](double t_end, std::uint64_t max_coll) {
    for (;;) {
      const std::uint64_t cur = eng.counters().collisions;
      if (cur >= max_coll) return;
      const std::uint64_t due = eng.collisions_until_rebuild();
      const std::uint64_t stop = due < max_coll - cur ? cur + due : max_coll;
      timed_advance(t_end, stop);
      const std::uint64_t done = eng.counters().collisions;
      if (done >= max_coll || done < stop) return;  // finished, or stopped by t_end
      if (!eng.rebuild_if_due()) throw std::logic_error("edmd: expected a scheduled rebuild");
      at_rebuild_point();
    }
  };

  double T = 0.0;
  // a run resumed in its measuring phase has its transport sums from the checkpoint
  const bool transport_begun = rs.phase == RunState::measuring;
  if (rs.phase == RunState::equilibrating) {
    // --- equilibration -----------------------------------------------------------------
    for (; rs.eq_chunk <= 20 && n_eq > 0; ++rs.eq_chunk) {
      advance_checked(kInf, n_eq * rs.eq_chunk / 20);
      char status[64];
      std::snprintf(status, sizeof status, "equilibrating  t=%.4g", eng.time());
      progress.update(static_cast<double>(eng.counters().collisions) / N, status);
    }
    T = snapshot();
    const double t_eq = eng.time();
    rs.rate_eq = t_eq > 0 ? eng.counters().collisions / t_eq : 0.0;
    eng.rebuild();
    rs.c_eq = eng.counters();
    eng.counters() = Counters{};
    eng.counters().vn_histogram.assign(rs.c_eq.vn_histogram.size(), 0);
    // the normal-speed bins in units of the measured temperature, not of the case's scales
    // (those are >= 1 by their defaults: bins of 0.09 sqrt(T) at T = 0.05 before)
    if (T > 0.0) eng.set_vn_bin_width(0.02 * std::sqrt(T));
    rs.t0 = eng.time();
    rs.T0 = T;
    T = snapshot();
    rs.e_initial = total_energy();
    rs.p_initial = eng.momentum();
    s.time.push_back(0.0);
    s.temperature.push_back(T);
    if (rough) s.rotational_temperature.push_back(rotational_temperature());
    prev = eng.counters();
    t_prev = rs.t0;
    T_prev = T;
    if (c.profiles) rs.tails.init(D, c.profile_slabs, c.tail_bins, c.tail_range * std::sqrt(rs.T0));
    rs.phase = RunState::measuring;
  }
  // collisional parts of the profiles through the engine hook, measuring phase only
  SlabProfiles& profiles = rs.profiles;
  SlabVelocityHistograms& tails = rs.tails;
  std::vector<double>& wall_in_series = rs.wall_in_series;
  std::vector<double>& loss_series = rs.loss_series;
  std::vector<Vec3> v_raw;
  if (c.profiles) {
    eng.set_collision_hook(&SlabProfiles::collision_hook, &profiles);
    v_raw.resize(N);
  }
  // transport bookkeeping (Bizon Sec. V): free-flight and collision hooks from here on
  SlabTransport& transport = rs.transport;
  CollisionHookPair both_hooks;
  if (c.transport) {
    if (!transport_begun) {
      eng.synchronize();
      std::vector<Vec3> xr(N), vr(N);
      for (std::size_t i = 0; i < N; ++i) xr[i] = eng.position(i), vr[i] = eng.velocity(i);
      transport.begin(xr, vr);
    }
    eng.set_move_hook(&SlabTransport::move_hook, &transport);
    if (c.profiles) {
      both_hooks = {&SlabProfiles::collision_hook, &profiles, &SlabTransport::collision_hook, &transport};
      eng.set_collision_hook(&CollisionHookPair::call, &both_hooks);
    } else {
      eng.set_collision_hook(&SlabTransport::collision_hook, &transport);
    }
    if (v_raw.empty()) v_raw.resize(N);
  }
  const Counters& c_eq = rs.c_eq;
  const double t0 = rs.t0, T0 = rs.T0, e_initial = rs.e_initial;
  const Vec3 p_initial = rs.p_initial;

  // Sampling interval in time (steady state) from the equilibration's collision rate, or,
  // with no equilibration (edmd.equilibrate = 0), from the mean rate of the run so far at each
  // sample (the state may still be settling; the first interval is taken by collisions);
  // collision-based throughout when cooling freely (the rate falls). A snapshot taken at a
  // collision count holds the pair that has just collided at contact (docs/edmd.md "Contact
  // values"): such snapshots give the time series but not the pair statistics or the
  // velocity histograms. Times decided from the past at the previous sample carry no such pair.
  const bool rate_of_the_run = !c.free_cooling && rs.rate_eq <= 0.0;
  auto interval_in_time = [&](const Counters& now, double t_now) {
    if (c.free_cooling) return 0.0;
    if (!rate_of_the_run) return c.sample_interval * N / rs.rate_eq;
    return now.collisions > 0 && t_now > t0 ? c.sample_interval * N * (t_now - t0) / now.collisions : 0.0;
  };
  double dt_sample = interval_in_time(prev, t_prev);  // prev, t_prev: the last sample's (also after a resume)
  const std::uint64_t coll_sample = static_cast<std::uint64_t>(std::max(1.0, c.sample_interval * N));
  const std::uint64_t n_prod = static_cast<std::uint64_t>(c.collisions * N);

  // trajectories (H5MD layout)
  const std::uint64_t coll_traj = c.trajectory_interval > 0 ? static_cast<std::uint64_t>(c.trajectory_interval * N) : 0;
  std::uint64_t& next_traj = rs.next_traj;
  std::int64_t& sample_no = rs.sample_no;
  const int pair_every = std::max<int>(1, static_cast<int>(std::ceil(5.0 / c.sample_interval)));  // pair stats every ~5 coll/particle
  while (eng.counters().collisions < n_prod) {
    // targets from the state at the last sample, so that a resumed run continues the
    // interpolated interval the checkpoint was taken in
    const std::uint64_t target = dt_sample > 0.0 ? n_prod : std::min(n_prod, prev.collisions + coll_sample);
    advance_checked(dt_sample > 0.0 ? t_prev + dt_sample : kInf, target);
    T = snapshot();
    const Counters& cur = eng.counters();
    const bool at_collision = cur.collisions >= target;  // stopped by the count, not the time
    const double dt = eng.time() - t_prev;
    ++sample_no;
    if (sample_no == fault_nonfinite_sample()) T = std::nan("");  // test hook (core/run_support.hpp)
    // NaN/Inf monitor (issue #8). The engine can only be checkpointed at a scheduled rebuild
    // (docs/edmd.md "Checkpoints"), so the run stops here and points at the newest one,
    // taken at most 10 collisions per particle before the fault.
    if (!std::isfinite(T) || !std::isfinite(cur.energy_lost) || !std::isfinite(cur.heating_energy) ||
        !std::isfinite(cur.background_energy) || !std::isfinite(cur.virial)) {
      progress.finish();
      char where[160];
      std::snprintf(where, sizeof where, "non-finite sample %lld (T = %g, energy lost %g, heating %g) at t = %.6g, %.6g collisions per particle",
                    static_cast<long long>(sample_no), T, cur.energy_lost, cur.heating_energy, eng.time() - t0,
                    static_cast<double>(eng.total_collisions()) / N);
      throw std::runtime_error(std::string(where) + ": stopping" +
                               (ctx.checkpoint_dir.empty() ? std::string("; no checkpoint directory")
                                                           : "; the newest checkpoint before the fault is kept in " +
                                                                 ctx.checkpoint_dir.string()));
    }
    if (dt > 0) {
      const double Tm = 0.5 * (T + T_prev);
      // Bizon eq. 24: P V = N T + (m sigma / (D t)) Sum k.dv
      s.z.push_back(1.0 + (cur.virial - prev.virial) / (D * dt * N * Tm));
      s.time.push_back(eng.time() - t0);
      s.temperature.push_back(T);
      if (rough) s.rotational_temperature.push_back(rotational_temperature());
      s.energy_lost.push_back((cur.energy_lost - prev.energy_lost) / (volume * dt));
      s.heating.push_back((cur.heating_energy - prev.heating_energy) / (volume * dt));
      s.background.push_back((cur.background_energy - prev.background_energy) / (volume * dt));
      s.collisions.push_back(static_cast<double>(cur.collisions - prev.collisions) * 2.0 / (N * dt));
      if (driving) {
        wall_in_series.push_back((cur.wall_energy[0] + cur.wall_energy[1] - prev.wall_energy[0] - prev.wall_energy[1]) / dt);
        loss_series.push_back((cur.energy_lost - prev.energy_lost) / dt);
      }
    }
    if (c.transport) {
      for (std::size_t i = 0; i < N; ++i) v_raw[i] = eng.velocity(i);
      transport.end_interval(dt, v_raw);
    }
    if (c.profiles) {
      for (std::size_t i = 0; i < N; ++i) v_raw[i] = eng.velocity(i);  // lab frame (snapshot() removed the mean)
      profiles.add_snapshot(x, v_raw);
      profiles.end_interval(dt);
      tails.add(profiles, x, v_raw);
    }
    if (!c.free_cooling && !at_collision) {
      vhist.add(v, T, D);
      if (sample_no % pair_every == 0) pairs.add(x, v, T);
    }
    if (coll_traj && cur.collisions >= next_traj) {
      for (const auto& p : x)
        for (int d = 0; d < D; ++d) traj_pos.push_back(d == 0 ? p.x : d == 1 ? p.y : p.z);
      traj_time.push_back(eng.time() - t0);
      traj_step.push_back(static_cast<std::int64_t>(cur.collisions));
      next_traj = cur.collisions + coll_traj;
    }
    prev = cur;
    t_prev = eng.time();
    T_prev = T;
    dt_sample = interval_in_time(prev, t_prev);
    char status[64];
    std::snprintf(status, sizeof status, "t=%.4g T=%.5g", eng.time() - t0, T);
    progress.update(c.equilibrate + static_cast<double>(cur.collisions) / N, status);
  }
  progress.finish();
  eng.synchronize();
  const double wall = wall_seconds_since(wall0);
  const Counters& f = eng.counters();
  const double t_run = eng.time() - t0;

  // ---- summary -------------------------------------------------------------------------
  std::vector<double> Tseries(s.temperature.begin() + 1, s.temperature.end());
  const MeanError Tm = block_average(Tseries);
  const MeanError Zm = block_average(s.z);
  // A blocked error whose blocking reached no plateau is a lower bound (the series is
  // correlated over a good part of the window, or drifts through it): flagged as the DSMC
  // does (`KEY_plateau`, docs/OUTPUT.md; absent when the window is too short to tell) and said
  // on stderr. Measured (docs/edmd.md "Errors of the window means"): heated disks and rough
  // grains scatter over seeds 2.2-2.6x their blocked T errors, every run flagged.
  // errors whose window is too short to judge (about 91 samples needed): said in one note, and
  // the run's table marks them "(few samples: unchecked)", as the DSMC's
  std::string unchecked;
  std::size_t unchecked_samples = 0;
  // errors that cannot be given at all (fewer than 2 samples in the window: a measurement no
  // longer than one sampling interval, e.g. the default interval of 1 collision per grain in
  // a shorter run): said in one note, as summary.json holds null for them
  std::string no_error;
  std::size_t no_error_samples = 0;
  auto flag_plateau = [&](const std::string& key, const MeanError& e) {
    if (e.samples < 2) {
      no_error += (no_error.empty() ? "" : ", ") + key;
      no_error_samples = e.samples;
    }
    if (!e.plateau_judged && std::isfinite(e.stderr_) && e.samples > 1) {
      unchecked += (unchecked.empty() ? "" : ", ") + key;
      unchecked_samples = e.samples;
    }
    if (!e.plateau_judged || !std::isfinite(e.stderr_)) return;
    summary.set(key + "_plateau", e.plateau);
    if (!e.plateau)
      std::fprintf(stderr,
                   "warning: %s = %.3g is unreliable: block averaging over the window (%zu samples) reached no "
                   "plateau: the series is correlated over a good part of it (then the error is a lower bound) "
                   "or drifts through it (%s_plateau = false); take the error from independent replicas: "
                   "grainbath sweep CASE --set run.seed=1,2,...,8\n",
                   key.c_str(), e.stderr_, e.samples, key.c_str());
  };
  const double T_mean = Tm.mean;
  // In free cooling T decays through the window, so theory evaluated at the window mean of T
  // is not the theory of the window: a rate that goes as T^p (collision frequency p = 1/2,
  // loss rate p = 3/2) averages to its time average <T^p>_t over the window (trapezoid over
  // the samples, Jensen: <T^p> != <T>^p). Steady runs keep T_mean everywhere.
  auto time_mean_power = [&](double p) {
    double integral = 0.0;
    for (std::size_t k = 1; k < s.time.size(); ++k)
      integral += 0.5 * (std::pow(s.temperature[k - 1], p) + std::pow(s.temperature[k], p)) * (s.time[k] - s.time[k - 1]);
    const double span = s.time.size() > 1 ? s.time.back() - s.time.front() : 0.0;
    return span > 0.0 ? integral / span : std::pow(T_mean, p);
  };
  const double Th = c.free_cooling ? time_mean_power(0.5) : 0.0;   // <T^1/2>_t
  const double T1 = c.free_cooling ? time_mean_power(1.0) : 0.0;    // <T>_t
  const double T32 = c.free_cooling ? time_mean_power(1.5) : 0.0;   // <T^3/2>_t
  // Z from the totals (ratio of sums) and its error from the blocked per-interval series
  const double Z = c.free_cooling ? Zm.mean : 1.0 + f.virial / (D * t_run * N * T_mean);
  summary.set("pressure.Z", Z);
  summary.set("pressure.Z_stderr", Zm.stderr_);
  flag_plateau("pressure.Z_stderr", Zm);
  // Driven grains (heating, driving walls) have slow modes of small amplitude that one window
  // does not resolve: Z's blocking passes the plateau test, yet over seeds of the shipped driven
  // cases Z scattered 1.26-1.56x its blocked error, pooled 1.43 +- 0.16x (docs/edmd.md "Errors of
  // the window means"; elastic and medium runs: right). Said where the flag cannot say it.
  if ((c.heating.kind != HeatingKind::none || c.driving_walls()) && Zm.plateau_judged && Zm.plateau &&
      std::isfinite(Zm.stderr_))
    std::fprintf(stderr,
                 "note: pressure.Z_stderr = %.3g passed the plateau test, but for driven grains one run's blocked "
                 "errors of Z were 1.4x too small on average over replicas of the shipped driven cases (slow modes, "
                 "docs/edmd.md \"Errors of the window means\"); for an error to quote, run replicas: grainbath sweep "
                 "CASE --set run.seed=1,2,...,8\n",
                 Zm.stderr_);
  if (!c.free_cooling) {  // a window mean of a decaying T describes nothing (haff.* does)
    summary.set("pressure.P", n * T_mean * Z);
    // its error from the blocked per-interval pressures n T_k Z_k (T_k the interval's mean
    // temperature, Bizon eq. 24), which carry the fluctuations of T and of the virial together
    // (review 4: P had no error). Elastic grains keep T fixed: then it is n T Z_stderr.
    if (s.z.size() + 1 == s.temperature.size()) {
      std::vector<double> p(s.z.size());
      for (std::size_t k = 0; k < p.size(); ++k) p[k] = n * 0.5 * (s.temperature[k] + s.temperature[k + 1]) * s.z[k];
      const MeanError Pm = block_average(p);
      summary.set("pressure.P_stderr", Pm.stderr_);
      flag_plateau("pressure.P_stderr", Pm);
    }
    // The pressure on the walls: the normal momentum they took (Counters::wall_virial) per unit
    // time and wall area (length in 2D), what a manometer in the wall reads. In a box walled in
    // every direction it is, by the virial theorem of the closed box (StaticWalls.
    // VirialTheoremOfAClosedBoxHoldsExactly; docs/edmd.md "Pressure on the walls"),
    // pressure.P L/(L - sigma) for a square or cube of side L, the centres being confined to
    // L - sigma; with walls in one direction it is the normal pressure the bulk exerts.
    const double extent[3] = {box.x, box.y, box.z};
    double wall_area = 0.0;
    for (int d = 0; d < D; ++d) {
      if (!c.walls[d]) continue;
      double a = 2.0;  // the two walls of direction d
      for (int e = 0; e < D; ++e)
        if (e != d) a *= extent[e];
      wall_area += a;
    }
    if (wall_area > 0.0 && t_run > 0.0) summary.set("pressure.wall", f.wall_virial / (t_run * wall_area));
    summary.set("temperature.mean", T_mean);
    summary.set("temperature.stderr", Tm.stderr_);
    flag_plateau("temperature.stderr", Tm);
  }
  summary.set("temperature.initial", T0);
  const double mean_e = f.collisions ? f.sum_e / f.collisions : 1.0;
  summary.set("restitution.mean_e", mean_e);
  // G_s (Bizon eq. 23 generalised): Z = 1 + 2^{D-1} (1 + <e>)/2 * packing * g
  const double pref = D == 2 ? 1.0 : 2.0;
  const double Gs = (Z - 1.0) / (1.0 + mean_e);
  summary.set("pressure.G_s", Gs);
  summary.set("pressure.g_contact", Gs / (pref * c.packing_fraction));
  // the same with the collision-weighted (1 + e): the virial sums (1 + e) g_n / 2, so with a
  // speed-dependent e the relevant average is <(1 + e) g_n> / <g_n>, not 1 + <e>
  const double w_e = f.sum_vn > 0 ? 2.0 * f.virial / f.sum_vn : 2.0;
  summary.set("pressure.g_contact_weighted_e", (Z - 1.0) / (w_e * pref * c.packing_fraction));
  const double g_ref = theory::g_contact_reference(D, c.packing_fraction);
  summary.set("theory.Z", theory::z_reference(D, c.packing_fraction));
  // Enskog's pressure of inelastic grains with the equilibrium contact value (Garzo-Dufty:
  // p = n T [1 + 2^{D-2} (1 + e) phi g]): the collisional part of the EOS times (1 + e)/2, with
  // the collision-weighted restitution the virial sums (w_e = <(1 + e) g_n>_c / <g_n>_c, exactly
  // 1 + e for a constant e); only where it predicts this run (homogeneous_and_undriven)
  if (homogeneous_and_undriven(c))
    summary.set("theory.Z_enskog", 1.0 + 0.5 * w_e * (theory::z_reference(D, c.packing_fraction) - 1.0));
  summary.set("theory.g_contact", g_ref);
  if (D == 2) {
    summary.set("theory.Z_henderson", theory::z_henderson(c.packing_fraction));
    summary.set("theory.G_cs", c.packing_fraction * theory::g_contact_disk_cs(c.packing_fraction));
  } else {
    summary.set("theory.Z_klm", theory::z_sphere_klm(c.packing_fraction));
  }
  // collision frequency per particle vs Enskog
  const double omega = t_run > 0 ? 2.0 * f.collisions / (N * t_run) : 0.0;
  // Enskog's frequency goes as sqrt(T): over the window, at T_freq = <T^1/2>_t^2
  const double T_freq = c.free_cooling ? Th * Th : T_mean;
  const double omega_e = theory::enskog_frequency(D, c.packing_fraction, g_ref, T_freq);
  summary.set("collision.frequency", omega);
  summary.set("collision.enskog_frequency", omega_e);
  summary.set("collision.frequency_over_enskog", omega / omega_e);
  summary.set("collision.g_contact_from_rate", omega / theory::enskog_frequency(D, c.packing_fraction, 1.0, T_freq));
  const double vn_mean = f.collisions ? f.sum_vn / f.collisions : 0.0;
  const double vn2_mean = f.collisions ? f.sum_vn2 / f.collisions : 0.0;
  // collision averages weight each time by the rate (∝ T^1/2): <v_n>_c ∝ <T>_t/<T^1/2>_t,
  // <v_n^2>_c ∝ <T^3/2>_t/<T^1/2>_t (both T_mean's powers in a steady run)
  const double vn_scale = c.free_cooling ? std::sqrt(std::numbers::pi) * T1 / Th : std::sqrt(std::numbers::pi * T_mean);
  const double vn2_scale = c.free_cooling ? 4.0 * T32 / Th : 4.0 * T_mean;
  summary.set("collision.vn_over_sqrt_piT", vn_mean / vn_scale);  // Bizon after eq. 33
  summary.set("collision.vn2_over_4T", vn2_mean / vn2_scale);
  summary.set("collision.count", static_cast<std::int64_t>(f.collisions));
  {
    // state.hash (src/core/state_hash.hpp): every bit of the final positions, velocities and
    // (rough grains) spins, by id, so runs that must agree bitwise (restart vs straight run,
    // same case and seed) can be compared to the last bit; positions are synchronised above
    StateHash h;
    double v[9];
    for (std::size_t id = 0; id < N; ++id) {
      const Vec3 r = eng.position(id), u = eng.velocity(id), w = c.rough ? eng.angular_velocity(id) : Vec3{};
      std::size_t k = 0;
      for (int d = 0; d < D; ++d) v[k++] = d == 0 ? r.x : d == 1 ? r.y : r.z;
      for (int d = 0; d < D; ++d) v[k++] = d == 0 ? u.x : d == 1 ? u.y : u.z;
      if (c.rough) {
        if (D == 2) {
          v[k++] = w.z;
        } else {
          v[k++] = w.x;
          v[k++] = w.y;
          v[k++] = w.z;
        }
      }
      h.add(id, std::span<const double>(v, k));
    }
    summary.set("state.hash", h.hex());
  }
  if (!c.free_cooling) {
    const double contact = pairs.contact_value();
    // applies but not measurable: null in summary.json, and the reason here (docs/OUTPUT.md)
    if (!std::isfinite(contact))
      std::fprintf(stderr,
                   "warning: no g_r.contact_fit: the quadratic fit of g(r) over [sigma, 1.1 sigma] needs 3 bins there, "
                   "sampling.gr_bin = %.4g gives fewer: use gr_bin <= 0.033\n",
                   c.gr_bin);
    summary.set("g_r.contact_fit", contact);
    // g(sigma+) from the collisions (measure.hpp, contact_from_collisions): the approaching
    // pairs' density at contact, omega <1/u>_c, and the receding ones', omega <1/(e u)>_c;
    // exact in expectation for any pair velocity distribution. Collisions the TC guard made
    // elastic enter through Counters::guard_receding (NaN, so null, after an older checkpoint).
    if (f.collisions > 0) {
      const CollisionContact cc =
          contact_from_collisions(D, (N - 1.0) / volume, omega, f.vn_histogram, eng.vn_bin_width(), f.collisions,
                                  [&](double u) { return restitution(law, u).e; },
                                  f.guard_elastic > 0 ? f.guard_receding : 0.0);
      summary.set("g_r.contact_from_collisions", cc.g);
      // <1/u>_c against molecular chaos at T (sqrt(pi/T)/2 in 2D and 3D), and the receding
      // pairs' excess <1/(e u)>_c / <1/u>_c (1 for elastic grains)
      summary.set("collision.inv_vn_over_chaos", cc.inverse_speed / (0.5 * std::sqrt(std::numbers::pi / T_mean)));
      summary.set("collision.receding_excess", cc.inverse_receding_speed / cc.inverse_speed);
    } else {
      summary.set("g_r.contact_from_collisions", std::nan(""));
    }
  }
  // loss rate (Bizon eqs. 14, 29-31): grain-grain collisions only (energy_lost); losses at
  // static inelastic walls are energy.wall_loss_rate
  const double gamma = t_run > 0 ? f.energy_lost / (volume * t_run) : 0.0;
  const double Gfor = Gs / pref / c.packing_fraction;  // g from the EOS measurement, as Bizon does
  // the loss rate goes as T^3/2: over the window, at T_loss = <T^3/2>_t^(2/3)
  const double T_loss = c.free_cooling ? std::cbrt(T32 * T32) : T_mean;
  const double g0 = theory::gamma0(D, c.packing_fraction, Gfor, mean_e, T_loss);
  const double ge = theory::gamma_e(law, D, c.packing_fraction, Gfor, T_loss);
  summary.set("loss.gamma", gamma);
  // the chaos rates are those of smooth grains (normal restitution only): rough grains also
  // lose energy through the tangential restitution (docs/rough.md), and gamma/gamma_e read
  // 2.65 in cases/rough-driven/mu-0.5 (run-table audit 2026-12-06), which described nothing
  if (!c.rough) {
    summary.set("loss.gamma0", g0);
    summary.set("loss.gamma_e", ge);
    if (g0 > 0) summary.set("loss.gamma_over_gamma0", gamma / g0);
    if (ge > 0) summary.set("loss.gamma_over_gamma_e", gamma / ge);
  }
  // Bizon eq. 33 check: gamma/gamma_e tracks (<v_n^2>_c/<v_n>_c) / (4T/sqrt(pi T)), 1 under molecular chaos
  // (v_n^2)_c/(v_n)_c under molecular chaos: 4 T/sqrt(pi T) steady, 4 <T^3/2>_t/(sqrt(pi) <T>_t) cooling
  const double vr_scale = c.free_cooling ? std::sqrt(std::numbers::pi) * T1 / (4.0 * T32) : std::sqrt(std::numbers::pi) / (4.0 * std::sqrt(T_mean));
  summary.set("loss.velocity_ratio", vr_scale * vn2_mean / std::max(vn_mean, 1e-300));
  if (const double T_heat = heating_balance_temperature(c); std::isfinite(T_heat)) {
    summary.set("theory.heating_balance_temperature", T_heat);
    summary.set("heating.temperature_over_balance", T_mean / T_heat);
  }
  if (c.background.present()) {
    if (homogeneous_and_undriven(c)) {
      const double K = c.background.density / c.background.knudsen;
      const double Tth = theory::steady_temperature_medium(law, D, c.packing_fraction, c.background.temperature, K,
                                                           c.background.mass_ratio);
      summary.set("theory.medium_steady_temperature", Tth);
      summary.set("medium.temperature_over_theory", T_mean / Tth);
    }
    summary.set("medium.background_collision_rate", t_run > 0 ? f.background_collisions / (N * t_run) : 0.0);
  }
  // conservation
  summary.set("conservation.energy_change",
              (total_energy() - e_initial) -
                  (f.heating_energy + f.background_energy + f.wall_energy[0] + f.wall_energy[1] - f.energy_lost -
                   f.wall_energy_lost));
  summary.set("conservation.relative_energy_change_elastic", (total_energy() - e_initial) / e_initial);
  summary.set("conservation.momentum_change", norm(eng.momentum() - p_initial));
  summary.set("energy.heating_rate", t_run > 0 ? f.heating_energy / (volume * t_run) : 0.0);
  summary.set("energy.background_rate", t_run > 0 ? f.background_energy / (volume * t_run) : 0.0);
  summary.set("energy.loss_rate", gamma);
  summary.set("energy.wall_loss_rate", t_run > 0 ? f.wall_energy_lost / (volume * t_run) : 0.0);
  summary.set("overlap.min_distance", eng.min_distance());
  if (vhist.samples > 0) {
    const double c4 = vhist.c4_sum / vhist.samples, c2 = vhist.c2_sum / vhist.samples;
    summary.set("velocity.a2", c4 / (c2 * c2) * D / (D + 2.0) - 1.0);  // Sonine a2 = D<c^4>/((D+2)<c^2>^2) - 1
  }
  if (c.free_cooling) {
    const double e_c = mean_e;
    const double th = theory::haff_time(D, c.packing_fraction, g_ref, e_c, T0, true);
    const double th0 = theory::haff_time(D, c.packing_fraction, g_ref, e_c, T0, false);
    // fit t0 from T(t) = T0/(1 + t/t0)^2: T^{-1/2} linear in t
    double sx = 0, sy = 0, sxx = 0, sxy = 0, m = 0;
    for (std::size_t k = 0; k < s.time.size(); ++k) {
      const double y = std::sqrt(T0 / s.temperature[k]);
      sx += s.time[k], sy += y, sxx += s.time[k] * s.time[k], sxy += s.time[k] * y, m += 1;
    }
    const double slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
    summary.set("haff.t0_measured", 1.0 / slope);
    summary.set("haff.t0_theory", th);
    summary.set("haff.t0_theory_no_a2", th0);
    summary.set("haff.ratio", (1.0 / slope) / th);
    summary.set("haff.a2_van_noije_ernst", theory::a2_van_noije_ernst(D, e_c));
    summary.set("haff.final_temperature", s.temperature.back());
  }
  // engine throughput (event loop only, measurements excluded) and overall
  const double cps = engine_seconds > 0 ? (c_eq.collisions + f.collisions) / engine_seconds : 0.0;
  summary.set("performance.collisions_per_second", cps);
  // per wall second of this invocation: after --resume, the collisions since the resume over
  // the resumed part's wall time (review 4: all collisions over the resumed part's time)
  summary.set("performance.overall_collisions_per_second",
              wall > 0 ? static_cast<double>(eng.total_collisions() - total_at_start) / wall : 0.0);
  summary.set("performance.engine_seconds", engine_seconds);
  summary.set("performance.wall_seconds", wall);
  summary.set("performance.events_per_collision", f.collisions ? double(f.events) / f.collisions : 0.0);
  summary.set("performance.stale_fraction", f.events ? double(f.stale) / f.events : 0.0);
  // the threads of the snapshot measurements (the event loop itself is serial)
  summary.set("performance.threads", static_cast<std::int64_t>(omp_get_max_threads()));
  summary.set("guard.elastic_collisions", static_cast<std::int64_t>(f.guard_elastic));
  summary.set("guard.clamped", static_cast<std::int64_t>(f.clamped));
  summary.set("background.collisions", static_cast<std::int64_t>(f.background_collisions));
  summary.set("walls.collisions", static_cast<std::int64_t>(f.wall_collisions));
  if (driving) {
    // steady-state energy balance from the run's own counters (docs/edmd.md "Driving walls")
    const double in = (f.wall_energy[0] + f.wall_energy[1]) / t_run, loss = f.energy_lost / t_run;
    summary.set("walls.energy_input_rate", in);                  // energy per unit time, whole box
    summary.set("walls.energy_input_low", f.wall_energy[0] / t_run);
    summary.set("walls.energy_input_high", f.wall_energy[1] / t_run);
    summary.set("walls.hits_low", static_cast<std::int64_t>(f.wall_hits[0]));
    summary.set("walls.hits_high", static_cast<std::int64_t>(f.wall_hits[1]));
    summary.set("walls.collisional_loss_rate", loss);
    summary.set("walls.balance", in / loss - 1.0);
    // error of the balance from the blocked per-interval series of (input - loss)
    std::vector<double> diff(wall_in_series.size());
    for (std::size_t k = 0; k < diff.size(); ++k) diff[k] = wall_in_series[k] - loss_series[k];
    summary.set("walls.balance_stderr", block_average(diff).stderr_ / loss);
    summary.set("walls.energy_change_per_time", (total_energy() - e_initial) / t_run);
    const int wd = c.walls[0] ? 0 : c.walls[1] ? 1 : 2;
    const double Lw = wd == 0 ? box.x : wd == 1 ? box.y : box.z;
    const theory::WallDriving drive{c.wall_driving[0], c.wall_driving[1], c.wall_restitution_side[0],
                                    c.wall_restitution_side[1], Lw};
    const double T_bal = theory::wall_balance_temperature(law, D, c.packing_fraction, drive, true);
    const double T_bal_dilute = theory::wall_balance_temperature(law, D, c.packing_fraction, drive, false);
    summary.set("theory.wall_balance_temperature", T_bal);
    summary.set("theory.wall_balance_temperature_dilute", T_bal_dilute);
    summary.set("theory.wall_balance_temperature_thesis_reading",
                theory::wall_balance_temperature(law, D, c.packing_fraction, drive, false, true));
    summary.set("walls.temperature_over_balance_dilute", T_mean / T_bal_dilute);
    summary.set("walls.temperature_over_balance", T_mean / T_bal);
  }

  TransportResult tr;
  if (c.transport) {
    eng.set_move_hook(nullptr, nullptr);
    eng.set_collision_hook(nullptr, nullptr);
    const bool cond = c.heating.profile == ForcingProfile::tent;
    TransportAnalysis an;
    an.kind = cond ? TransportAnalysis::conductivity : TransportAnalysis::viscosity;
    an.fit_inner = c.transport_fit_inner;
    an.fit_outer = c.transport_fit_outer;
    summary.set("transport.experiment", std::string(cond ? "conductivity" : "viscosity"));
    for (const auto& sc : transport_scalars(transport, an)) {
      summary.set("transport." + sc.name, sc.value);
      if (sc.stderr_ > 0.0) summary.set("transport." + sc.name + "_stderr", sc.stderr_);
    }
    summary.set("transport.blocks", static_cast<std::int64_t>(transport.blocks().size()));
    tr = transport_result(transport);
  }
  // rough grains: steady R = Trot/Ttr over the second half of the samples (blocked standard
  // error of the per-sample ratio), the models' R and their Ttr(t), Trot(t) from the
  // measured start (docs/rough.md R2-R12; the models use the Enskog collision frequency)
  std::vector<std::pair<std::string, std::vector<closures::rough::Sample>>> model_curves;
  if constexpr (rough) {
    const std::size_t m = s.temperature.size();
    std::vector<double> ratio, ttr, trot;
    for (std::size_t k = m / 2; k < m; ++k) {
      if (k == 0) continue;  // the start is not a steady sample
      ratio.push_back(s.rotational_temperature[k] / s.temperature[k]);
      ttr.push_back(s.temperature[k]);
      trot.push_back(s.rotational_temperature[k]);
    }
    const MeanError Rm = block_average(ratio), Ttm = block_average(ttr), Trm = block_average(trot);
    summary.set("rotation.R", Rm.mean);
    summary.set("rotation.R_stderr", Rm.stderr_);
    summary.set("rotation.window_start_time", s.time[m / 2 > 0 ? m / 2 : 1]);
    summary.set("rotation.Ttr_mean", Ttm.mean);
    summary.set("rotation.Ttr_stderr", Ttm.stderr_);
    summary.set("rotation.Trot_mean", Trm.mean);
    summary.set("rotation.Trot_stderr", Trm.stderr_);
    flag_plateau("rotation.R_stderr", Rm);
    flag_plateau("rotation.Ttr_stderr", Ttm);
    flag_plateau("rotation.Trot_stderr", Trm);
    summary.set("rotation.Trot_initial", s.rotational_temperature.front());
    summary.set("rotation.moment_of_inertia_q", c.rough->q);
    for (const auto& [k, v] : rough_steady_theory(c)) summary.set("theory." + k, v);
    const auto p = rough_parameters(c);
    for (auto model : {rough_model::A, rough_model::B, rough_model::C, rough_model::D, rough_model::E}) {
      try {
        model_curves.emplace_back(closures::rough::to_string(model),
                                  closures::rough::integrate(model, p, s.temperature.front(), s.rotational_temperature.front(), s.time));
      } catch (const closures::ClosureError& err) {
        std::fprintf(stderr, "warning: rough model %s not integrated: %s\n", closures::rough::to_string(model), err.what());
      }
    }
  }

  if (!unchecked.empty())
    std::fprintf(stderr,
                 "note: %s: the window holds %zu samples, too few to check the blocking for a plateau (about 91 "
                 "needed); the errors assume correlations shorter than the longest blocks. A smaller "
                 "sampling.interval or more edmd.collisions give more samples; replicas give an error that "
                 "assumes nothing: grainbath sweep CASE --set run.seed=1,2,...,8\n",
                 unchecked.c_str(), unchecked_samples);

  if (!no_error.empty())
    std::fprintf(stderr,
                 "note: %s: the window holds %zu sample%s: no error bar (sampling.interval = %s, the measurement "
                 "edmd.collisions = %s, both collisions per particle); a sampling.interval of at most collisions/16 "
                 "gives a blocked error, replicas give one without: grainbath sweep CASE --set "
                 "run.seed=1,2,...,8\n",
                 no_error.c_str(), no_error_samples, no_error_samples == 1 ? "" : "s",
                 format_real(c.sample_interval).c_str(), format_real(c.collisions).c_str());

  // ---- results.h5 ----------------------------------------------------------------------
  H5File h5((ctx.out_dir / "results.h5").string(), H5File::Mode::create);
  write_provenance(h5, ctx, "edmd");
  h5.attribute("/", "units", "sigma = 1, m = 1, k_B = 1; time sigma sqrt(m/energy)");
  {
    // The time series under /timeseries with the time axis t, the layout DSMC writes
    // (src/dsmc/output.cpp), so both solvers' results read alike. /series/<name> (time for
    // t) is the former layout, kept as soft links for existing scripts (docs/OUTPUT.md: to be
    // removed later). The checkpoint keeps its own names (checkpoint.cpp "series/*").
    std::vector<std::pair<std::string, const std::vector<double>*>> series{
        {"t", &s.time},
        {"temperature", &s.temperature},
        {"Z", &s.z},
        {"loss_rate", &s.energy_lost},
        {"heating_rate", &s.heating},
        {"background_rate", &s.background},
        {"collision_frequency", &s.collisions}};
    if (rough) series.emplace_back("rotational_temperature", &s.rotational_temperature);
    for (const auto& [name, values] : series) h5.write("/timeseries/" + name, *values);
    h5.attribute("/timeseries", "units",
                 std::string("t: time; temperature, rotational_temperature: energy; Z: 1; loss_rate, heating_rate, "
                             "background_rate: energy/(sigma^D time); collision_frequency: 1/time per grain"));
    for (const auto& [name, values] : series)
      h5.soft_link("/series/" + (name == "t" ? std::string("time") : name), "/timeseries/" + name);
  }
  if (rough) {
    for (const auto& [name, curve] : model_curves) {
      std::vector<double> a, b;
      for (const auto& x : curve) a.push_back(x.Ttr), b.push_back(x.Trot);
      h5.write("/theory/rough_model_" + name + "/Ttr", a);  // at /timeseries/t
      h5.write("/theory/rough_model_" + name + "/Trot", b);
    }
  }
  if (!c.free_cooling) {
    h5.write("/observables/gr/r", pairs.gr_radii());
    h5.write("/observables/gr/g", pairs.gr());
    h5.write("/observables/velocity_correlation/r", pairs.corr_radii());
    h5.write("/observables/velocity_correlation/parallel", pairs.parallel());
    h5.write("/observables/velocity_correlation/perpendicular", pairs.perpendicular());
    h5.write("/observables/velocity_distribution/v_over_sqrtT", vhist.centres());
    for (int d = 0; d < D; ++d) h5.write(std::string("/observables/velocity_distribution/") + "xyz"[d], vhist.density(d));
    // how many snapshots each average holds (those at fixed times only), for error estimates
    h5.attribute("/observables/gr", "snapshots", static_cast<std::int64_t>(pairs.snapshots));
    h5.attribute("/observables/velocity_correlation", "snapshots", static_cast<std::int64_t>(pairs.snapshots));
    h5.attribute("/observables/velocity_distribution", "snapshots", static_cast<std::int64_t>(std::llround(vhist.total / N)));
  }
  {
    std::vector<double> centres, dens;
    const double w = eng.vn_bin_width();
    const double tot = static_cast<double>(std::max<std::uint64_t>(1, f.collisions));
    // collisions beyond the last bin (600 bins of 0.02 sqrt(T0)): a gas that heated far above
    // T0 after the measurements began (a cold start with no equilibration)
    std::uint64_t binned = 0;
    for (std::uint64_t n : f.vn_histogram) binned += n;
    if (f.collisions > 0 && static_cast<double>(f.collisions - std::min(binned, f.collisions)) > 1e-3 * tot)
      std::fprintf(stderr,
                   "warning: %.3g %% of the collisions had normal speeds beyond the normal-speed histogram (%zu bins of "
                   "%.4g, 0.02 sqrt(T0) with T0 = %.4g at the start of the measurements; the gas heated after that: "
                   "equilibrate longer); /observables/normal_speed/density misses them\n",
                   100.0 * static_cast<double>(f.collisions - std::min(binned, f.collisions)) / tot,
                   f.vn_histogram.size(), w, rs.T0);
    for (std::size_t b = 0; b < f.vn_histogram.size(); ++b) {
      centres.push_back((b + 0.5) * w / std::sqrt(T_mean));
      dens.push_back(f.vn_histogram[b] / tot / (w / std::sqrt(T_mean)));
    }
    h5.write("/observables/normal_speed/vn_over_sqrtT", centres);  // Bizon Fig. 10 (normal component)
    h5.write("/observables/normal_speed/density", dens);
  }
  if (!traj_time.empty()) {
    // H5MD layout: /particles/all/position/{value,time,step}, /particles/all/box
    h5.write("/particles/all/position/value", traj_pos,
             {static_cast<hsize_t>(traj_time.size()), static_cast<hsize_t>(N), static_cast<hsize_t>(D)});
    h5.write("/particles/all/position/time", traj_time);
    h5.write("/particles/all/position/step", traj_step);
    std::vector<double> edges{box.x, box.y, box.z};
    edges.resize(static_cast<std::size_t>(D));
    h5.write("/particles/all/box/edges", edges);
    // H5MD 1.1 (de Buyl et al. 2014): integer dimension, one boundary string per axis
    // ("periodic" or "none"), version as the integer pair (1, 1), author and creator groups
    h5.attribute("/particles/all/box", "dimension", static_cast<std::int64_t>(D));
    std::vector<std::string> boundary;
    for (int d = 0; d < D; ++d) boundary.push_back(c.walls[d] ? "none" : "periodic");
    h5.attribute("/particles/all/box", "boundary", boundary);
    h5.attribute("/h5md", "version", std::vector<std::int64_t>{1, 1});
    h5.attribute("/h5md/author", "name", std::string("grainbath user"));
    h5.attribute("/h5md/creator", "name", std::string("grainbath"));
    h5.attribute("/h5md/creator", "version", std::string(GRAINBATH_VERSION));
  }
  // every numeric summary value but the wall-clock performance block, so that results.h5
  // is a function of case and seed alone (and a resumed run's file equals an uninterrupted one's)
  for (const auto& [k, val] : summary.entries()) {
    if (k.rfind("performance.", 0) == 0) continue;
    if (const double* d = std::get_if<double>(&val)) h5.attribute("/summary", k, *d);
  }
  if (c.profiles) {
    const ProfileResult pr = profiles.result();
    h5.write("/profiles/z", pr.centres);
    h5.attribute("/profiles", "axis", std::string(1, "xyz"[c.profile_axis]));
    h5.attribute("/profiles", "slab_volume", pr.slab_volume);
    h5.attribute("/profiles", "batches", static_cast<double>(pr.batches));
    for (const auto& fld : pr.fields) {
      h5.write("/profiles/" + fld.name, fld.mean);
      h5.write("/profiles/" + fld.name + "_stderr", fld.stderr_);
    }
    h5.write("/profiles/velocity_histogram/v", tails.centres());
    h5.write("/profiles/velocity_histogram/counts", tails.counts,
             {static_cast<hsize_t>(c.profile_slabs), static_cast<hsize_t>(D), static_cast<hsize_t>(tails.bins)});
    h5.write("/profiles/velocity_histogram/samples_per_slab", tails.samples);
  }
  if (c.transport) {
    h5.write("/transport/z_slab", tr.z_slab);
    h5.write("/transport/z_plane", tr.z_plane);
    h5.attribute("/transport", "axis", std::string(1, "xyz"[c.heating.profile_axis]));
    h5.attribute("/transport", "blocks", static_cast<double>(tr.blocks));
    for (const auto& fld : tr.fields) {
      h5.write("/transport/" + fld.name, fld.mean);
      h5.write("/transport/" + fld.name + "_stderr", fld.stderr_);
    }
    // raw block sums (layouts in src/edmd/transport.hpp) for offline re-analysis
    std::vector<double> bt, bs, bp;
    for (const auto& b : transport.blocks()) {
      bt.push_back(b.time);
      bs.insert(bs.end(), b.slab.begin(), b.slab.end());
      bp.insert(bp.end(), b.plane.begin(), b.plane.end());
    }
    const hsize_t nb = bt.size(), S = static_cast<hsize_t>(c.transport_slabs);
    h5.write("/transport/blocks/time", bt);
    h5.write("/transport/blocks/slab", bs, {nb, S, static_cast<hsize_t>(SlabTransport::kSlab)});
    h5.write("/transport/blocks/plane", bp, {nb, S, static_cast<hsize_t>(SlabTransport::kPlane)});
  }
  h5.close();  // a failed write (disk full) surfaces here, before the output is committed
}

}  // namespace

void run(const Config& c, const RunContext& ctx, Summary& summary) {
  // The threads serve only the snapshot measurements (the pair statistics of measure.cpp);
  // the CLI gives one unless [run] threads or OMP_NUM_THREADS asks for more (0: leave
  // OpenMP's own count, i.e. OMP_NUM_THREADS)
  if (ctx.threads > 0) omp_set_num_threads(ctx.threads);
  visit_law(c, [&](const auto& law) { run_with(law, c, ctx, summary); });
}

}  // namespace grainbath::edmd
