// The SLICOT calls of the generalized equations (declarations: slicot_generalized.hpp).
#include "riccati/slicot_generalized.hpp"

#include <algorithm>
#include <complex>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "kfx/summary.hpp"

namespace kfx::detail {

namespace {

using Eigen::MatrixXd;

const char* Sg02adInfoText(int info) {
  switch (info) {
    case 1:
      return "the extended matrix pencil is singular";
    case 2:
      return "the QZ algorithm failed";
    case 3:
      return "reordering of the generalized eigenvalues failed";
    case 4:
      return "after reordering, rounding moved eigenvalues across the unit circle";
    case 5:
      return "the stable deflating subspace does not have dimension n (eigenvalues on or near the unit circle)";
    case 6:
      return "the spectrum is too close to the unit circle (the computed solution is not symmetric)";
    case 7:
      return "a singular matrix was met in forming the solution (U11 singular)";
    default:
      return "unknown error";
  }
}

}  // namespace

Sg02adResult SolveFilterDareSg02ad(const ConstRef& A, const ConstRef& E, const ConstRef& C, const ConstRef& Q,
                                   const ConstRef& R, const ConstRef& S) {
  Sg02adResult out;
  const int n = FortranInt(A.rows());
  const int m = FortranInt(C.rows());
  const int p = 0;  // not referenced with FACT = 'N'
  const int ld_n = std::max(1, n);
  const int ld_m = std::max(1, m);
  const int ld_st = std::max(1, 2 * n + m);
  const int ld_u = std::max(1, 2 * n);
  // Column-major copies with leading dimension max(1, rows); SG02AD restores Q, R, L after scaling.
  MatrixXd a = A.transpose(), e = E.transpose(), b = C.transpose(), q = Q, r = R, l = S;
  a.conservativeResize(ld_n, std::max(1, n));
  e.conservativeResize(ld_n, std::max(1, n));
  b.conservativeResize(ld_n, std::max(1, m));
  q.conservativeResize(ld_n, std::max(1, n));
  r.conservativeResize(ld_m, std::max(1, m));
  l.conservativeResize(ld_n, std::max(1, m));
  MatrixXd x = MatrixXd::Zero(ld_n, std::max(1, n));
  const std::size_t two_n = static_cast<std::size_t>(std::max(1, 2 * n));
  std::vector<double> alfar(two_n), alfai(two_n), beta(two_n);
  std::vector<double> s(static_cast<std::size_t>(ld_st) * static_cast<std::size_t>(ld_st));
  std::vector<double> t(static_cast<std::size_t>(ld_st) * two_n);
  std::vector<double> u(static_cast<std::size_t>(ld_u) * two_n);
  std::vector<int> iwork(static_cast<std::size_t>(std::max({1, m, 2 * n})));
  std::vector<kfx_fortran_logical> bwork(two_n);
  // Minimum workspace plus room for the blocked QZ (DGGES) and the QR of the basis.
  const int ldwork = std::max({14 * n + 23, 16 * n, 2 * n + m, 3 * m}) + 64 * (2 * n + m);
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  double rcond = 0.0;
  const double tol = 0.0;  // default (machine epsilon) for the pencil compression
  int iwarn = 0, info = 0;
  sg02ad_("D", "B", "N", "U", "N", "G", "S", "R", &n, &m, &p, a.data(), &ld_n, e.data(), &ld_n, b.data(), &ld_n,
          q.data(), &ld_n, r.data(), &ld_m, l.data(), &ld_n, &rcond, x.data(), &ld_n, alfar.data(), alfai.data(),
          beta.data(), s.data(), &ld_st, t.data(), &ld_st, u.data(), &ld_u, &tol, iwork.data(), dwork.data(), &ldwork,
          bwork.data(), &iwarn, &info, 1, 1, 1, 1, 1, 1, 1, 1);
  KFX_ASSERT(info >= 0);  // a negative info is an argument error: a bug here
  out.info = info;
  out.iwarn = iwarn;
  out.rcond = rcond;
  if (info != 0) {
    out.message = std::string("SG02AD failed (info ") + std::to_string(info) + "): " + Sg02adInfoText(info);
    return out;
  }
  out.P = x.topLeftCorner(n, n);
  out.message = "SG02AD: rcond = " + FormatNumber(rcond);
  if (iwarn != 0) out.message += " (SG02AD warns: the solution may be inaccurate)";
  return out;
}

// SG03AD with TRANS = 'T' solves A X A^T - E X E^T = scale Y; Y = -Q gives the equation of the header.
Sg03adResult SolveGeneralizedLyapunovSg03ad(const ConstRef& A, const ConstRef& E, const ConstRef& Q) {
  Sg03adResult out;
  const int n = FortranInt(A.rows());
  const int ld = std::max(1, n);
  MatrixXd a = A, e = E, qq(ld, ld), zz(ld, ld);
  out.X = -0.5 * (Q + Q.transpose());
  std::vector<double> alphar(static_cast<std::size_t>(ld)), alphai(static_cast<std::size_t>(ld)),
      beta(static_cast<std::size_t>(ld));
  std::vector<int> iwork(1);
  const int ldwork = std::max({1, 4 * n, 8 * n + 16}) + 64 * n;
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  double sep = 0.0, ferr = 0.0;
  int info = 0;
  sg03ad_("D", "X", "N", "T", "U", &n, a.data(), &ld, e.data(), &ld, qq.data(), &ld, zz.data(), &ld, out.X.data(), &ld,
          &out.scale, &sep, &ferr, alphar.data(), alphai.data(), beta.data(), iwork.data(), dwork.data(), &ldwork,
          &info, 1, 1, 1, 1, 1);
  KFX_ASSERT(info >= 0);
  out.info = info;
  if (info == 0 || info == 3) {
    out.eigenvalues.resize(n);
    for (int i = 0; i < n; ++i) out.eigenvalues(i) = std::complex<double>(alphar[i], alphai[i]) / beta[i];
    // SG03AD fills only the UPLO triangle on input; on output X is full. Undo the scale, symmetrize.
    if (out.scale > 0.0 && out.scale != 1.0) out.X /= out.scale;
    SymmetrizeInPlace(out.X);
  }
  return out;
}

Sb04qdResult SolveSteinSb04qd(const ConstRef& A, const ConstRef& B, const ConstRef& C) {
  Sb04qdResult out;
  const int n = FortranInt(A.rows());
  const int m = FortranInt(B.rows());
  const int ld_n = std::max(1, n), ld_m = std::max(1, m);
  MatrixXd a = -A, b = B, z(ld_m, ld_m);
  out.X = C;
  std::vector<int> iwork(static_cast<std::size_t>(std::max(1, 4 * n)));
  const int ldwork = std::max({1, 2 * n * n + 9 * n, 5 * m, n + m}) + 64 * (n + m);
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  int info = 0;
  sb04qd_(&n, &m, a.data(), &ld_n, b.data(), &ld_m, out.X.data(), &ld_n, z.data(), &ld_m, iwork.data(), dwork.data(),
          &ldwork, &info);
  KFX_ASSERT(info >= 0);
  out.info = info;
  return out;
}

}  // namespace kfx::detail
