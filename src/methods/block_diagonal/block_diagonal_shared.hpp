#pragma once
// Private helpers shared by the files of the block-diagonal method (004): the shape checks of a coupled
// step, raw access to packed blocks, the product with a packed block-diagonal matrix, the per-subsystem
// Kalman steps, and the whole O(n r^2) step with the running filter's estimate update folded in. (The
// range-based passes that the distributed filter calls are declared in block_diagonal_internal.hpp.)
#include <Eigen/Dense>
#include <string>

#include "kfx/block_diagonal.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"

namespace kfx::detail {

/// F packed c x (n c) with c >= 1, and H, V, R, G, U of the same n, c and of d >= 1, r (coupled_model.cpp).
/// @throws kfx::Error naming the matrix at fault, after label.
void RequireStepShapes(const CoupledStep& s, const std::string& label);
/// P packed c x (n c). @throws kfx::Error naming it.
void RequirePackedCovariance(const std::string& name, const Eigen::MatrixXd& P, Eigen::Index c, Eigen::Index n);

// Raw access to block i of a packed matrix with `rows` rows and blocks `cols` wide.
inline Eigen::Map<const Eigen::MatrixXd> BlockOf(const Eigen::MatrixXd& m, Eigen::Index i, Eigen::Index cols) {
  return Eigen::Map<const Eigen::MatrixXd>(m.data() + i * cols * m.rows(), m.rows(), cols);
}
inline Eigen::Map<Eigen::MatrixXd> BlockOf(Eigen::MatrixXd& m, Eigen::Index i, Eigen::Index cols) {
  return Eigen::Map<Eigen::MatrixXd>(m.data() + i * cols * m.rows(), m.rows(), cols);
}

// dst = blockdiag(blocks_i) src for nb blocks a x b stored contiguously (column-major) from bl; src and
// dst column-major with `cols` columns (leading dimensions src_ld, dst_ld). The fixed-shape kernels for
// a, b <= 2 unless SetBlockDiagonalSpecializedKernels(false) (block_diagonal_passes.cpp).
void BlockRowsTimesRaw(const double* bl, Eigen::Index a, Eigen::Index b, Eigen::Index nb, const double* src,
                       Eigen::Index src_ld, double* dst, Eigen::Index dst_ld, Eigen::Index cols);

// The same for blocks [i0, i0 + nb) of a packed matrix (blocks.rows() x (n b)).
inline void BlockRowsTimes(const Eigen::MatrixXd& blocks, Eigen::Index b, Eigen::Index i0, Eigen::Index nb,
                           const double* src, Eigen::Index src_ld, double* dst, Eigen::Index dst_ld,
                           Eigen::Index cols) {
  const Eigen::Index a = blocks.rows();
  BlockRowsTimesRaw(blocks.data() + i0 * a * b, a, b, nb, src, src_ld, dst, dst_ld, cols);
}

// The per-subsystem Kalman step for subsystems [i0, i1) with process noise Q (packed c x (n c)):
// L = F P F^T + Q, M = H L H^T + R = R_c^T R_c (Cholesky), J = L H^T M^{-1} into J, P_out = L - J H L,
// and, when rinv is not null, R_c^{-1} (d x d upper triangular) into rinv[(i - i0) d^2 ...]
// (subsystem_steps.cpp). @throws kfx::NumericalError if some M is not positive definite.
void SubsystemKalmanSteps(const CoupledStep& s, const Eigen::MatrixXd& Pp, const Eigen::MatrixXd& Q, Eigen::Index i0,
                          Eigen::Index i1, double* rinv, Eigen::MatrixXd& J, Eigen::MatrixXd& P_out);

// The estimate update folded into the covariance passes (the running filter): on entry x = F x_prev
// and nu is the innovation (length n d); on exit x = F x_prev + K nu (eq. (7)) and mu_u = C_1 Y^T nu.
struct EstimateFold {
  const double* nu;
  double* x;
  Eigen::VectorXd* mu_u;
  const PredictFold* predict;  // when given, pass 1 forms x = F x_prev and nu first
};

// Eqs. (8)-(17) over all subsystems into out (its storage reused), E^T and Y^T stored when store_gain,
// and, when est is given, the estimate update folded in (block_diagonal_step.cpp). Shapes must have
// been checked by the caller.
void BlockDiagonalUpdate(const CoupledStep& s, const Eigen::MatrixXd& Pp, BlockDiagonalCovarianceStep& out,
                         bool store_gain, const EstimateFold* est);

}  // namespace kfx::detail
