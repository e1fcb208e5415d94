#include "kfx/spring_mass_chain.hpp"

#include <cmath>

#include "kfx/discretize.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

bool SpringMassChainOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  const Index N = masses.size();
  if (N < 1) return fail("masses: expected at least one mass");
  if (!masses.allFinite() || (masses.array() <= 0.0).any()) return fail("masses: expected positive finite masses");
  if (stiffness.size() != N + 1) {
    return fail("stiffness: expected " + std::to_string(N + 1) + " spring constants, got " +
                std::to_string(stiffness.size()));
  }
  if (damping.size() != N + 1) {
    return fail("damping: expected " + std::to_string(N + 1) + " damper constants, got " +
                std::to_string(damping.size()));
  }
  if (!stiffness.allFinite() || (stiffness.array() < 0.0).any()) {
    return fail("stiffness: expected finite values >= 0");
  }
  if (!damping.allFinite() || (damping.array() < 0.0).any()) return fail("damping: expected finite values >= 0");
  if (!(dt > 0.0) || !std::isfinite(dt)) return fail("dt: expected a positive step");
  if (first_mass < 0 || first_mass > N) {
    return fail("first_mass: expected 0 or a mass in 1.." + std::to_string(N) + ", got " + std::to_string(first_mass));
  }
  return true;
}

SpringMassChainOptions UniformChain(int N, double m, double k, double c, bool left_fixed, bool right_fixed, double dt) {
  if (N < 1) throw Error("N: expected at least one mass, got " + std::to_string(N));
  SpringMassChainOptions o;
  o.masses = VectorXd::Constant(N, m);
  o.stiffness = VectorXd::Constant(N + 1, k);
  o.damping = VectorXd::Constant(N + 1, c);
  o.left_fixed = left_fixed;
  o.right_fixed = right_fixed;
  o.dt = dt;
  return o;
}

namespace {

MatrixXd Tridiagonal(const VectorXd& e, bool left_fixed, bool right_fixed) {
  const Index N = e.size() - 1;
  MatrixXd K = MatrixXd::Zero(N, N);
  for (Index i = 0; i <= N; ++i) {  // element i joins mass i and i + 1 (1-based)
    const bool left_wall = i == 0, right_wall = i == N;
    if ((left_wall && !left_fixed) || (right_wall && !right_fixed)) continue;
    if (!left_wall) K(i - 1, i - 1) += e(i);
    if (!right_wall) K(i, i) += e(i);
    if (!left_wall && !right_wall) {
      K(i - 1, i) -= e(i);
      K(i, i - 1) -= e(i);
    }
  }
  return K;
}

}  // namespace

SpringMassChain BuildSpringMassChain(const SpringMassChainOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  const Index N = options.masses.size(), n = 2 * N;
  SpringMassChain out;
  out.K = Tridiagonal(options.stiffness, options.left_fixed, options.right_fixed);
  out.D = Tridiagonal(options.damping, options.left_fixed, options.right_fixed);
  MatrixXd Ac = MatrixXd::Zero(n, n);
  for (Index i = 0; i < N; ++i) {
    Ac(2 * i, 2 * i + 1) = 1.0;
    for (Index j = 0; j < N; ++j) {
      Ac(2 * i + 1, 2 * j) = -out.K(i, j) / options.masses(i);
      Ac(2 * i + 1, 2 * j + 1) = -out.D(i, j) / options.masses(i);
    }
  }
  out.order.resize(n);
  Index pos = 0;
  if (options.first_mass > 0) {
    out.order(pos++) = 2 * (options.first_mass - 1);
    out.order(pos++) = 2 * (options.first_mass - 1) + 1;
  }
  for (Index i = 0; i < N; ++i) {
    if (i + 1 == options.first_mass) continue;
    out.order(pos++) = 2 * i;
    out.order(pos++) = 2 * i + 1;
  }
  out.Ac.resize(n, n);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) out.Ac(i, j) = Ac(out.order(i), out.order(j));
  out.Ad = DiscretizeZoh(out.Ac, MatrixXd::Zero(n, 0), options.dt).Ad;
  return out;
}

}  // namespace kfx
