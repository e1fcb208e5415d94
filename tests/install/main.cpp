// Solves a scalar filter DARE through the installed library and checks the closed form.
#include <kfx/riccati.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const double q = 0.3, r = 2.0;  // random walk: P = (q + sqrt(q^2 + 4 q r)) / 2
  const Eigen::MatrixXd one = Eigen::MatrixXd::Ones(1, 1);
  const kfx::DareSolution s = kfx::SolveFilterDare(one, one, q * one, r * one);
  const double expected = (q + std::sqrt(q * q + 4 * q * r)) / 2;
  std::printf("P = %.15g (expected %.15g)\n", s.P_pred(0, 0), expected);
  return s.summary.ok() && std::abs(s.P_pred(0, 0) - expected) < 1e-12 ? 0 : 1;
}
