#pragma once
// Slab-resolved hydrodynamic fields of the EDMD gas along one axis (docs/edmd.md "Slab
// profiles"): number density, mean velocity, temperature components, the full pressure
// tensor and the heat-flux vector, each with its kinetic part (from synchronised snapshots)
// and its collisional part (from every grain-grain collision, Irving-Kirkwood: the momentum
// and the transferred energy of a collision are spread over the slabs crossed by the
// segment joining the two centres).
//
// Units: sigma = 1, m = 1, k_B = 1. Slab "volume" = slab width times the cross-section
// (area in 3D, length in 2D). Pressure tensor P_ab = momentum flux (positive for a
// repulsive gas), heat flux q_a in the frame of the local mean velocity.
//
// Use: init(); engine.set_collision_hook(&SlabProfiles::collision_hook, &profiles);
// at each sampling time: add_snapshot(x, v) then end_interval(dt) with dt the time since
// the previous sampling time; result() for means and batch-mean standard errors.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "edmd/engine.hpp"
#include "operators/vec3.hpp"

namespace grainbath::edmd {

struct ProfileSetup {
  int dims = 3;
  Vec3 length{1, 1, 1};
  int axis = 2;              // the slab normal (0 = x, 1 = y, 2 = z); the wall-normal one in a channel
  int slabs = 20;
  bool periodic_axis = true;  // false: hard walls at 0 and L along the axis
};

// Raw sums of one block of sampling intervals. Kinetic moments per slab (kKin numbers):
// [0] count, [1..3] Sum v_a, [4..12] Sum v_a v_b (a*3+b), [13..15] Sum |v|^2 v_a; summed
// over the snapshots of the block. Collisional sums per slab (kColl numbers): [0..8]
// Sum J_a r_b f (a*3+b), [9..11] Sum dE_tr r_b f, [12] Sum of the energy changes of the
// grains (the collisional sink, half at each centre); f = fraction of the segment in the
// slab, J = impulse given to j, r = r_j - r_i, dE_tr = (dE_j - dE_i)/2 in the lab frame.
struct ProfileBlock {
  double snapshots = 0.0;
  double time = 0.0;         // total length of the sampling intervals
  std::vector<double> kin;   // slabs * kKin
  std::vector<double> coll;  // slabs * kColl
};

// Everything a checkpoint needs (issue #8): the setup and these members.
struct ProfileAccumulators {
  std::size_t block_intervals = 1;  // sampling intervals per stored block (doubles on merge)
  std::size_t open_intervals = 0;   // intervals already in `open`
  std::vector<ProfileBlock> blocks; // closed blocks, all of block_intervals intervals
  ProfileBlock open;                // the block being filled
  std::uint64_t collisions = 0;     // collisions seen by the hook
};

struct ProfileField {
  std::string name;               // e.g. "density", "T_x", "P_kin_xz", "q_col_z"
  std::vector<double> mean, stderr_;
};

struct ProfileResult {
  std::vector<double> centres;  // slab centres along the axis
  double slab_volume = 0.0;
  std::size_t batches = 0;      // batches behind the standard errors
  std::vector<ProfileField> fields;
  const ProfileField& field(const std::string& name) const;  // throws std::out_of_range
};

class SlabProfiles {
 public:
  static constexpr int kKin = 16;
  static constexpr int kColl = 13;
  static constexpr std::size_t kMaxBlocks = 256;  // merged pairwise beyond 2 * kMaxBlocks

  void init(const ProfileSetup& setup);
  const ProfileSetup& setup() const { return setup_; }
  // For Engine::set_collision_hook(&SlabProfiles::collision_hook, this).
  static void collision_hook(void* self, const CollisionRecord& c) {
    static_cast<SlabProfiles*>(self)->add_collision(c);
  }
  void add_collision(const CollisionRecord& c);
  // Kinetic moments of one synchronised snapshot (positions, velocities by particle).
  void add_snapshot(const std::vector<Vec3>& x, const std::vector<Vec3>& v);
  // Closes the sampling interval of length dt (time since the previous sampling time).
  void end_interval(double dt);
  // Means from all closed intervals, standard errors from up to `batches` batch means.
  ProfileResult result(std::size_t batches = 32) const;

  int slab_of(double z) const;  // slab index of a coordinate along the axis (wrapped / clamped)
  double slab_width() const { return width_; }
  double slab_volume() const { return volume_; }
  const ProfileAccumulators& accumulators() const { return acc_; }
  ProfileAccumulators& accumulators() { return acc_; }

  // Fields from one block of raw sums (the means use the sum of all blocks).
  std::vector<std::vector<double>> fields_of(const ProfileBlock& b) const;
  std::vector<std::string> field_names() const;

 private:
  void close_block();
  ProfileSetup setup_;
  double L_ = 1.0, width_ = 1.0, volume_ = 1.0;
  ProfileAccumulators acc_;
};

// Histograms of the lab-frame velocity components per slab (velocity-distribution tails,
// thesis ch. 9): counts[(slab * dims + component) * bins + bin] over [-vmax, vmax]; values
// outside land in the end bins' overflow counters (not in the histogram).
struct SlabVelocityHistograms {
  int dims = 2, slabs = 1, bins = 400;
  double vmax = 1.0;
  std::vector<double> counts;   // slabs * dims * bins
  std::vector<double> samples;  // grain samples per slab (normalisation)
  std::vector<double> outside;  // per slab and component: samples beyond +-vmax
  void init(int d, int nslabs, int nbins, double v_max);
  void add(const SlabProfiles& slabs_of, const std::vector<Vec3>& x, const std::vector<Vec3>& v);
  std::vector<double> centres() const;
};

}  // namespace grainbath::edmd
