#pragma once
// Transport bookkeeping for Bizon's inhomogeneous-forcing experiments (Sec. V; docs/edmd.md
// "Transport coefficients"): exact per-slab energy and momentum balances and the fluxes
// through the slab planes, from which the thermal conductivity (Fourier, eq. 2) and the
// shear viscosity (Newton, eq. 38) follow.
//
// Slabs k = 0..S-1 of width w = L/S along the (periodic) axis z; plane k sits at z = k w, the
// lower face of slab k. Every free-flight piece (Engine::set_move_hook) is cut at the planes
// it crosses: the grain carries its kinetic energy E(t_c) and momentum v(t_c) through the
// plane (kinetic fluxes) and the air-table force does the work E(t_b) - E(t_a) on it while it
// is inside a slab (input), with E(t) = |v0 + a t|^2/2. Every grain-grain collision (hook)
// sinks (dE_i + dE_j)/2 at each centre and moves the transferred energy (dE_j - dE_i)/2 and
// the impulse J from slab(i) to slab(j) through the planes between them (Irving-Kirkwood
// through planes, the collisional fluxes). With the stored energy / momentum of each slab
// at the sampling times, the balance storage = input + sink + flux in - flux out holds per
// slab to round-off by construction (tested). Every grain's slab is tracked by counting
// its crossings, so round-off at a plane can never put a grain in two slabs.
//
// Units: sigma = 1, m = 1, k_B = 1; fluxes per unit cross-section (a length in 2D) and time.
#include <cstdint>
#include <string>
#include <vector>

#include "edmd/engine.hpp"
#include "edmd/profile.hpp"
#include "operators/vec3.hpp"

namespace grainbath::edmd {

struct TransportSetup {
  int dims = 2;
  Vec3 length{1, 1, 1};
  int axis = 1;       // z of Bizon Sec. V
  int component = 0;  // y of eqs. 35-38: the momentum component whose flux along z is P_yz
  int slabs = 32;
};

// Raw sums of one block of sampling intervals.
// Per slab (kSlab): [0] work of the forcing, [1] impulse of the forcing (component), [2] the
// collisional sink (<= 0), [3] Int N dt, [4..6] Int Sum v_a dt, [7..15] Int Sum v_a v_b dt
// (a*3+b), [16] stored energy change, [17] stored momentum change (component), [18] stored
// momentum change along the axis, [19] forcing impulse along the axis, [20..22] collisional
// virial Sum r_ij,a J_b for (a, b) = (c, c), (z, z), (z, c), each collision's share split over
// the slabs by the fraction of the centre-to-centre segment inside them (Irving-Kirkwood),
// for the volume-averaged pressure tensor (Bizon Fig. 15: normal stress difference).
// Per plane (kPlane), crossings counted + upward (increasing z): [0] Sum +-E kinetic,
// [1] Sum +-dE_tr collisional, [2] Sum +-v_c kinetic, [3] Sum +-J_c collisional, [4] Sum +-v_z,
// [5] Sum +-J_z, [6] net grain crossings.
struct TransportBlock {
  double time = 0.0;
  std::vector<double> slab, plane;
};

// Everything SlabTransport carries between sampling intervals, as flat arrays for the EDMD
// checkpoint (taken at a scheduled rebuild, where every free flight has been cut at the
// rebuild time in an uninterrupted run as well, so the sums continue bitwise).
struct TransportCheckpoint {
  std::vector<double> stored;   // slab contents at the last sample: energy, component momentum, axis momentum (3 S)
  std::vector<double> blocks;   // closed blocks, rows [time, slab sums (S kSlab), plane sums (S kPlane)]
  std::vector<double> open;     // the open block, one row alike
  std::vector<std::uint64_t> slab_of;  // by id: the tracked slab
  std::vector<std::uint64_t> counts;   // block_intervals, open_intervals, closed blocks
};

// name, mean, stderr_ per slab or plane (the slab-profile field type)
using TransportField = ProfileField;

// Derived fields (jackknife over the blocks). Slab fields at the slab centres, plane fields
// at the planes z = k w.
struct TransportResult {
  std::vector<double> z_slab, z_plane;
  std::size_t blocks = 0;
  std::vector<TransportField> fields;
  const TransportField& field(const std::string& name) const;  // throws std::out_of_range
};

class SlabTransport {
 public:
  static constexpr int kSlab = 23;
  static constexpr int kPlane = 7;
  static constexpr std::size_t kMaxBlocks = 32;  // merged pairwise beyond 2 * kMaxBlocks

  void init(const TransportSetup& setup, std::size_t particles);
  const TransportSetup& setup() const { return setup_; }
  double slab_width() const { return width_; }
  double cross_section() const { return cross_; }
  // Start of the measurement: every grain's slab and the stored contents from a
  // synchronised state (positions, velocities by id).
  void begin(const std::vector<Vec3>& x, const std::vector<Vec3>& v);
  // Closes a sampling interval of length dt at a synchronised state (velocities by id).
  void end_interval(double dt, const std::vector<Vec3>& v);

  static void move_hook(void* self, std::uint32_t id, const Vec3& r0, const Vec3& v0, const Vec3& r1, const Vec3& v1,
                        const Vec3& a, double dt) {
    static_cast<SlabTransport*>(self)->add_move(id, r0, v0, r1, v1, a, dt);
  }
  static void collision_hook(void* self, const CollisionRecord& c) {
    static_cast<SlabTransport*>(self)->add_collision(c);
  }
  void add_move(std::uint32_t id, const Vec3& r0, const Vec3& v0, const Vec3& r1, const Vec3& v1, const Vec3& a,
                double dt);
  void add_collision(const CollisionRecord& c);

  // All closed intervals summed.
  TransportBlock total() const;
  const std::vector<TransportBlock>& blocks() const { return blocks_; }
  int slab_of_particle(std::uint32_t id) const { return slab_[id]; }

  // Checkpoint: save() the state; load() restores it into a SlabTransport init()-ed from the
  // same case (throws std::runtime_error if the layout differs: slabs, particles, or the
  // stored slab contents do not match `begun`, whether begin() had run).
  TransportCheckpoint save() const;
  void load(const TransportCheckpoint& ck, bool begun);

 private:
  void add_piece(int k, const Vec3& v0, const Vec3& a, double ta, double tb, double Ea, double Eb, double ca,
                 double cb, double za, double zb);
  void cross(int plane, int sign, double E, double vc, double vz);
  void contents(const std::vector<Vec3>& v, std::vector<double>& e, std::vector<double>& pc,
                std::vector<double>& pz) const;
  TransportSetup setup_;
  double L_ = 1.0, width_ = 1.0, cross_ = 1.0;
  std::vector<int> slab_;  // by id: tracked slab
  std::vector<double> e_prev_, pc_prev_, pz_prev_;
  std::size_t block_intervals_ = 1, open_intervals_ = 0;
  std::vector<TransportBlock> blocks_;
  TransportBlock open_;
};

// Calls two collision hooks (slab profiles and transport bookkeeping in the same run).
struct CollisionHookPair {
  CollisionHook first = nullptr;
  void* first_context = nullptr;
  CollisionHook second = nullptr;
  void* second_context = nullptr;
  static void call(void* self, const CollisionRecord& c) {
    const auto* p = static_cast<const CollisionHookPair*>(self);
    p->first(p->first_context, c);
    p->second(p->second_context, c);
  }
};

// What the analysis needs besides the sums.
struct TransportAnalysis {
  enum Kind { conductivity, viscosity } kind = conductivity;
  // conductivity: planes whose distance from the forcing peak (z = L/2), in units of L/2,
  // lies in [fit_inner, fit_outer] enter the summary kappa/kappa_Enskog
  double fit_inner = 0.2, fit_outer = 0.8;
  // ... and of those, the planes whose local packing is below the hard-disk fluid limit
  // (liquid-hexatic coexistence starts at nu = 0.700, Bernard & Krauth 2011) give
  // kappa_over_enskog_fluid: Enskog is a fluid theory; colder, denser planes crystallise
  double fluid_packing = 0.70;
};

// Fields of one (summed) block. Names (slab): density, packing, u_c, u_z, T, T_c, T_z,
// work_rate, loss_rate, storage_rate, forcing_density (component impulse per volume and
// time); (plane): energy_flux_kin, energy_flux_col, energy_flux, energy_flux_balance
// (integrated from plane 0 with the measured flux there), energy_flux_bizon (integrated from
// plane 0 with zero flux there and no storage term, Bizon Fig. 12), T_plane, dTdz, kappa
// (-flux/dTdz), kappa_enskog (local packing and T), kappa_ratio, P_cz_kin, P_cz_col, P_cz,
// P_zz, dudz, mu_enskog, net_flux, balance_residual (energy), momentum_residual.
std::vector<TransportField> transport_fields(const SlabTransport& t, const TransportBlock& b);
// Means with jackknife standard errors over the stored blocks.
TransportResult transport_result(const SlabTransport& t);

// Scalars of the summary, each with a jackknife standard error.
struct TransportScalar {
  std::string name;
  double value = 0.0, stderr_ = 0.0;
};
std::vector<TransportScalar> transport_scalars(const SlabTransport& t, const TransportAnalysis& an);

}  // namespace grainbath::edmd
