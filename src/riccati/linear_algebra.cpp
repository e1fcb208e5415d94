// Small dense linear algebra of the riccati layer on LAPACK (declarations: riccati_internal.hpp) and
// the public SpectralRadius.
#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "kfx/riccati.hpp"
#include "kfx/validation.hpp"
#include "riccati/riccati_internal.hpp"

namespace kfx {
namespace detail {

using Eigen::Index;
using Eigen::MatrixXd;

void SymmetrizeInPlace(MatrixXd& m) {
  const Index n = m.rows();
  for (Index j = 0; j < n; ++j) {
    for (Index i = 0; i < j; ++i) {
      const double v = 0.5 * (m(i, j) + m(j, i));
      m(i, j) = v;
      m(j, i) = v;
    }
  }
}

void UpdateWithCongruence(const ConstRef& A, const MatrixXd& S, double alpha, double beta, MatrixXd* out) {
  CongruenceWork work;
  UpdateWithCongruenceLower(A, S, alpha, beta, &work, out);
  if (A.rows() >= 32) out->triangularView<Eigen::StrictlyUpper>() = out->transpose();
}

void UpdateWithCongruenceLower(const ConstRef& A, const ConstRef& S, double alpha, double beta, CongruenceWork* work,
                               MatrixXd* out) {
  const Index n = A.rows();
  if (n < 32) {
    const MatrixXd AS = A * S.selfadjointView<Eigen::Lower>();
    if (beta == 0.0) out->setZero(n, n);
    if (beta != 1.0 && beta != 0.0) *out *= beta;
    out->noalias() += alpha * (AS * A.transpose());
    SymmetrizeInPlace(*out);
    return;
  }
  if (beta == 0.0 && out->rows() != n) out->resize(n, n);
  const int nf = FortranInt(n), lda = FortranInt(A.outerStride());
  work->L = S;
  work->L.diagonal() *= 0.5;
  work->B = A;
  const double one = 1.0;
  dtrmm_("R", "L", "N", "N", &nf, &nf, &one, work->L.data(), &nf, work->B.data(), &nf);
  dsyr2k_("L", "N", &nf, &nf, &alpha, work->B.data(), &nf, A.data(), &lda, &beta, out->data(), &nf);
}

bool AddCongruenceOfPdLower(const ConstRef& A, const ConstRef& X, double alpha, CongruenceWork* work, MatrixXd* out) {
  const Index n = A.rows();
  if (n < 32) return false;
  const int nf = FortranInt(n);
  work->L = X;
  int info = 0;
  dpotrf_("L", &nf, work->L.data(), &nf, &info, 1);
  if (info != 0) return false;
  work->B = A;
  const double one = 1.0;
  dtrmm_("R", "L", "N", "N", &nf, &nf, &one, work->L.data(), &nf, work->B.data(), &nf);  // B = A L
  dsyrk_("L", "N", &nf, &nf, &alpha, work->B.data(), &nf, &one, out->data(), &nf);       // out += alpha B B^T (lower)
  return true;
}

double LowerFrobeniusNorm(const MatrixXd& m) {
  const Index n = m.rows();
  double off = 0.0;
  for (Index j = 0; j < n; ++j) off += m.col(j).tail(n - j - 1).squaredNorm();
  return std::sqrt(2.0 * off + m.diagonal().squaredNorm());
}

MatrixXd MatrixPool::Take(Index rows, Index cols) {
  for (auto it = free_.begin(); it != free_.end(); ++it) {
    if (it->size() == rows * cols) {
      MatrixXd m = std::move(*it);
      free_.erase(it);
      m.resize(rows, cols);  // same number of entries: no reallocation
      return m;
    }
  }
  return MatrixXd(rows, cols);
}

void MatrixPool::Give(MatrixXd&& m) {
  if (m.size() > 0) free_.push_back(std::move(m));
}

bool Eigenvalues(const ConstRef& a_in, Eigen::VectorXcd* eig) {
  const int n = FortranInt(a_in.rows());
  eig->resize(n);
  if (n == 0) return true;
  MatrixXd a = a_in;
  std::vector<double> wr(n), wi(n);
  double dummy = 0.0, work_query = 0.0;
  int lwork = -1, info = 0, one = 1;
  dgeev_("N", "N", &n, a.data(), &n, wr.data(), wi.data(), &dummy, &one, &dummy, &one, &work_query, &lwork, &info, 1,
         1);
  lwork = std::max(static_cast<int>(work_query), 3 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  dgeev_("N", "N", &n, a.data(), &n, wr.data(), wi.data(), &dummy, &one, &dummy, &one, work.data(), &lwork, &info, 1,
         1);
  KFX_ASSERT(info >= 0);
  if (info != 0) return false;
  for (int i = 0; i < n; ++i) (*eig)(i) = std::complex<double>(wr[i], wi[i]);
  return true;
}

double SpectralRadiusUnchecked(const ConstRef& a) {
  if (a.rows() == 0) return 0.0;
  Eigen::VectorXcd eig;
  if (!Eigenvalues(a, &eig)) return std::numeric_limits<double>::quiet_NaN();
  return eig.cwiseAbs().maxCoeff();
}

double MinEigenvalue(const MatrixXd& p) {
  const int n = FortranInt(p.rows());
  if (n == 0) return 0.0;
  MatrixXd a = p;
  const double vl = 0.0, vu = 0.0, abstol = 0.0;
  const int il = 1;
  int found = 0, info = 0, lwork = -1, liwork = -1, iwork_query = 0, one = 1;
  double w_query = 0.0, z_dummy = 0.0;
  std::vector<double> w(n);
  std::vector<int> isuppz(2 * static_cast<std::size_t>(n));
  dsyevr_("N", "I", "U", &n, a.data(), &n, &vl, &vu, &il, &il, &abstol, &found, w.data(), &z_dummy, &one, isuppz.data(),
          &w_query, &lwork, &iwork_query, &liwork, &info, 1, 1, 1);
  lwork = std::max(static_cast<int>(w_query), 26 * n);
  liwork = std::max(iwork_query, 10 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  std::vector<int> iwork(static_cast<std::size_t>(liwork));
  dsyevr_("N", "I", "U", &n, a.data(), &n, &vl, &vu, &il, &il, &abstol, &found, w.data(), &z_dummy, &one, isuppz.data(),
          work.data(), &lwork, iwork.data(), &liwork, &info, 1, 1, 1);
  KFX_ASSERT(info >= 0);
  if (info != 0 || found < 1) return std::numeric_limits<double>::quiet_NaN();
  return w[0];
}

}  // namespace detail

double SpectralRadius(const Eigen::Ref<const Eigen::MatrixXd>& A) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  return detail::SpectralRadiusUnchecked(A);
}

}  // namespace kfx
