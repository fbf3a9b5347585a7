// Reading a DSMC case: [grains], [background], [restitution], [dsmc], [sampling],
// [domain] (spatial runs), [checkpoint]. Every key, default and unit: docs/CASE_FILE.md.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/checkpoint.hpp"
#include "core/h5.hpp"
#include "dsmc/collision_groups.hpp"
#include "dsmc/dsmc.hpp"

namespace grainbath::dsmc {

const char* to_string(Boundary b) {
  switch (b) {
    case Boundary::periodic: return "periodic";
    case Boundary::specular: return "specular";
    case Boundary::diffuse: return "diffuse";
    case Boundary::open: return "open";
  }
  return "?";
}

double Config::wavenumber() const {
  return 2.0 * std::numbers::pi * grains.wavenumber_index / domain.length[0];
}

const std::vector<ModelDescription>& dsmc_models() {
  static const std::vector<ModelDescription> models = {
      {"boundary", "periodic", "particles leaving one face re-enter through the opposite one", {}},
      {"boundary", "specular", "mirror reflection: the normal velocity is reversed", {}},
      {"boundary", "diffuse",
       "re-emission with the flux-weighted Maxwellian of the wall temperature",
       {"[domain] wall_temperature (TB, energy)"}},
      {"boundary", "open", "particles leaving the box are removed (free outflow, no inflow)", {}},
      // the medium's own keys (review 4: list-models showed them only under the EDMD medium)
      {"background medium", "[background]",
       "Bisi-Spiga linear elastic operator: hard-sphere collisions with a Maxwellian medium at rate (nB/eps)|v - w|",
       {"density (0, >= 0, 1/volume): nB; 0: no medium", "knudsen (1, > 0): eps, the Knudsen number",
        "temperature (1, > 0, energy): TB", "mass_ratio (0.5, (0, 1)): alpha = mB/(m + mB)",
        "velocity ([0,0,0], velocity): uB", "profile (uniform): see the background profiles below"}},
      {"background profile", "uniform", "nB, uB, TB constant ([background] density, velocity, temperature)", {}},
      {"background profile", "isobaric_sine",
       "TB(x) = TB0 (1 + A sin kx), nB TB = const, uB = 0 (a steady Euler solution)",
       {"amplitude (0, dimensionless, |A| < 1): A", "wavenumber_index (1, integer): k = 2 pi index / length_x"}},
      {"background profile", "shear",
       "uB = (U0 sin(k y), 0, 0), nB and TB uniform (a steady inviscid Euler solution); needs dimensions >= 2",
       {"amplitude (0, velocity): U0", "wavenumber_index (1, integer): k = 2 pi index / length_y"}},
      {"background profile", "file",
       "per-cell nB, TB, uB from an HDF5 file with datasets density [cells], temperature [cells], velocity [cells x 3] "
       "(cells in x-fastest order, shape matching [domain] cells)",
       {"file (required, path relative to the case directory)"}},
      {"grain profile", "uniform", "uniform initial grain density", {}},
      {"grain profile", "mode", "n0 (1 + A cos kx) initial density",
       {"amplitude (0.1, |A| < 1)", "wavenumber_index (1, integer): k = 2 pi index / length_x"}},
  };
  return models;
}

namespace {

std::string join_names(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "\"" : ", \"") + x + "\"";
  return s;
}

Boundary parse_boundary(const std::string& s) {
  if (s == "specular") return Boundary::specular;
  if (s == "diffuse") return Boundary::diffuse;
  if (s == "open") return Boundary::open;
  return Boundary::periodic;
}

void read_domain(CaseReader& r, Config& c) {
  Domain& d = c.domain;
  d.dimensions = static_cast<int>(r.integer_required("domain", "dimensions", 1, 3));
  const auto dims = static_cast<std::size_t>(d.dimensions);
  const auto len = r.reals("domain", "length", std::vector<double>(dims, 10.0), dims, dims, Bounds::positive());
  std::vector<double> cells_default(dims, 10.0);
  const auto cells = r.reals("domain", "cells", cells_default, dims, dims, Bounds::closed(1, 1e7));
  for (std::size_t a = 0; a < dims && a < len.size() && a < cells.size(); ++a) {
    d.length[a] = len[a];
    if (cells[a] != std::floor(cells[a])) {
      r.problem("domain", "cells", "element " + std::to_string(a) + ": expected a whole number of cells, found " +
                                       std::to_string(cells[a]));
    }
    d.cells[a] = static_cast<int>(cells[a]);
  }
  const std::vector<std::string> valid = {"periodic", "specular", "diffuse", "open"};
  const auto names = r.texts("domain", "boundaries", {"periodic"});
  const std::size_t nfaces = 2 * dims;
  if (names.size() != 1 && names.size() != dims && names.size() != nfaces) {
    r.problem("domain", "boundaries",
              "expected 1 name (all faces), " + std::to_string(dims) + " (one per axis) or " + std::to_string(nfaces) +
                  " (lo and hi per axis), found " + std::to_string(names.size()));
  }
  for (const auto& n : names)
    if (std::find(valid.begin(), valid.end(), n) == valid.end())
      r.problem("domain", "boundaries", "unknown boundary \"" + n + "\"; valid: periodic, specular, diffuse, open");
  for (std::size_t f = 0; f < 6; ++f) {
    std::string name = "periodic";
    if (f < nfaces) {
      if (names.size() == 1) name = names[0];
      else if (names.size() == dims) name = names[f / 2];
      else if (names.size() == nfaces) name = names[f];
    }
    d.faces[f] = parse_boundary(name);
  }
  for (std::size_t a = 0; a < dims; ++a)
    if ((d.faces[2 * a] == Boundary::periodic) != (d.faces[2 * a + 1] == Boundary::periodic))
      r.problem("domain", "boundaries", "axis " + std::string(1, "xyz"[a]) +
                                            ": a periodic face needs a periodic opposite face");
  d.wall_temperature = r.real("domain", "wall_temperature", c.background.temperature, Bounds::positive(), "energy");
  // As for any key the run would not use: no silent acceptance (a forgotten "diffuse"?). When
  // --set changed the boundaries, the file's wall_temperature is dropped with a note instead,
  // as the keys of a law --set replaced (physics_config.cpp), so boundaries can be scanned.
  if (r.has("domain", "wall_temperature") &&
      std::none_of(d.faces.begin(), d.faces.begin() + static_cast<std::ptrdiff_t>(nfaces),
                   [](Boundary b) { return b == Boundary::diffuse; })) {
    if (r.overridden("domain", "boundaries") && !r.overridden("domain", "wall_temperature"))
      r.ignore("domain", "wall_temperature",
               "ignored: no face is \"diffuse\" with --set domain.boundaries = [" + join_names(names) + "]");
    else
      r.problem("domain", "wall_temperature",
                "not used: no face is \"diffuse\" (wall_temperature is the temperature of diffuse walls; "
                "[domain] boundaries here: " + join_names(names) + ")");
  }
}

// The keys a profile of `kind` ("background profile", "grain profile") reads: the first word
// of each key description in dsmc_models(), the registry `list-models` prints.
std::vector<std::string> profile_keys(std::string_view kind, std::string_view profile) {
  std::vector<std::string> keys;
  for (const auto& m : dsmc_models())
    if (m.kind == kind && m.name == profile)
      for (const auto& k : m.keys) keys.push_back(k.substr(0, k.find(' ')));
  return keys;
}

// A key of another profile is not "unknown": say which profiles read it (as for the keys of
// another restitution law, core/physics_config.cpp). When --set changed the profile, the
// file's keys of the profile it replaced are ignored with a note, so that
// `--set background.profile=uniform` works without editing the file.
void reject_other_profile_keys(CaseReader& r, std::string_view section, std::string_view kind,
                               const std::string& profile) {
  const std::string file_profile = r.overridden(section, "profile") ? r.file_string(section, "profile") : "";
  const std::vector<std::string> mine = profile_keys(kind, profile);
  // a key both profiles read may mean different things (amplitude: A, dimensionless, for
  // isobaric_sine; U0, a velocity, for shear): the file's value is not carried over silently
  if (!file_profile.empty() && file_profile != profile) {
    const std::vector<std::string> file_keys = profile_keys(kind, file_profile);
    for (const auto& key : mine)
      if (std::find(file_keys.begin(), file_keys.end(), key) != file_keys.end() && r.has(section, key) &&
          !r.overridden(section, key))
        r.problem(section, key,
                  "the file's value is profile = \"" + file_profile + "\"'s, and --set " + std::string(section) +
                      ".profile = \"" + profile + "\" reads this key too, perhaps with another meaning (see grainbath "
                      "list-models): give it with --set " + std::string(section) + "." + key + "=VALUE");
  }
  std::vector<std::string> seen;
  for (const auto& m : dsmc_models()) {
    if (m.kind != kind || m.name == profile) continue;
    for (const auto& key : profile_keys(kind, m.name)) {
      if (std::find(mine.begin(), mine.end(), key) != mine.end() || !r.has(section, key)) continue;
      if (std::find(seen.begin(), seen.end(), key) != seen.end()) continue;
      seen.push_back(key);
      const std::vector<std::string> file_keys = profile_keys(kind, file_profile);
      if (!file_profile.empty() && file_profile != profile && !r.overridden(section, key) &&
          std::find(file_keys.begin(), file_keys.end(), key) != file_keys.end()) {
        r.ignore(section, key,
                 "ignored: a key of the file's profile = \"" + file_profile + "\", which --set " + std::string(section) +
                     ".profile = \"" + profile + "\" replaces");
        continue;
      }
      std::string owners;
      for (const auto& o : dsmc_models()) {
        if (o.kind != kind) continue;
        const auto ok = profile_keys(kind, o.name);
        if (std::find(ok.begin(), ok.end(), key) != ok.end())
          owners += (owners.empty() ? "\"" : " or \"") + o.name + "\"";
      }
      std::string own;
      for (const auto& k : mine) own += (own.empty() ? "" : ", ") + k;
      r.used_elsewhere(section, key,
                       "not used by profile = \"" + profile + "\" (it is a key of profile = " + owners + "; " +
                           (own.empty() ? "profile = \"" + profile + "\" takes no keys of its own"
                                        : "keys of profile = \"" + profile + "\": " + own) +
                           "; see grainbath list-models)");
    }
  }
}

void read_background_field(CaseReader& r, Config& c, const std::string& case_dir) {
  BackgroundField& f = c.field;
  const std::string profile =
      r.choice("background", "profile", "uniform", {"uniform", "isobaric_sine", "shear", "file"});
  if (profile == "isobaric_sine") f.profile = BackgroundProfile::isobaric_sine;
  if (profile == "shear") f.profile = BackgroundProfile::shear;
  if (profile == "file") f.profile = BackgroundProfile::file;
  // a profile that is no profile (already reported) says nothing about which keys are right
  const auto named = r.resolved().find("background.profile");
  if (named == r.resolved().end() || named->second == "\"" + profile + "\"")
    reject_other_profile_keys(r, "background", "background profile", profile);
  if (f.profile != BackgroundProfile::uniform && !c.spatial())
    r.problem("background", "profile", "profile \"" + profile + "\" needs a spatial run: add a [domain] section");
  // uB is a constant of the uniform medium only; the other profiles set it themselves
  // (src/dsmc/spatial.cpp, local_background), and a given velocity would be dropped without
  // a word while velocity.final and the density mode's phase still used it (mutation audit of
  // the fused step and the spatial code, S14)
  if (f.profile != BackgroundProfile::uniform && r.has("background", "velocity"))
    r.problem("background", "velocity",
              "not used by profile = \"" + profile + "\", which sets the medium's velocity itself (" +
                  (f.profile == BackgroundProfile::isobaric_sine ? std::string("uB = 0: at rest, at uniform pressure")
                   : f.profile == BackgroundProfile::shear
                       ? std::string("uB = (U0 sin(2 pi n y / Ly), 0, 0): give U0 as background.amplitude")
                       : std::string("the file's velocity in each cell")) +
                  "): remove it, or use profile = \"uniform\" for a drifting medium");
  if (f.profile == BackgroundProfile::isobaric_sine) {
    f.amplitude = r.real("background", "amplitude", 0.0, Bounds::open(-1.0, 1.0));
    f.wavenumber_index = static_cast<int>(r.integer("background", "wavenumber_index", 1, 1, 1 << 20));
  } else if (f.profile == BackgroundProfile::shear) {
    f.amplitude = r.real("background", "amplitude", 0.0, Bounds::any(), "velocity");
    f.wavenumber_index = static_cast<int>(r.integer("background", "wavenumber_index", 1, 1, 1 << 20));
    if (c.domain.dimensions < 2)
      r.problem("background", "profile", "profile \"shear\" (uB_x varying in y) needs dimensions >= 2");
  } else if (f.profile == BackgroundProfile::file) {
    f.file = r.text("background", "file", "");
    if (f.file.empty()) {
      r.problem("background", "file", "missing: profile = \"file\" needs file = \"grid.h5\"");
      return;
    }
    const std::string path = (f.file.front() == '/') ? f.file : case_dir + "/" + f.file;
    try {
      H5File h(path, H5File::Mode::read);
      std::vector<hsize_t> dn, dt, dv;
      f.grid_density = h.read_doubles("density", &dn);
      f.grid_temperature = h.read_doubles("temperature", &dt);
      f.grid_velocity = h.read_doubles("velocity", &dv);
      const std::size_t cells = c.domain.cell_count();
      bool usable = true;
      if (f.grid_density.size() != cells || f.grid_temperature.size() != cells || f.grid_velocity.size() != 3 * cells)
        usable = false, r.problem("background", "file",
                  path + ": expected density and temperature with " + std::to_string(cells) +
                      " values and velocity with " + std::to_string(3 * cells) + " (the [domain] cells), found " +
                      std::to_string(f.grid_density.size()) + ", " + std::to_string(f.grid_temperature.size()) +
                      " and " + std::to_string(f.grid_velocity.size()));
      // the layouts a grid may have (docs/CASE_FILE.md): flat, or the cells' array with x
      // fastest ([nz, ny, nx] in 3D), velocity with the 3 components of a cell together (a
      // last axis of 3). The right count in another order ([3, cells] for the velocity, x
      // slowest) would be read scrambled, so it is refused with the shape found.
      if (usable) {
        std::vector<hsize_t> grid;  // the domain's cells, slowest axis first
        for (int a = c.domain.dimensions - 1; a >= 0; --a) grid.push_back(static_cast<hsize_t>(c.domain.cells[a]));
        const auto text = [](const std::vector<hsize_t>& d) {
          std::string t = "[";
          for (std::size_t k = 0; k < d.size(); ++k) t += (k ? ", " : "") + std::to_string(d[k]);
          return t + "]";
        };
        const auto n = static_cast<hsize_t>(cells);
        std::vector<hsize_t> grid3 = grid;
        grid3.push_back(3);
        const std::vector<std::pair<const char*, const std::vector<hsize_t>*>> scalars{{"density", &dn},
                                                                                        {"temperature", &dt}};
        for (const auto& [name, d] : scalars)
          if (*d != std::vector<hsize_t>{n} && *d != grid) {
            r.problem("background", "file", path + ": " + name + " has the shape " + text(*d) + ": expected " +
                                                text({n}) + (grid.size() > 1 ? " or " + text(grid) : "") +
                                                " (the [domain] cells, x fastest)");
            usable = false;
          }
        if (dv != std::vector<hsize_t>{3 * n} && dv != std::vector<hsize_t>{n, 3} && dv != grid3) {
          r.problem("background", "file", path + ": velocity has the shape " + text(dv) + ": expected " +
                                              text({3 * n}) + ", " + text({n, 3}) +
                                              (grid.size() > 1 ? " or " + text(grid3) : "") +
                                              " (the 3 components of a cell together, cells x fastest)" +
                                              (dv == std::vector<hsize_t>{3, n} ? ": write its transpose" : ""));
          usable = false;
        }
      }
      for (std::size_t i = 0; i < f.grid_density.size() && i < f.grid_temperature.size(); ++i)
        if (!(f.grid_density[i] >= 0) || !(f.grid_temperature[i] > 0)) {
          r.problem("background", "file", path + ": cell " + std::to_string(i) +
                                              ": expected density >= 0 and temperature > 0, found density " +
                                              format_real(f.grid_density[i]) + ", temperature " +
                                              format_real(f.grid_temperature[i]));
          usable = false;
          break;
        }
      if (usable) {
        // what the run takes from the file, so that a grid changed in place under the same
        // name is noticed on --resume and by `sweep --resume` (CaseReader::record_file_checksum)
        Fnv1a sum;
        for (const std::vector<double>* a : {&f.grid_density, &f.grid_temperature, &f.grid_velocity}) {
          sum.add_length(a->size());
          sum.add_elements(*a);
        }
        r.record_file_checksum("background", "file_checksum", sum.h);
      }
    } catch (const std::exception& e) {
      r.problem("background", "file", std::string(e.what()) + " (expected datasets density, temperature, velocity)");
    }
  }
}

}  // namespace

Config read_config(CaseReader& r) {
  Config c;
  const std::string case_dir = [&] {
    const std::string& f = r.file();
    const auto slash = f.rfind('/');
    return slash == std::string::npos ? std::string(".") : f.substr(0, slash);
  }();
  name_other_solver_keys(r, "dsmc");
  c.grains.density = r.real("grains", "density", 1.0, Bounds::positive(), "grains per volume");
  c.grains.mass = r.real("grains", "mass", 1.0, Bounds::positive(), "mass");
  c.grains.temperature = r.real("grains", "temperature", 1.0, Bounds::positive(), "energy");
  c.grains.drift = r.vec3("grains", "drift", {});
  c.background = read_background(r);
  if (r.has_section("domain")) read_domain(r, c);
  read_background_field(r, c, case_dir);
  const std::string gprofile = r.choice("grains", "profile", "uniform", {"uniform", "mode"});
  if (const auto named = r.resolved().find("grains.profile");
      named == r.resolved().end() || named->second == "\"" + gprofile + "\"")
    reject_other_profile_keys(r, "grains", "grain profile", gprofile);
  if (gprofile == "mode") {
    c.grains.profile = GrainProfile::mode;
    c.grains.amplitude = r.real("grains", "amplitude", 0.1, Bounds::open(-1.0, 1.0));
    c.grains.wavenumber_index = static_cast<int>(r.integer("grains", "wavenumber_index", 1, 1, 1 << 20));
    if (!c.spatial()) r.problem("grains", "profile", "profile \"mode\" needs a spatial run: add a [domain] section");
  }
  if (names_walton(r)) {
    c.rough = read_rough(r, 0.4, "grains");  // DSMC grains are spheres: q = 2/5
    if (c.spatial())
      r.problem("restitution", "law", "law \"walton\" (rough grains) is implemented for homogeneous runs only (no [domain])");
  } else {
    c.restitution = read_restitution(r, "grains");
  }
  c.particles = r.integer("dsmc", "particles", 100000, 2, 2'000'000'000);
  c.dt = r.real("dsmc", "dt", 0.01, Bounds::positive(), "time");
  c.t_end = r.real("dsmc", "t_end", 10.0, Bounds::positive(), "time");
  c.rebalance_every = r.integer("dsmc", "rebalance_every", 50, 0, 1'000'000'000);
  c.exact_bound = r.choice("dsmc", "bound", "exact", {"exact", "bird"}) == "exact";
  if (!c.spatial()) {
    c.collision_group = r.integer("dsmc", "collision_group", 4096, 0, 1'000'000'000);
    if (c.collision_group > 0 && c.collision_group < static_cast<std::int64_t>(kMinCollisionGroup))
      r.problem("dsmc", "collision_group",
                "expected 0 (all grains in one collision cell) or at least " + std::to_string(kMinCollisionGroup) +
                    " grains (16 tiles of 64), found " + std::to_string(c.collision_group));
  }
  c.sample_every = r.real("sampling", "every", c.dt * 10, Bounds::positive(), "time");
  c.steady_from = r.real("sampling", "steady_from", 0.5 * c.t_end, Bounds::non_negative(), "time");
  c.histogram_bins = static_cast<int>(r.integer("sampling", "histogram_bins", 100, 4, 100000));
  c.histogram_range = r.real("sampling", "histogram_range", 6.0, Bounds::positive(), "thermal speeds");
  c.relaxation_theory = r.boolean("sampling", "relaxation_theory", true);
  // the relaxation curves exist for homogeneous runs only (the moment ODEs; for rough grains
  // models A-E, which have no medium): elsewhere the key is read (resolved parameters, and so
  // resuming, unchanged) but says it does nothing
  if (r.has("sampling", "relaxation_theory") && (c.spatial() || (c.rough && c.background.present())))
    r.ignore("sampling", "relaxation_theory",
             c.spatial() ? "no effect in a spatial run: the relaxation curves are of homogeneous runs only"
                         : "no effect: the rough-grain models A-E have no background medium");
  if (c.spatial()) {
    c.sample_fields = r.boolean("sampling", "fields", true);
    c.field_batches = static_cast<int>(r.integer("sampling", "field_batches", 16, 2, 1024));
    if (c.grains.profile == GrainProfile::mode) {
      c.mode_fit_from = r.real("sampling", "mode_fit_from", 0.0, Bounds::non_negative(), "time");
      c.mode_fit_to = r.real("sampling", "mode_fit_to", c.t_end, Bounds::positive(), "time");
    }
  }
  // keys of a spatial run or of its density mode, where this run has neither: say whose they
  // are rather than "unknown key" (as for the keys of another law or profile)
  const char* mode_fit = "not used without [grains] profile = \"mode\" in a spatial run (the fit of the density mode's decay)";
  if (!c.spatial()) {
    const char* spatial = "not used by a homogeneous run (a key of spatial runs, with a [domain] section: the per-cell fields)";
    r.used_elsewhere("sampling", "fields", spatial);
    r.used_elsewhere("sampling", "field_batches", spatial);
  }
  if (!c.spatial() || c.grains.profile != GrainProfile::mode) {
    r.used_elsewhere("sampling", "mode_fit_from", mode_fit);
    r.used_elsewhere("sampling", "mode_fit_to", mode_fit);
  }
  if (c.spatial()) {
    const double per_cell = static_cast<double>(c.particles) / static_cast<double>(c.domain.cell_count());
    if (per_cell < 2.0)
      r.problem("dsmc", "particles", "expected at least 2 particles per cell on average (" +
                                         std::to_string(c.domain.cell_count()) + " cells), found " +
                                         std::to_string(per_cell));
  }
  c.checkpoint = read_checkpoint_settings(r, "time");
  // Checks between two keys name both values and where each came from (a line or --set).
  auto value = [&](std::string_view sec, std::string_view key, double x) {
    return std::string(key) + " = " + format_real(x) + " (" + r.origin(sec, key) + ")";
  };
  if (c.dt > c.t_end)
    r.problem("dsmc", "dt", "expected dt <= t_end, found " + value("dsmc", "dt", c.dt) + " > " +
                                value("dsmc", "t_end", c.t_end), "dsmc", "t_end");
  c.steps = static_cast<std::int64_t>(std::ceil(c.t_end / c.dt - 1e-9));
  // the run takes whole steps: a t_end that is no multiple of dt is reached by the next whole
  // step, and said (docs/CASE_FILE.md: a value not used as written gets a note)
  if (c.dt <= c.t_end && std::abs(static_cast<double>(c.steps) * c.dt - c.t_end) > 1e-9 * c.t_end)
    r.note("dsmc", "t_end",
           "t_end = " + format_real(c.t_end) + " is not a whole number of steps of dt = " + format_real(c.dt) +
               ": the run takes " + std::to_string(c.steps) + " steps, to t = " +
               format_real(static_cast<double>(c.steps) * c.dt));
  c.sample_every_steps = std::max<std::int64_t>(1, std::llround(c.sample_every / c.dt));
  // samples are taken at whole steps: a value that is no multiple of dt is rounded, and said
  // (review 4: every = 0.001 at dt = 0.01 ran at 0.01 without a word)
  if (r.has("sampling", "every") && std::abs(static_cast<double>(c.sample_every_steps) * c.dt - c.sample_every) >
                                        1e-9 * c.sample_every)
    r.note("sampling", "every",
           "every = " + format_real(c.sample_every) + " is not a whole number of steps of dt = " + format_real(c.dt) +
               ": samples are taken every " + std::to_string(c.sample_every_steps) + " step" +
               (c.sample_every_steps > 1 ? "s" : "") + ", every " +
               format_real(static_cast<double>(c.sample_every_steps) * c.dt));
  if (c.steady_from >= c.t_end) {
    r.problem("sampling", "steady_from",
              "expected steady_from < t_end, so the averaging window is not empty, found " +
                  value("sampling", "steady_from", c.steady_from) + " >= " + value("dsmc", "t_end", c.t_end),
              "dsmc", "t_end");
  } else if (r.has("sampling", "every") && c.sample_every > c.t_end - c.steady_from) {
    // the steady window [steady_from, t_end] would hold one sample at most: no error bar (the
    // default, 10 dt, is left alone: short test runs take it without asking for a window)
    r.problem("sampling", "every",
              "expected every <= t_end - steady_from (the averaging window), found " +
                  value("sampling", "every", c.sample_every) + " > " + value("dsmc", "t_end", c.t_end) + " - " +
                  value("sampling", "steady_from", c.steady_from),
              "dsmc", "t_end");
  }
  // a periodic checkpoint interval longer than the run writes none (SIGINT still writes one)
  if (c.checkpoint.every > 0 && c.checkpoint.every >= c.t_end)
    r.note("checkpoint", "every",
           "every = " + format_real(c.checkpoint.every) + " >= t_end = " + format_real(c.t_end) +
               ": no periodic checkpoint is written in this run (an interruption still writes one)");
  if (c.steps > 2'000'000'000)
    r.problem("dsmc", "dt",
              "t_end / dt is more than 2e9 steps, found " + value("dsmc", "t_end", c.t_end) + " / " +
                  value("dsmc", "dt", c.dt),
              "dsmc", "t_end");
  return c;
}

}  // namespace grainbath::dsmc
