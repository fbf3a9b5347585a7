// The engine's two event queues give the same run: src/edmd/engine.cpp is compiled twice into
// this program, once with the bucketed EventCalendar (the default) and once with the indexed
// heap (-DGRAINBATH_EDMD_HEAP, built by no configuration otherwise), and the calendar runs
// with its links deferred and not (`calendar_defer`; the engine defers only at N >= 50000,
// which no other default-tier test reaches). Each run prints its end state bit for bit; the
// ctest `edmd_queue_parity` requires the three outputs to be identical
// (docs/reviews/mutation-audit-event-calendar.md, "Open").
//
// Not a gtest: linking grainbath_edmd would bring the other queue's engine (one definition
// of Engine per program). The start is made here: 2500 disks on a square lattice at
// packing fraction 0.5, velocities from the counter-based generator.
//
// usage: edmd_queue_parity_{calendar,heap} DEFER (-1, 0 or 1)
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numbers>
#include <vector>

#include "edmd/engine.hpp"
#include "operators/random.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
std::uint64_t fnv(std::uint64_t h, double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  for (int b = 0; b < 8; ++b) h = (h ^ ((bits >> (8 * b)) & 0xffu)) * 1099511628211ull;
  return h;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DEFER\n", argv[0]);
    return 2;
  }
  const int side = 50, n = side * side;
  const double nu = 0.5;
  const double L = std::sqrt(n * std::numbers::pi / 4.0 / nu);  // nu = n pi sigma^2 / (4 L^2)
  EngineSetup setup;
  setup.dims = 2;
  setup.length = {L, L, 1.0};
  setup.seed = 11;
  setup.calendar_defer = std::atoi(argv[1]);
  setup.heating.kind = HeatingKind::white_noise;
  setup.heating.kick = 0.1;
  std::vector<Vec3> r(n), v(n);
  CounterRng rng(11, Stream::initial_velocities, 0, 0);
  for (int k = 0; k < n; ++k) {
    r[k] = {(k % side + 0.5) * L / side, (k / side + 0.5) * L / side, 0.0};
    v[k] = {rng.normal(), rng.normal(), 0.0};
  }
  Engine eng(setup, r, v);
  // 40 collisions per disk: 4 scheduled rebuilds (re-bases of the calendar), white-noise
  // kicks and inelastic collisions keeping the event times spread
  eng.advance(ConstantRestitution{0.9}, std::numeric_limits<double>::infinity(), 40ull * n);
  eng.synchronize();
  std::uint64_t h = 1469598103934665603ull;
  for (int id = 0; id < n; ++id) {
    const Vec3 p = eng.position(id), u = eng.velocity(id);
    for (double x : {p.x, p.y, u.x, u.y}) h = fnv(h, x);
  }
  const Counters& c = eng.counters();
  std::printf("time %a\ncollisions %llu\nevents %llu\nstale %llu\nrebuilds %llu\nstate %016llx\n", eng.time(),
              static_cast<unsigned long long>(c.collisions), static_cast<unsigned long long>(c.events),
              static_cast<unsigned long long>(c.stale), static_cast<unsigned long long>(eng.rebuilds()),
              static_cast<unsigned long long>(h));
  return 0;
}
