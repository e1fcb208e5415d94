#include "base/lapack_eigen.hpp"

#include <algorithm>
#include <complex>
#include <limits>
#include <vector>

#include "base/lapack_fortran.hpp"

namespace kfx::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

bool EigenDecompose(const Eigen::MatrixXd& a_in, Eigen::VectorXcd* values, Eigen::MatrixXcd* vectors) {
  const int n = static_cast<int>(a_in.rows());
  values->resize(n);
  if (vectors) vectors->resize(n, n);
  if (n == 0) return true;
  MatrixXd a = a_in, vr(n, n);
  VectorXd wr(n), wi(n);
  const char* jobvr = vectors ? "V" : "N";
  const int one = 1, ldvr = vectors ? n : 1;
  double dummy = 0.0, query = 0.0;
  int lwork = -1, info = 0;
  dgeev_("N", jobvr, &n, a.data(), &n, wr.data(), wi.data(), &dummy, &one, vr.data(), &ldvr, &query, &lwork, &info, 1,
         1);
  lwork = std::max(static_cast<int>(query), 4 * n);
  std::vector<double> work(static_cast<size_t>(lwork));
  dgeev_("N", jobvr, &n, a.data(), &n, wr.data(), wi.data(), &dummy, &one, vr.data(), &ldvr, work.data(), &lwork, &info,
         1, 1);
  if (info != 0) return false;
  for (int k = 0; k < n; ++k) (*values)(k) = {wr(k), wi(k)};
  if (vectors) {
    for (int k = 0; k < n; ++k) {
      if (wi(k) == 0.0) {
        vectors->col(k) = vr.col(k).cast<std::complex<double>>();
      } else if (k + 1 < n) {  // DGEEV: v_k = vr_k + i vr_{k+1}, v_{k+1} = conj(v_k)
        for (int i = 0; i < n; ++i) {
          (*vectors)(i, k) = {vr(i, k), vr(i, k + 1)};
          (*vectors)(i, k + 1) = {vr(i, k), -vr(i, k + 1)};
        }
        ++k;
      }
    }
  }
  return true;
}

double ConditionNumber(const Eigen::MatrixXcd& t) {
  const Index n = t.rows();
  MatrixXd e(2 * n, 2 * n);
  e << t.real(), -t.imag(), t.imag(), t.real();
  const VectorXd s = Eigen::JacobiSVD<MatrixXd>(e).singularValues();
  return s(2 * n - 1) > 0.0 ? s(0) / s(2 * n - 1) : std::numeric_limits<double>::infinity();
}

}  // namespace kfx::detail
