#pragma once
// A small, exact-in-time reference simulation of the homogeneous kinetic equation
// df/dt = (1/eps) J_EL + J_IN, written for the closures tests from the collision rules alone
// (Bisi-Spiga eqs. 3, 5, 6 and the rates of docs/closures.md Sec. 0), independent of src/dsmc.
//
// Direct simulation with null events (Gillespie with majorants): background candidates at
// total rate N (nB/eps) Gb, grain-pair candidates at rate (N/2) n Gg; a candidate with
// relative speed |g| is accepted with probability |g|/G. There is no time step, so the only
// approximations are N (the Boltzmann limit, O(1/N)) and the majorants (raised on the rare
// candidate that exceeds them).
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "closures/closures.hpp"

namespace grainbath::closures::test {

struct Moments {
  std::array<double, 3> u;
  double T, a2;
};

class ReferenceSimulation {
 public:
  ReferenceSimulation(const Parameters& p, int N, unsigned long seed) : p_(p), rng_(seed), v_(N) {}

  void init_maxwellian(const std::array<double, 3>& u, double T) {
    const double s = std::sqrt(T / p_.mass);
    for (auto& v : v_)
      for (int a = 0; a < 3; ++a) v[a] = u[a] + s * normal_(rng_);
    // Majorants from the initial state; raised on demand later (a candidate above them is
    // accepted with probability 1 instead of |g|/G: a bias only on those rare events).
    const double thB = p_.TB * (1.0 - p_.alpha) / (p_.alpha * p_.mass);
    double U = 0;
    for (int a = 0; a < 3; ++a) U += (u[a] - p_.uB[a]) * (u[a] - p_.uB[a]);
    Gb_ = std::sqrt(U) + 7.0 * s + 7.0 * std::sqrt(thB);
    Gg_ = 10.0 * s;
  }

  // Advance to absolute time t_end.
  void run_until(double t_end) {
    const int N = static_cast<int>(v_.size());
    const double thB = p_.TB / (p_.alpha * p_.mass / (1.0 - p_.alpha));
    for (;;) {
      const double Rb = N * p_.nB / p_.eps * Gb_, Rg = 0.5 * N * p_.n * Gg_;
      const double R = Rb + Rg;
      const double dt = -std::log(1.0 - uni_(rng_)) / R;
      if (t_ + dt > t_end) {
        t_ = t_end;  // memoryless: restarting the clock at t_end is exact
        return;
      }
      t_ += dt;
      if (uni_(rng_) * R < Rb) {
        auto& v = v_[pick(N)];
        std::array<double, 3> g;
        const double sb = std::sqrt(thB);
        for (int a = 0; a < 3; ++a) g[a] = v[a] - (p_.uB[a] + sb * normal_(rng_));
        const double gm = norm(g);
        if (gm > Gb_) Gb_ = 1.2 * gm;
        if (uni_(rng_) * Gb_ >= gm) continue;
        const auto n = apse(g, gm);
        const double gn = dot(g, n);
        for (int a = 0; a < 3; ++a) v[a] -= 2.0 * p_.alpha * gn * n[a];  // eq. 3
      } else {
        const int i = pick(N);
        int j = pick(N - 1);
        if (j >= i) ++j;
        std::array<double, 3> g;
        for (int a = 0; a < 3; ++a) g[a] = v_[i][a] - v_[j][a];
        const double gm = norm(g);
        if (gm > Gg_) Gg_ = 1.2 * gm;
        if (uni_(rng_) * Gg_ >= gm) continue;
        const auto n = apse(g, gm);
        const double gn = dot(g, n);
        double e = 1.0 - 2.0 * p_.beta * std::pow(std::abs(gn), p_.delta);  // eq. 5
        if (e < 0.0) e = 0.0;
        const double k = 0.5 * (1.0 + e) * gn;  // eq. 6
        for (int a = 0; a < 3; ++a) {
          v_[i][a] -= k * n[a];
          v_[j][a] += k * n[a];
        }
      }
    }
  }

  Moments moments() const {
    const double N = static_cast<double>(v_.size());
    std::array<double, 3> u{0, 0, 0};
    for (const auto& v : v_)
      for (int a = 0; a < 3; ++a) u[a] += v[a] / N;
    double c2 = 0, c4 = 0;
    for (const auto& v : v_) {
      const double q = (v[0] - u[0]) * (v[0] - u[0]) + (v[1] - u[1]) * (v[1] - u[1]) + (v[2] - u[2]) * (v[2] - u[2]);
      c2 += q;
      c4 += q * q;
    }
    c2 /= (N - 1.0);
    c4 /= N;
    const double th = c2 / 3.0;
    return {u, p_.mass * th, c4 / (15.0 * th * th) - 1.0};
  }
  double time() const { return t_; }

 private:
  static double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  }
  static double norm(const std::array<double, 3>& a) { return std::sqrt(dot(a, a)); }
  int pick(int N) { return std::min(N - 1, static_cast<int>(uni_(rng_) * N)); }
  // apse unit vector with density |g.n|/(2 pi |g|) on S^2: |cos| = sqrt(U), uniform azimuth
  std::array<double, 3> apse(const std::array<double, 3>& g, double gm) {
    const std::array<double, 3> e3{g[0] / gm, g[1] / gm, g[2] / gm};
    std::array<double, 3> t = std::abs(e3[0]) < 0.9 ? std::array<double, 3>{1, 0, 0}
                                                    : std::array<double, 3>{0, 1, 0};
    const double d = dot(t, e3);
    for (int a = 0; a < 3; ++a) t[a] -= d * e3[a];
    const double tn = norm(t);
    const std::array<double, 3> e1{t[0] / tn, t[1] / tn, t[2] / tn};
    const std::array<double, 3> e2{e3[1] * e1[2] - e3[2] * e1[1], e3[2] * e1[0] - e3[0] * e1[2],
                                   e3[0] * e1[1] - e3[1] * e1[0]};
    const double mu = std::sqrt(uni_(rng_)), sn = std::sqrt(1.0 - mu * mu);
    const double psi = 2.0 * M_PI * uni_(rng_);
    return {mu * e3[0] + sn * (std::cos(psi) * e1[0] + std::sin(psi) * e2[0]),
            mu * e3[1] + sn * (std::cos(psi) * e1[1] + std::sin(psi) * e2[1]),
            mu * e3[2] + sn * (std::cos(psi) * e1[2] + std::sin(psi) * e2[2])};
  }

  Parameters p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uni_{0.0, 1.0};
  std::vector<std::array<double, 3>> v_;
  double t_ = 0.0;
  double Gb_ = 1.0, Gg_ = 1.0;  // majorants, raised on demand
};

}  // namespace grainbath::closures::test
