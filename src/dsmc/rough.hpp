#pragma once
// Rough grains (Walton's rule, operators/walton.hpp; docs/rough.md sec. 7) in homogeneous
// DSMC: spins, the grain-grain NTC step with Walton collisions, the rotational temperature,
// and the mean-field models A-E beside the run (closures/rough).
//
// DSMC has no grain radius (lengths are mean free paths), and Walton's rule involves the spin
// only through a*omega: the state stores s = a*omega (velocity units) and applies the rule
// with a = 1. Then Trot = I <|omega|^2>/3 = q m <|s|^2>/3 (three rotational degrees of
// freedom: DSMC grains are spheres).
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "closures/rough.hpp"
#include "dsmc/collision_groups.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

// Gaussian spins from their own stream (keyed on the grain id) rescaled to exactly the case's
// initial Trot; adds their energy to s.initial_kinetic_energy (the budget counts rotation).
void initialise_spins(State& s, const Config& c, std::uint64_t seed);

// Grain-grain collisions of a homogeneous run over c.dt: Bird's no-time-counter candidates
// at rate (N n g_max dt / 2), accepted with |g|/g_max, apse direction n with density
// ~ (g.n)_+ (so the pair rate is ~ (g.n)_+, which the spin does not change: Walton's g_n
// involves v only), then walton_collision on (v, s). In the collision groups of the step
// (`[dsmc] collision_group`, src/dsmc/collision_groups.hpp; `groups` and `per_group` are the
// caller's scratch), in parallel, or with collision_group = 0 in one cell as before.
void rough_grain_step(State& s, const Config& c, std::uint64_t seed, CollisionGroups& groups,
                      std::vector<GrainCounters>& per_group);

double rotational_energy(const State& s, const Config& c);
double rotational_temperature(const State& s, const Config& c);

// Closures beside the run (free cooling or driven by nothing but the collisions: H = 0):
// parameters with nu = G sqrt(Ttr), G = 4 n / sqrt(pi m) (cross-section 1: nu = n <|g|>), 3D.
closures::rough::Parameters rough_parameters(const Config& c);
// `grainbath theory` / the summary's theory block for rough grains: without a medium, models
// A-E integrated from the case's initial (Ttr, Trot) to t_end ("rough.model_X.Ttr_at_t_end",
// "...Trot_at_t_end"); with a medium none (the models have no bath term).
std::vector<std::pair<std::string, double>> rough_theory_values(const Config& c);
// Models A-E integrated from the first sample (Ttr, Trot) at times t: names
// "rough_model_X/Ttr", "rough_model_X/Trot".
std::vector<std::pair<std::string, std::vector<double>>> rough_model_series(const Config& c, const std::vector<double>& t,
                                                                            double Ttr0, double Trot0);

}  // namespace grainbath::dsmc
