#pragma once
// Range-based passes of the O(n r^2) block-diagonal step (004 eqs. (8)-(17)), for the distributed
// filter (include/kfx/distributed.hpp), defined in block_diagonal_passes.cpp; BlockDiagonalCovarianceUpdate
// (block_diagonal_step.cpp) runs the same passes over all subsystems. For subsystems [i0, i1) of the
// (local) step s:
//   pass 1: the per-subsystem Kalman steps (J, P = L - J H L) and E^T, Y^T, and N += Z^T Z;
//   factor: C_1 = (U^{-1} + N)^{-1} = Fc Fc^T without inverting U;
//   pass 2: P_i += W_i W_i^T, W_i = E_i Fc = A_i G_i Fc with A_i = J_i H_i - I (E is never formed:
//   both passes read G in place).
// A subsystem's results depend only on its own blocks, on Fc and on where its internal chunk of
// kfx's 256 subsystems starts, so callers that start every range at the same global positions get
// the same bits on any partition.
#include <Eigen/Dense>

#include "kfx/block_diagonal.hpp"

namespace kfx::detail {

/// Scratch buffers of the passes (resized on first use; reuse across steps avoids allocation).
/// Chunk-sized (O(256 r) doubles), independent of n.
struct BlockDiagonalWorkspace {
  Eigen::VectorXd rinv, B, Z, A, Wt, T, rnu, jnu, gv;
};

/// Whether the passes may use their fixed-shape kernels (SetBlockDiagonalSpecializedKernels).
bool SpecializedKernels();

/// Sizes out->P_filt and out->gain.J for s, and E^T, Y^T when store_gain (else they get 0 columns and
/// pass 2 recomputes E from G). Keeps the storage when the sizes agree.
void BlockDiagonalResize(const CoupledStep& s, bool store_gain, BlockDiagonalCovarianceStep* out);
/// Pass 1 over subsystems [i0, i1) of s: J, P = L - J H L, (E^T, Y^T when stored); adds Z^T Z of the
/// range to the lower triangle of N (r x r) and, when nu (the innovation, length n d) is given,
/// Y^T nu of the range to *ytnu. For r = 0 only the per-subsystem Kalman steps. Shapes must have been
/// checked by the caller.
/// When predict is given, pass 1 first forms, chunk by chunk (while F and H are in cache), the
/// prediction x_pred = F x_prev and the innovation nu = y - H x_pred of the range into the caller's
/// arrays (global indexing, like nu), and then uses that innovation: nu must be predict->nu.
struct PredictFold {
  const double* x_prev;
  const double* y;
  double* x_pred;
  double* nu;
};
void BlockDiagonalPass1(const CoupledStep& s, const Eigen::MatrixXd& P_prev_blocks, Eigen::Index i0, Eigen::Index i1,
                        const double* nu, BlockDiagonalWorkspace* work, BlockDiagonalCovarianceStep* out,
                        Eigen::MatrixXd* N, Eigen::VectorXd* ytnu, const PredictFold* predict = nullptr);
/// C_1 = Fc Fc^T with Fc = Ld (r x k, k <= r) lower trapezoidal (Ld(t, q) = 0 for t < q), so
/// that pass 2's W = G Fc costs half a dense product.
struct CouplingFactor {
  Eigen::MatrixXd FcT;  ///< k x r: Fc^T (upper trapezoidal)
  Eigen::MatrixXd Ld;   ///< r x k: Fc
};
/// From the full symmetric N: C_1 = (U^{-1} + N)^{-1} into *C1 (without inverting U) and its factor.
/// @throws kfx::NumericalError if I + S^T N S is not positive definite.
CouplingFactor BlockDiagonalFactor(const Eigen::MatrixXd& U, const Eigen::MatrixXd& N, Eigen::MatrixXd* C1);
/// Pass 2 over subsystems [i0, i1): P_i += W_i W_i^T (W^T = Fc^T E^T, E^T stored or recomputed from
/// G, H, J) and, when x is given (F x_prev on entry), x_i += J_i nu_i - E_i v with v = mu_u = C_1 Y^T nu.
void BlockDiagonalPass2(const CoupledStep& s, const CouplingFactor& factor, Eigen::Index i0, Eigen::Index i1,
                        const double* nu, const Eigen::VectorXd* v, double* x, BlockDiagonalWorkspace* work,
                        BlockDiagonalCovarianceStep* out);

}  // namespace kfx::detail
