#include "kfx/validation.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace kfx {

namespace detail {
void AssertFail(const char* expr, const char* file, int line) {
  std::ostringstream os;
  os << "kfx internal error: assertion '" << expr << "' failed at " << file << ":" << line
     << " (please report this as a bug)";
  throw InternalError(os.str());
}
}  // namespace detail

std::string ShapeString(const Eigen::Ref<const Eigen::MatrixXd>& m) { return ShapeString(m.rows(), m.cols()); }

std::string ShapeString(Eigen::Index rows, Eigen::Index cols) {
  return std::to_string(rows) + "x" + std::to_string(cols);
}

void RequireFinite(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (!std::isfinite(m(i, j))) {
        std::ostringstream os;
        os << name << ": expected finite entries, got " << m(i, j) << " at (" << i << ", " << j << ")";
        throw Error(os.str());
      }
    }
  }
}

void RequireShape(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m, Eigen::Index rows,
                  Eigen::Index cols) {
  if ((rows >= 0 && m.rows() != rows) || (cols >= 0 && m.cols() != cols)) {
    std::ostringstream os;
    os << name << ": expected ";
    if (rows >= 0 && cols >= 0) {
      os << "a " << ShapeString(rows, cols) << " matrix";
    } else if (rows >= 0) {
      os << "a matrix with " << rows << (rows == 1 ? " row" : " rows");
    } else {
      os << "a matrix with " << cols << (cols == 1 ? " column" : " columns");
    }
    os << ", got " << ShapeString(m);
    throw Error(os.str());
  }
}

void RequireSquare(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m) {
  if (m.rows() != m.cols()) throw Error(name + ": expected a square matrix, got " + ShapeString(m));
}

void RequireSymmetric(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m, double tol) {
  RequireSquare(name, m);
  RequireFinite(name, m);
  if (m.size() == 0) return;
  const double scale = std::max(1.0, m.cwiseAbs().maxCoeff());
  const double asym = (m - m.transpose()).cwiseAbs().maxCoeff();
  if (asym > tol * scale) {
    std::ostringstream os;
    os << name << ": expected a symmetric matrix, got max |M - M^T| = " << asym << " (tolerance " << tol * scale << ")";
    throw Error(os.str());
  }
}

void RequirePositiveSemidefinite(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m, double tol) {
  RequireSymmetric(name, m);
  if (m.size() == 0) return;
  const double scale = std::max(1.0, m.diagonal().cwiseAbs().maxCoeff());
  Eigen::MatrixXd shifted = 0.5 * m + 0.5 * m.transpose();
  shifted.diagonal().array() += tol * scale;
  Eigen::LLT<Eigen::MatrixXd> llt(shifted);
  if (llt.info() != Eigen::Success) {
    const double min_eig =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * m + 0.5 * m.transpose(), Eigen::EigenvaluesOnly)
            .eigenvalues()
            .minCoeff();
    std::ostringstream os;
    os << name << ": expected a positive semidefinite matrix (smallest eigenvalue >= -" << tol
       << " * max(1, max diagonal) = " << -tol * scale << "), got smallest eigenvalue " << min_eig;
    throw Error(os.str());
  }
}

void RequirePositiveDefinite(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m, double tol) {
  RequireSymmetric(name, m);
  if (m.size() == 0) return;
  const double scale = m.diagonal().cwiseAbs().maxCoeff();
  Eigen::LLT<Eigen::MatrixXd> llt(0.5 * m + 0.5 * m.transpose());
  bool ok = llt.info() == Eigen::Success && scale > 0;
  if (ok) {
    const double min_pivot = llt.matrixLLT().diagonal().cwiseAbs2().minCoeff();
    ok = min_pivot > tol * scale;
  }
  if (!ok) {
    const double min_eig =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * m + 0.5 * m.transpose(), Eigen::EigenvaluesOnly)
            .eigenvalues()
            .minCoeff();
    std::ostringstream os;
    // The threshold is relative: a matrix whose condition number is above about 1/tol counts as singular.
    os << name << ": expected a positive definite matrix (every Cholesky pivot > " << tol
       << " * max diagonal = " << tol * scale << ", i.e. a condition number below about " << 1.0 / tol
       << "), got smallest eigenvalue " << min_eig;
    throw Error(os.str());
  }
}

void RequireVector(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Index n) {
  if (n >= 0 && v.size() != n) {
    throw Error(name + ": expected a vector of length " + std::to_string(n) + ", got length " +
                std::to_string(v.size()));
  }
  RequireFinite(name, v);
}

void Symmetrize(Eigen::Ref<Eigen::MatrixXd> m) {
  KFX_ASSERT(m.rows() == m.cols());
  // In place, no temporary: average each off-diagonal pair once.
  const Eigen::Index n = m.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = j + 1; i < n; ++i) {
      const double v = 0.5 * m(i, j) + 0.5 * m(j, i);  // no overflow of the sum near DBL_MAX
      m(i, j) = v;
      m(j, i) = v;
    }
  }
}

}  // namespace kfx
