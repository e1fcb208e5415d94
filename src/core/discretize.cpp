#include "kfx/discretize.hpp"

#include <cmath>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

void RequireStep(double dt) {
  if (!(std::isfinite(dt) && dt > 0.0)) {
    throw Error("dt: expected a finite step > 0, got " + std::to_string(dt));
  }
}

}  // namespace

Eigen::MatrixXd MatrixExponential(const Eigen::MatrixXd& M) {
  RequireSquare("M", M);
  RequireFinite("M", M);
  Eigen::MatrixXd E = M.exp();
  if (!E.allFinite()) {
    throw NumericalError("MatrixExponential: e^M overflows (norm of M = " + std::to_string(M.norm()) + ")");
  }
  return E;
}

ZohDiscretization DiscretizeZoh(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, double dt) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  RequireShape("B", B, A.rows(), B.cols());
  RequireFinite("B", B);
  RequireStep(dt);
  const Eigen::Index n = A.rows();
  const Eigen::Index m = B.cols();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n + m, n + m);
  M.topLeftCorner(n, n) = A * dt;
  M.topRightCorner(n, m) = B * dt;
  const Eigen::MatrixXd E = MatrixExponential(M);
  return {E.topLeftCorner(n, n), E.topRightCorner(n, m)};
}

NoiseDiscretization DiscretizeProcessNoise(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Qc, double dt) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  RequireShape("Qc", Qc, A.rows(), A.rows());
  RequirePositiveSemidefinite("Qc", Qc);
  RequireStep(dt);
  const Eigen::Index n = A.rows();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  M.topLeftCorner(n, n) = -A * dt;
  M.topRightCorner(n, n) = Qc * dt;
  M.bottomRightCorner(n, n) = A.transpose() * dt;
  const Eigen::MatrixXd E = MatrixExponential(M);
  NoiseDiscretization out;
  out.Ad = E.bottomRightCorner(n, n).transpose();
  out.Qd = out.Ad * E.topRightCorner(n, n);
  Symmetrize(out.Qd);
  return out;
}

}  // namespace kfx
