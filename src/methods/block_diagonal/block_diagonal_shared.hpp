#pragma once
// Private helpers shared by the files of the block-diagonal method (004): the shape checks of a coupled
// step, raw access to packed blocks, the product with a packed block-diagonal matrix, the per-subsystem
// Kalman steps, and the whole O(n r^2) step with the running filter's estimate update folded in. (The
// range-based passes that the distributed filter calls are declared in block_diagonal_internal.hpp.)
#include <Eigen/Dense>
#include <string>
#include <vector>

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

/// The block-diagonal filter with its gain frozen at the fixed point reached from P_filt (RunCoupledFilter's
/// steady state), run `group` steps at a time (steady_state_run.cpp derives the split).
class FrozenBlockDiagonal {
 public:
  /// The gain of the step from P_filt (BlockDiagonalCovarianceUpdate), Fc_i = (I - J_i H_i) F_i and the
  /// r x r matrices M_m, m < group - 1: O(n c r^2 group) once.
  FrozenBlockDiagonal(const CoupledStep& s, const Eigen::MatrixXd& P_filt, int group);
  /// Steps k0 + 1 .. k0 + L (1 <= L <= group): x_filt row k0 holds x_{k0} on entry; rows k0 + 1 .. k0 + L
  /// of x_filt and rows k0 .. k0 + L - 1 of coupling (mu_u) are written from rows k0 .. k0 + L - 1 of y,
  /// which must be finite.
  void Run(const TimeSeries& y, int k0, int L, TimeSeries* x_filt, TimeSeries* coupling) const;
  const Eigen::MatrixXd& coupling_cov() const { return gain_.C1; }

 private:
  int group_;
  BlockDiagonalGain gain_;  // J, E^T, C_1, Y^T
  Eigen::MatrixXd F_, H_, Fc_;
  std::vector<Eigen::MatrixXd> M_;
};

}  // namespace kfx::detail
