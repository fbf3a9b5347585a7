// The EDMD case reader (src/edmd/driver.cpp read_config) and what it turns into the theory
// values (theory_values): the checks between keys name the key they concern, the bounds hold
// at their edges, and a theory is given only where it predicts the run. Found by the mutation
// audit of the EDMD reader (docs/reviews/mutation-audit-edmd-reader.md): each test below
// fails with one of its mutations; the defaults are in tests/docs/test_case_file_defaults.py.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include "core/case_file.hpp"
#include "edmd/edmd.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {

const std::string kBase = "[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.1\n";

// Every problem read_config and finish() report for `toml`, one "file:line: key: message" a line.
std::string problems(const std::string& toml) {
  CaseReader r(toml, "t.toml");
  try {
    read_config(r);
    r.finish();
  } catch (const CaseError& e) {
    std::string all;
    for (const auto& p : e.problems()) all += p.to_string() + "\n";
    return all;
  }
  return "";
}

// The notes read_config and finish() print for `toml` (stderr), the case being valid.
std::string notes(const std::string& toml) {
  CaseReader::forget_said_notes();
  CaseReader r(toml, "t.toml");
  ::testing::internal::CaptureStderr();
  read_config(r);
  r.finish();
  return ::testing::internal::GetCapturedStderr();
}

Config config(const std::string& toml) {
  CaseReader r(toml, "t.toml");
  Config c = read_config(r);
  r.finish();
  return c;
}

std::map<std::string, double> theory(const std::string& toml) {
  std::map<std::string, double> m;
  for (const auto& [k, v] : theory_values(config(toml))) m[k] = v;
  return m;
}

}  // namespace

TEST(EdmdCaseReader, ChecksBetweenKeysNameTheKeyTheyConcern) {
  struct T {
    std::string extra, key, what;
  };
  const std::string air = "[heating]\nmodel = \"air_table\"\nacceleration = 1.0\n";
  const std::vector<T> cases = {
      {"[walls]\ndirections = [\"z\"]\n", "walls.directions", "a wall in z cuts a 2D box"},
      {"[walls]\ndirections = [\"x\", \"x\"]\n", "walls.directions", "direction x given twice"},
      {"[walls]\ndirections = [\"x\"]\ndriving_speed = 1.0\ndriving_speed_high = 2.0\n", "walls.driving_speed",
       "give either driving_speed (both walls) or driving_speed_low/_high, not both"},
      // the key the case gives, with its line (until 2026-12-06: walls.driving_speed, no line)
      {"[walls]\ndriving_speed_low = 1.0\n", "walls.driving_speed_low", "need exactly one wall direction"},
      {"[walls]\ndirections = [\"x\", \"y\"]\nrestitution_high = 0.9\n", "walls.restitution_high",
       "driving walls (or per-wall restitution) need exactly one wall direction in [walls] directions, found 2"},
      // equal to restitution: no per-wall driving, so no wall to apply it to
      {"[walls]\nrestitution_low = 1.0\n", "walls.restitution_low", "there are no walls to apply it to"},
      {"aspect = [2.0]\n", "edmd.aspect", "expected an array of 2"},
      {"aspect = [0.0, 1.0]\n", "edmd.aspect", "> 0"},
      {air + "profile = \"tent\"\naxis = \"z\"\n", "heating.axis", "axis z is not a direction of a 2D box"},
      {air + "profile = \"tent\"\naxis = \"x\"\n[walls]\ndirections = [\"x\"]\n", "heating.axis",
       "the forcing profile needs a periodic axis, found walls in x"},
      {air + "profile = \"shear\"\ncomponent = \"y\"\n", "heating.component",
       "the biased component must be a box direction other than the axis, found y"},
      {air + "profile = \"tent\"\nbias = 0.1\n", "heating.bias",
       "used only with profile = \"shear\", found profile = \"tent\""},
      {"[background]\ndensity = 1.0\nvelocity = [0.0, 0.0, 1.0]\n", "background.velocity", "a 2D medium cannot drift in z"},
      {"[background]\ndensity = 1.0\n[sampling]\nfree_cooling = true\n", "sampling.free_cooling",
       "free cooling needs [heating] model = \"none\", no background medium"},
      {"[sampling]\nfree_cooling = true\n[profiles]\n", "profiles.slabs", "profiles need a steady state"},
      {air + "[transport]\n", "transport.slabs", "[transport] needs [heating] model = \"air_table\" with profile"},
      {air + "profile = \"tent\"\n[background]\ndensity = 1.0\n[transport]\n", "transport.slabs",
       "[transport] does not book a background medium"},
      {air + "profile = \"tent\"\n[transport]\nfit_inner = 0.5\nfit_outer = 0.5\n", "transport.fit_outer",
       "must exceed fit_inner"},
      // the collapse guard names the wall's own key
      {air + "[walls]\ndirections = [\"x\"]\nrestitution_high = 0.5\ndriving_speed_low = 1.0\n",
       "walls.restitution_high", "the air table with a static wall of restitution < 1 collapses"},
  };
  for (const auto& t : cases) {
    SCOPED_TRACE(t.extra);
    const std::string all = problems(kBase + t.extra);
    EXPECT_NE(all.find(": " + t.key + ": "), std::string::npos) << all;
    EXPECT_NE(all.find(t.what), std::string::npos) << all;
  }
  // (the line of the key given: [walls] is line 5 after kBase's four)
  const std::string high = problems(kBase + "[walls]\ndirections = [\"x\", \"y\"]\nrestitution_high = 0.9\n");
  EXPECT_NE(high.find("t.toml:7: walls.restitution_high: driving walls"), std::string::npos) << high;
}

TEST(EdmdCaseReader, ABoxEdgeBelowThreeDiametersBlamesTheKeyThatMadeIt) {
  // N = 2 at nu = 0.3: edge sqrt(2 pi / 1.2) = 2.29 sigma in both directions (a lattice of
  // spacing 1.14 sigma: it starts, but the cells need 3 sigma)
  const std::string few = problems("[edmd]\ndimensions = 2\nparticles = 2\npacking_fraction = 0.3\n");
  EXPECT_NE(few.find(": edmd.particles: the box edge in x is 2.28"), std::string::npos) << few;
  // the same volume made long and thin by the aspect: blamed on the aspect
  const std::string thin = problems(kBase + "aspect = [1.0, 100.0]\n");
  EXPECT_NE(thin.find(": edmd.aspect: the box edge in x is "), std::string::npos) << thin;
}

TEST(EdmdCaseReader, BoundsHoldAtTheirEdges) {
  // a sampling interval equal to the measurement is allowed (two samples), a longer one is not
  EXPECT_EQ(problems(kBase + "collisions = 2.0\n[sampling]\ninterval = 2.0\n"), "");
  const std::string wn = "[heating]\nmodel = \"white_noise\"\nkick = 0.1\n";
  EXPECT_EQ(problems(kBase + wn + "rate = 1000\n"), "");
  EXPECT_NE(problems(kBase + wn + "rate = 1001\n").find(": heating.rate: expected an integer in [1, 1000], found 1001"),
            std::string::npos);
  EXPECT_NE(problems(kBase + "[heating]\nmodel = \"air_table\"\nacceleration = 0.0\n").find(": heating.acceleration: "),
            std::string::npos);
  const std::string tent = "[heating]\nmodel = \"air_table\"\nacceleration = 1.0\nprofile = \"tent\"\n";
  EXPECT_NE(problems(kBase + tent + "[transport]\nslabs = 3\n").find(": transport.slabs: expected an integer in [4, "),
            std::string::npos);
  EXPECT_EQ(problems(kBase + tent + "[transport]\nslabs = 4\n"), "");
  EXPECT_NE(problems(kBase + "[walls]\ndirections = [\"x\"]\nrestitution_high = 0.0\n").find(": walls.restitution_high: "),
            std::string::npos);
  EXPECT_NE(problems(kBase + "[profiles]\nvelocity_bins = 1\n").find(": profiles.velocity_bins: "), std::string::npos);
  EXPECT_NE(problems(kBase + "[transport]\nfit_outer = 1.5\n").find(": transport.fit_outer: expected a value in [0.0, 1.0]"),
            std::string::npos);
}

TEST(EdmdCaseReader, TheLatticeStartHoldsUpToSpacingOneAndSaysTheLargestPacking) {
  // 100 disks on a 10 x 10 lattice: spacing sqrt(pi / (4 nu)), 1 at nu = pi/4 = 0.7854
  EXPECT_EQ(problems("[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.78\n"), "");
  const std::string over = problems("[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.79\n");
  EXPECT_NE(over.find(": edmd.packing_fraction: expected packing_fraction <= 0.785398 for 100 grains, found 0.79"),
            std::string::npos)
      << over;
  // 1000 spheres on 10^3 sites: the largest is pi/6 = 0.523599 (spacing^3, not ^2)
  const std::string spheres = problems("[edmd]\ndimensions = 3\nparticles = 1000\npacking_fraction = 0.6\n");
  EXPECT_NE(spheres.find("expected packing_fraction <= 0.523599 for 1000 grains, found 0.6"), std::string::npos)
      << spheres;
}

TEST(EdmdCaseReader, ACheckpointIntervalFromTheWholeRunOnIsSaid) {
  // equilibrate + collisions = 3: every = 3 writes no periodic checkpoint, every = 2.5 does
  const std::string run = kBase + "equilibrate = 1.0\ncollisions = 2.0\n[checkpoint]\n";
  EXPECT_NE(notes(run + "every = 3.0\n").find("checkpoint.every: every = 3.0 >= equilibrate + collisions = 3.0"),
            std::string::npos);
  EXPECT_EQ(notes(run + "every = 2.5\n").find("checkpoint.every"), std::string::npos);
}

TEST(EdmdCaseReader, TheoryValuesAreGivenOnlyWhereTheyPredictTheRun) {
  const std::string inelastic = kBase + "[restitution]\nlaw = \"constant\"\ne = 0.9\n";
  EXPECT_EQ(theory(inelastic).count("edmd.Z_enskog"), 1u);
  // walls in y (not only in x) make the gas inhomogeneous
  EXPECT_EQ(theory(inelastic + "[walls]\ndirections = [\"y\"]\n").count("edmd.Z_enskog"), 0u);
  // rough grains exchange energy with their spins: not Enskog's smooth-grain pressure
  EXPECT_EQ(theory(kBase + "[restitution]\nlaw = \"walton\"\ne = 0.9\nbeta0 = 0.5\n").count("edmd.Z_enskog"), 0u);
  // e depends on the impact speed: the run weights it with its own collisions instead
  EXPECT_EQ(theory(kBase + "[restitution]\nlaw = \"bizon\"\n").count("edmd.Z_enskog"), 0u);
  EXPECT_EQ(theory(kBase + "[restitution]\nlaw = \"power\"\nbeta = 0.05\n").count("edmd.Z_enskog"), 0u);
  // the medium: its steady T only undriven; a DSMC counterpart only for spheres
  const std::string medium = "[background]\ndensity = 1.0\n";
  const auto undriven = theory(inelastic + medium);
  EXPECT_EQ(undriven.count("edmd.medium_steady_temperature"), 1u);
  EXPECT_EQ(undriven.count("edmd.dsmc_equivalent_grain_density"), 0u);
  EXPECT_EQ(theory(inelastic + medium + "[heating]\nmodel = \"white_noise\"\nkick = 0.1\n")
                .count("edmd.medium_steady_temperature"),
            0u);
  const auto spheres = theory("[edmd]\ndimensions = 3\nparticles = 1000\npacking_fraction = 0.1\n" + medium);
  EXPECT_EQ(spheres.count("edmd.dsmc_equivalent_grain_density"), 1u);
  // the heat-bath balance: white noise or the Boltzmann bath as the only source, smooth grains
  const std::string wn = "[heating]\nmodel = \"white_noise\"\nkick = 0.1\n";
  EXPECT_EQ(theory(inelastic + wn).count("edmd.heating_balance_temperature"), 1u);
  EXPECT_EQ(theory(inelastic + "[heating]\nmodel = \"boltzmann\"\n").count("edmd.heating_balance_temperature"), 1u);
  EXPECT_EQ(theory(inelastic + "[heating]\nmodel = \"air_table\"\nacceleration = 1.0\n")
                .count("edmd.heating_balance_temperature"),
            0u);
  EXPECT_EQ(theory(inelastic + wn + medium).count("edmd.heating_balance_temperature"), 0u);
  EXPECT_EQ(theory(inelastic + wn + "[walls]\ndirections = [\"y\"]\n").count("edmd.heating_balance_temperature"), 0u);
  EXPECT_EQ(theory(kBase + "[restitution]\nlaw = \"walton\"\ne = 0.9\nbeta0 = 0.5\n" + wn)
                .count("edmd.heating_balance_temperature"),
            0u);
  EXPECT_EQ(theory(inelastic).count("edmd.heating_balance_temperature"), 0u);
}

// `theory` gives the box's edges with the aspect applied, whose product is the volume the
// packing fraction sets: N pi/4 / nu (disks), N pi/6 / phi (spheres).
TEST(EdmdCaseReader, TheoryGivesTheBoxEdgesWithTheAspect) {
  const auto disks = theory("[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.3\naspect = [1.0, 4.0]\n");
  ASSERT_EQ(disks.count("edmd.box.x"), 1u);
  EXPECT_EQ(disks.count("edmd.box.z"), 0u);
  EXPECT_NEAR(disks.at("edmd.box.y") / disks.at("edmd.box.x"), 4.0, 1e-12);
  EXPECT_NEAR(disks.at("edmd.box.x") * disks.at("edmd.box.y"), 400 * std::numbers::pi / 4.0 / 0.3, 1e-9);
  const auto spheres =
      theory("[edmd]\ndimensions = 3\nparticles = 500\npacking_fraction = 0.2\naspect = [1.0, 2.0, 3.0]\n");
  ASSERT_EQ(spheres.count("edmd.box.z"), 1u);
  EXPECT_NEAR(spheres.at("edmd.box.z") / spheres.at("edmd.box.x"), 3.0, 1e-12);
  EXPECT_NEAR(spheres.at("edmd.box.x") * spheres.at("edmd.box.y") * spheres.at("edmd.box.z"),
              500 * std::numbers::pi / 6.0 / 0.2, 1e-9);
}

TEST(EdmdCaseReader, WallBalanceTheoryUsesTheEdgeBetweenTheWalls) {
  // the same channel turned by 90 degrees: walls in x with aspect [2, 1], walls in y with [1, 2]
  const std::string law = "[restitution]\nlaw = \"constant\"\ne = 0.9\n";
  const auto x = theory(kBase + "aspect = [2.0, 1.0]\n" + law + "[walls]\ndirections = [\"x\"]\ndriving_speed = 1.0\n");
  const auto y = theory(kBase + "aspect = [1.0, 2.0]\n" + law + "[walls]\ndirections = [\"y\"]\ndriving_speed = 1.0\n");
  for (const char* k : {"edmd.wall_balance_temperature", "edmd.wall_balance_temperature_dilute"}) {
    ASSERT_EQ(x.count(k), 1u) << k;
    ASSERT_EQ(y.count(k), 1u) << k;
    EXPECT_NEAR(y.at(k), x.at(k), 1e-12 * x.at(k)) << k;
  }
}

TEST(EdmdCaseReader, RoughTheoryCountsEveryKickedPair) {
  // white noise injects rate * kick^2 per collision: rate 2 with kick k is rate 1 with kick k sqrt 2
  const std::string rough = kBase + "[restitution]\nlaw = \"walton\"\ne = 0.9\nbeta0 = 0.5\n";
  const auto two = theory(rough + "[heating]\nmodel = \"white_noise\"\nrate = 2\nkick = 0.1\n");
  const auto one = theory(rough + "[heating]\nmodel = \"white_noise\"\nrate = 1\nkick = " +
                          std::to_string(0.1 * std::sqrt(2.0)) + "\n");
  ASSERT_EQ(two.count("edmd.rough.model_A.Ttr"), 1u);
  EXPECT_NEAR(two.at("edmd.rough.model_A.Ttr"), one.at("edmd.rough.model_A.Ttr"), 1e-5 * one.at("edmd.rough.model_A.Ttr"));
}
