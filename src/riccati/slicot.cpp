// The SLICOT calls of kfx: SB02OD (Riccati equations) and SB03MD (Lyapunov equations), discrete and
// continuous time (declarations and equations: slicot.hpp).
#include "riccati/slicot.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "kfx/summary.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;

std::vector<double> ColumnMajorCopy(const ConstRef& m, int ld) {
  std::vector<double> buf(static_cast<std::size_t>(ld) * static_cast<std::size_t>(std::max<Index>(m.cols(), 1)), 0.0);
  for (Index j = 0; j < m.cols(); ++j)
    for (Index i = 0; i < m.rows(); ++i) buf[static_cast<std::size_t>(j) * ld + i] = m(i, j);
  return buf;
}

const char* Sb02odInfoText(int info) {
  switch (info) {
    case 1:
      return "the extended matrix pencil is singular";
    case 2:
      return "the QZ algorithm failed";
    case 3:
      return "reordering of the generalized eigenvalues failed";
    case 4:
      return "after reordering, rounding moved eigenvalues across the unit circle (imaginary axis)";
    case 5:
      return "the stable deflating subspace does not have dimension n (eigenvalues on or near the unit circle "
             "or the imaginary axis)";
    case 6:
      return "U11 is singular (rcond < eps): no stabilizing solution can be formed";
    default:
      return "unknown error";
  }
}

}  // namespace

Sb02odResult SolveFilterRiccatiSb02od(TimeDomain domain, const ConstRef& A, const ConstRef& C, const ConstRef& Q,
                                      const ConstRef& R, const Eigen::MatrixXd* S) {
  Sb02odResult out;
  const int n = FortranInt(A.rows());
  const int m = FortranInt(C.rows());
  const int p = 0;  // not referenced with FACT = 'N'
  const int ld_n = std::max(1, n);
  const int ld_m = std::max(1, m);
  const int ld_st = std::max(1, 2 * n + m);
  const int ld_u = std::max(1, 2 * n);
  const int ld_l = S ? ld_n : 1;

  const MatrixXd At = A.transpose();
  const MatrixXd Ct = C.transpose();
  std::vector<double> a = ColumnMajorCopy(At, ld_n);
  std::vector<double> b = ColumnMajorCopy(Ct, ld_n);
  std::vector<double> q = ColumnMajorCopy(Q, ld_n);
  std::vector<double> r = ColumnMajorCopy(R, ld_m);
  std::vector<double> l = S ? ColumnMajorCopy(*S, ld_n) : std::vector<double>(1, 0.0);
  std::vector<double> x(static_cast<std::size_t>(ld_n) * std::max(1, n));
  const std::size_t two_n = static_cast<std::size_t>(std::max(1, 2 * n));
  std::vector<double> alfar(two_n), alfai(two_n), beta(two_n);
  std::vector<double> s(static_cast<std::size_t>(ld_st) * static_cast<std::size_t>(ld_st));
  std::vector<double> t(static_cast<std::size_t>(ld_st) * two_n);
  std::vector<double> u(static_cast<std::size_t>(ld_u) * two_n);
  std::vector<int> iwork(static_cast<std::size_t>(std::max({1, m, 2 * n})));
  std::vector<kfx_fortran_logical> bwork(two_n);
  // Minimum workspace of SB02OD plus room for the blocked QZ (DGGES) and reordering.
  const int ldwork = std::max({14 * n + 23, 16 * n, 2 * n + m, 3 * m}) + 64 * (2 * n + m);
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  double rcond = 0.0;
  const double tol = 0.0;  // SB02OD default (machine epsilon) for the pencil compression
  int info = 0;
  const char* dico = domain == TimeDomain::kDiscrete ? "D" : "C";
  sb02od_(dico, "B", "N", "U", S ? "N" : "Z", "S", &n, &m, &p, a.data(), &ld_n, b.data(), &ld_n, q.data(), &ld_n,
          r.data(), &ld_m, l.data(), &ld_l, &rcond, x.data(), &ld_n, alfar.data(), alfai.data(), beta.data(), s.data(),
          &ld_st, t.data(), &ld_st, u.data(), &ld_u, &tol, iwork.data(), dwork.data(), &ldwork, bwork.data(), &info, 1,
          1, 1, 1, 1, 1);
  KFX_ASSERT(info >= 0);  // a negative info is an argument error: a bug here
  out.info = info;
  out.rcond = rcond;
  if (info != 0) {
    out.message = std::string("SB02OD failed (info ") + std::to_string(info) + "): " + Sb02odInfoText(info);
    return out;
  }
  out.P = Eigen::Map<const MatrixXd, 0, Eigen::OuterStride<>>(x.data(), n, n, Eigen::OuterStride<>(ld_n));
  out.message = "SB02OD: rcond(U11) = " + FormatNumber(rcond);
  return out;
}

// SB03MD solves op(A)^T X op(A) - X = scale C (discrete) or op(A)^T X + X op(A) = scale C (continuous);
// with TRANA = 'T' (op(A) = A^T) and C = -Q these are A X A^T - X = -scale Q and A X + X A^T = -scale Q,
// so the solution of the unscaled equation is X / scale.
Sb03mdResult SolveLyapunovSb03md(TimeDomain domain, const ConstRef& A, const ConstRef& Q) {
  Sb03mdResult out;
  const int nf = FortranInt(A.rows());
  MatrixXd a = A;
  MatrixXd u(nf, nf);
  out.X = -0.5 * (Q + Q.transpose());
  std::vector<double> wr(static_cast<std::size_t>(nf)), wi(static_cast<std::size_t>(nf));
  std::vector<int> iwork(1);
  // Minimum for JOB = 'X' is max(n^2, 3n) (2n^2 + 2n in older releases); the extra 64 n lets DGEES use
  // its blocked code.
  const int ldwork = std::max(2 * nf * nf + 3 * nf, 1) + 64 * nf;
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  double sep = 0.0, ferr = 0.0;
  int info = 0;
  const int ld = std::max(1, nf);
  const char* dico = domain == TimeDomain::kDiscrete ? "D" : "C";
  sb03md_(dico, "X", "N", "T", &nf, a.data(), &ld, u.data(), &ld, out.X.data(), &ld, &out.scale, &sep, &ferr, wr.data(),
          wi.data(), iwork.data(), dwork.data(), &ldwork, &info, 1, 1, 1, 1);
  KFX_ASSERT(info >= 0);  // a negative info is an argument error: a bug here
  out.info = info;
  if (info == 0 || info == nf + 1) {
    out.eigenvalues.resize(nf);
    for (int i = 0; i < nf; ++i) out.eigenvalues(i) = std::complex<double>(wr[i], wi[i]);
  }
  if (info == 0 && out.scale > 0.0 && out.scale != 1.0) out.X /= out.scale;
  if (info == 0) SymmetrizeInPlace(out.X);
  return out;
}

}  // namespace kfx::detail
