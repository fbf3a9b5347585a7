#pragma once
// A stand-alone, event-free Monte Carlo of the homogeneously driven 2D rough gas
// (docs/rough.md sec. 5): N particles with planar velocities and spins along z, no positions.
// Per time step dt:
//   1. driving (thesis sec. 10, white noise on the translational velocities only): every
//      velocity component gets an independent kick N(0, H dt / m), so dTtr/dt = H; the mean
//      velocity is then removed (input (1 - 1/N) H into the thermal motion);
//   2. collisions by Bird's no-time-counter scheme: candidate pairs (i, j) with a normal n
//      uniform on the circle at rate (N/2) c' g_max, accepted with probability
//      (v_ij.n)_+ / g_max, so every particle collides at rate nu = c' E[(v_ij.n)_+]; with
//      c' = G sqrt(pi m) this is nu = G sqrt(Ttr) for Gaussian velocities (eq. R1). Accepted
//      pairs collide by Walton's rule (operators/walton.hpp).
// Molecular chaos holds by construction; the velocity distributions are whatever the dynamics
// makes them, so the comparison with the Gaussian mean-field models tests that assumption.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "operators/walton.hpp"

namespace grainbath::rough_test {

struct DrivenMcConfig {
  WaltonRestitution law;
  double q = 0.4;   // I / (m a^2)
  double G = 1.0;   // nu = G sqrt(Ttr)
  double H = 1.0;   // driving power per particle, dTtr/dt
  int N = 2000;
  unsigned long seed = 1;
};

class DrivenMc {
 public:
  static constexpr double m = 1.0, a = 0.5;

  // Gaussian start with temperatures Ttr0, Trot0.
  DrivenMc(const DrivenMcConfig& c, double Ttr0, double Trot0)
      : c_(c), I_(c.q * m * a * a), rng_(c.seed), v_(c.N), w_(c.N) {
    std::normal_distribution<double> N(0.0, 1.0);
    const double sv = std::sqrt(Ttr0 / m), sw = std::sqrt(Trot0 / I_);
    for (int i = 0; i < c.N; ++i) {
      v_[i] = {sv * N(rng_), sv * N(rng_), 0.0};
      w_[i] = {0.0, 0.0, sw * N(rng_)};
    }
    remove_mean();
    gmax_ = 6.0 * std::sqrt(2.0 * Ttr0 / m) + 1e-12;
  }

  double Ttr() const {  // (m/2) <|v|^2>, 2 degrees of freedom
    double s = 0.0;
    for (const Vec3& v : v_) s += norm2(v);
    return 0.5 * m * s / c_.N;
  }
  double Trot() const {  // I <w_z^2>, 1 degree of freedom
    double s = 0.0;
    for (const Vec3& w : w_) s += w.z * w.z;
    return I_ * s / c_.N;
  }
  double time() const { return t_; }
  const std::vector<Vec3>& velocities() const { return v_; }
  const std::vector<Vec3>& spins() const { return w_; }
  long collisions() const { return collisions_; }
  long sliding() const { return sliding_; }

  void step(double dt) {
    if (c_.H > 0.0) {
      std::normal_distribution<double> N(0.0, std::sqrt(c_.H * dt / m));
      for (Vec3& v : v_) {
        v.x += N(rng_);
        v.y += N(rng_);
      }
      remove_mean();
    }
    const double cprime = c_.G * std::sqrt(std::numbers::pi * m);
    candidates_ += 0.5 * c_.N * cprime * gmax_ * dt;
    std::uniform_int_distribution<int> pick(0, c_.N - 1);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    while (candidates_ >= 1.0) {
      candidates_ -= 1.0;
      const int i = pick(rng_);
      int j = pick(rng_);
      while (j == i) j = pick(rng_);
      const double phi = 2.0 * std::numbers::pi * U(rng_);
      const Vec3 n{std::cos(phi), std::sin(phi), 0.0};
      const double gn = dot(v_[i] - v_[j], n);
      if (gn <= 0.0) continue;
      if (gn > gmax_) gmax_ = gn;  // Bird's adaptive bound (rare after the first steps)
      if (U(rng_) * gmax_ >= gn) continue;
      const WaltonOutcome o = walton_collision(v_[i], v_[j], w_[i], w_[j], n, a, c_.q, c_.law, m);
      ++collisions_;
      if (o.sliding) ++sliding_;
    }
    t_ += dt;
  }

 private:
  void remove_mean() {
    Vec3 mean{};
    for (const Vec3& v : v_) mean += v;
    mean *= 1.0 / c_.N;
    for (Vec3& v : v_) v -= mean;
  }

  DrivenMcConfig c_;
  double I_;
  std::mt19937_64 rng_;
  std::vector<Vec3> v_, w_;
  double gmax_ = 1.0, candidates_ = 0.0, t_ = 0.0;
  long collisions_ = 0, sliding_ = 0;
};

}  // namespace grainbath::rough_test
