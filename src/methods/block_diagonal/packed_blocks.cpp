// Packed block-diagonal matrices of 004 (include/kfx/block_diagonal.hpp): to and from dense, the
// product with a vector, and the stacked coupled system as a dense kfx model.
#include <string>
#include <utility>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx {

using detail::BlockRowsTimes;
using detail::RequireStepShapes;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

MatrixXd BlockDiagonalToDense(const MatrixXd& blocks, Index block_cols) {
  if (block_cols < 1 || blocks.cols() % block_cols != 0) {
    throw Error("blocks: expected a x (n b) packed blocks with b = " + std::to_string(block_cols) + ", got " +
                ShapeString(blocks.rows(), blocks.cols()));
  }
  const Index a = blocks.rows(), n = blocks.cols() / block_cols;
  MatrixXd dense = MatrixXd::Zero(n * a, n * block_cols);
  for (Index i = 0; i < n; ++i) {
    dense.block(i * a, i * block_cols, a, block_cols) = blocks.middleCols(i * block_cols, block_cols);
  }
  return dense;
}

MatrixXd DiagonalBlocks(const MatrixXd& M, Index a) {
  if (a < 1 || M.rows() != M.cols() || M.rows() % a != 0) {
    throw Error("M: expected a square matrix of size a multiple of " + std::to_string(a) + ", got " +
                ShapeString(M.rows(), M.cols()));
  }
  const Index n = M.rows() / a;
  MatrixXd blocks(a, n * a);
  for (Index i = 0; i < n; ++i) blocks.middleCols(i * a, a) = M.block(i * a, i * a, a, a);
  return blocks;
}

VectorXd BlockDiagonalApply(const MatrixXd& blocks, Index block_cols, const VectorXd& x) {
  if (block_cols < 1 || blocks.cols() % block_cols != 0) {
    throw Error("blocks: expected packed blocks " + std::to_string(block_cols) + " wide, got " +
                ShapeString(blocks.rows(), blocks.cols()));
  }
  RequireVector("x", x, blocks.cols());
  const Index n = blocks.cols() / block_cols;
  VectorXd y(n * blocks.rows());
  BlockRowsTimes(blocks, block_cols, 0, n, x.data(), x.size(), y.data(), y.size(), 1);
  return y;
}

ModelStep ToDenseStep(const CoupledStep& s) {
  RequireStepShapes(s, "");
  const Index c = s.c();
  MatrixXd Q = BlockDiagonalToDense(s.V, c);
  if (s.r() > 0) Q.noalias() += s.G * s.U * s.G.transpose();
  Symmetrize(Q);
  return MakeStep(BlockDiagonalToDense(s.F, c), BlockDiagonalToDense(s.H, c), std::move(Q),
                  BlockDiagonalToDense(s.R, s.d()));
}

Model ToDenseModel(const CoupledSystem& system) {
  MatrixXd P0 = BlockDiagonalToDense(system.P0_blocks(), system.c());
  if (system.time_invariant()) return Model(ToDenseStep(*system.step(1)), system.m0(), std::move(P0));
  return Model(
      system.state_dim(), system.meas_dim(), [system](int k) { return ToDenseStep(*system.step(k)); }, system.m0(),
      std::move(P0), system.horizon());
}

}  // namespace kfx
