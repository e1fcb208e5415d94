// The O(n r^2) step of 004's block-diagonal filter over all subsystems, eqs. (8)-(17): the offline
// covariance update with its factored gain, and the same step with the running filter's estimate
// update folded in. Both go through the range passes of block_diagonal_passes.cpp.
#include <algorithm>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx {

using detail::BlockRowsTimes;
using detail::RequirePackedCovariance;
using detail::RequireStepShapes;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

VectorXd BlockDiagonalGain::Apply(const VectorXd& innovation) const {
  const Index c = J.rows(), nd = Yt.cols();
  RequireVector("innovation", innovation, nd);
  VectorXd out(Et.cols());
  const Index n = Et.cols() / std::max<Index>(c, 1);
  BlockRowsTimes(J, n > 0 ? nd / n : 0, 0, n, innovation.data(), nd, out.data(), out.size(), 1);
  if (Et.rows() > 0) out.noalias() -= Et.transpose() * (C1 * (Yt * innovation));
  return out;
}

VectorXd BlockDiagonalGain::CouplingMean(const VectorXd& innovation) const {
  RequireVector("innovation", innovation, Yt.cols());
  return C1 * (Yt * innovation);
}

MatrixXd BlockDiagonalGain::ToDense() const {
  const Index c = J.rows(), n = Et.cols() / std::max<Index>(c, 1);
  const Index d = n > 0 ? Yt.cols() / n : 0;
  MatrixXd K = BlockDiagonalToDense(J, d);
  if (Et.rows() > 0) K.noalias() -= Et.transpose() * C1 * Yt;
  return K;
}

BlockDiagonalCovarianceStep BlockDiagonalCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp) {
  BlockDiagonalCovarianceStep out;
  BlockDiagonalCovarianceUpdate(s, Pp, &out);
  return out;
}

namespace detail {

// Eqs. (8)-(17) over all subsystems, through the range passes of block_diagonal_passes.cpp (the
// distributed filter runs the same passes per slice): BlockDiagonalCovarianceUpdate stores the gain
// (E^T, Y^T: O(n r) doubles); CoupledFilter does not, and has K nu applied inside the passes. Neither
// pass reads E^T or Y^T (both work from G in place), so without the stored gain each subsystem's G rows
// are streamed twice per step and nothing r-wide is written: the step stays linear in n once the
// arrays leave the cache. The scratch is per chunk (O(256 r) doubles) and kept per thread, so steps
// allocate nothing.
void BlockDiagonalUpdate(const CoupledStep& s, const MatrixXd& Pp, BlockDiagonalCovarianceStep& out, bool store_gain,
                         const EstimateFold* est) {
  const Index n = s.n(), r = s.r();
  thread_local detail::BlockDiagonalWorkspace ws;
  detail::BlockDiagonalResize(s, store_gain, &out);
  MatrixXd N = MatrixXd::Zero(r, r);
  VectorXd ytnu = VectorXd::Zero(est ? r : 0);
  detail::BlockDiagonalPass1(s, Pp, 0, n, est ? est->nu : nullptr, &ws, &out, &N, est ? &ytnu : nullptr,
                             est ? est->predict : nullptr);
  N.triangularView<Eigen::StrictlyUpper>() = N.transpose();
  detail::CouplingFactor factor;
  if (r > 0)
    factor = detail::BlockDiagonalFactor(s.U, N, &out.gain.C1);
  else
    out.gain.C1.resize(0, 0);
  VectorXd v;
  if (est) {
    v.noalias() = out.gain.C1 * ytnu;  // mu_u = C_1 Y^T nu (after eq. (17), -C_3 = C_1); empty when r = 0
    *est->mu_u = v;
  }
  detail::BlockDiagonalPass2(s, factor, 0, n, est ? est->nu : nullptr, est ? &v : nullptr, est ? est->x : nullptr, &ws,
                             &out);
}

}  // namespace detail

void BlockDiagonalCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp, BlockDiagonalCovarianceStep* result) {
  KFX_ASSERT(result != nullptr);
  if (&Pp == &result->P_filt) throw Error("P_prev: must not alias the output's P_filt");
  RequireStepShapes(s, "");
  RequirePackedCovariance("P_prev", Pp, s.c(), s.n());
  detail::BlockDiagonalUpdate(s, Pp, *result, /*store_gain=*/true, nullptr);  // reuses the caller's storage
}

}  // namespace kfx
