#pragma once
// Case sections shared by every solver: [restitution] and the uniform part of [background].
// Units (scaled, Bisi-Spiga): lengths in grain-grain mean free paths (DSMC) or grain
// diameters (EDMD), grain mass m, temperatures in energy units (k_B = 1).
#include <string>
#include <string_view>
#include <vector>

#include "core/case_file.hpp"
#include "operators/restitution.hpp"
#include "operators/walton.hpp"

namespace grainbath {

// Every restitution law a case may name, with its keys (for list-models and errors).
struct ModelDescription {
  std::string kind;   // "restitution", "heating", "boundary", "background profile", ...
  std::string name;
  std::string summary;
  std::vector<std::string> keys;  // "key (default, unit): meaning"
};
const std::vector<ModelDescription>& restitution_models();

// [restitution] law = "elastic" | "constant" | "power" | "bizon"; only the chosen law's keys
// are valid (a key of another law is reported as one, and so is [`trot_section`]
// rotational_temperature, walton's; when --set changed the law, the file's keys of the law
// it replaced are ignored with a note).
RestitutionLaw read_restitution(CaseReader& reader, std::string_view trot_section = "");

// [restitution] law = "walton": rough grains with spin (docs/rough.md; the solvers that carry
// spins read it instead of read_restitution, which rejects the law).
struct RoughParameters {
  WaltonRestitution law;
  double q = 0.5;                       // I / (m a^2)
  double rotational_temperature = 0.0;  // initial Trot = I <|omega|^2> / d_rot (energy)
};
// true if the case names law = "walton" (records the key as read)
bool names_walton(CaseReader& reader);
// e, beta0 (required), mu (default: never sliding), q (default `default_q`) from
// [restitution], and the initial Trot from [`trot_section`] rotational_temperature (default 0).
RoughParameters read_rough(CaseReader& reader, double default_q, std::string_view trot_section);

// Tells `reader` the sections and [sampling] keys that belong to the other solver than
// `solver` ("dsmc" or "edmd"), so finish() says so instead of "unknown".
void name_other_solver_keys(CaseReader& reader, std::string_view solver);

struct BackgroundParameters {
  double mass_ratio = 0.5;   // alpha = mB / (m + mB), in (0, 1)
  double density = 0.0;      // nB; 0 = no medium (free cooling)
  double temperature = 1.0;  // TB, energy units
  Vec3 velocity;             // uB
  double knudsen = 1.0;      // eps = background mean free path / grain-grain one
  bool present() const { return density > 0.0; }
};
// Reads mass_ratio, density, temperature, velocity, knudsen from [background].
BackgroundParameters read_background(CaseReader& reader);

}  // namespace grainbath
