// Square-root, UD (Bierman-Thornton) and information forms of the Kalman filter (FactoredForm,
// factored_forms.hpp): the covariance kept factored from step to step.
//
// Square root (as SLICOT FB01QD, one orthogonal transformation per half-step, Householder QR):
//   predict: [A L, G_Q]^T = Q_1 [L'^T; 0]                         (P' = A P A^T + Q = L' L'^T)
//   update:  [[L_R^T, 0], [(C L)^T, L^T]] = Q_2 [[S_e^T, Kb^T], [0, L+^T]]
//            S = S_e S_e^T, K = Kb S_e^{-1}, P+ = L+ L+^T
// UD: P = U D U^T (U unit upper triangular, D diagonal). Measurements are decorrelated by the
//   Cholesky factor of R (y~ = L_R^{-1} y) and processed one at a time by Bierman's update; the
//   time update is Thornton's modified weighted Gram-Schmidt of [A U, G_Q] with weights diag(D, I).
// Information: Y = P^{-1}. Update Y+ = Y + C^T R^{-1} C; predict Y' = (I + M Q)^{-1} M with
//   M = A^{-T} Y A^{-1} (A invertible) or Y' = Q^{-1} - Q^{-1} A (Y + A^T Q^{-1} A)^{-1} A^T Q^{-1} (Q > 0).
// References: Bierman, Factorization Methods for Discrete Sequential Estimation (1977); Thornton &
// Bierman (1978); Kaminski, Bryson & Schmidt, IEEE TAC 16 (1971); SLICOT FB01QD/FB01RD.
#include "filter/factored_forms.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "filter/conventional_form.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kLog2Pi = 1.8378770664093454835606594728112;

// G with G G^T = M for a symmetric positive semidefinite M (pivoted LDL^T; pivots that rounding
// made negative are set to zero). n x n, not triangular. A rank-deficient M (Q = B U B^T with fewer
// noise inputs than states) can make Eigen's LDL^T give up after a zero pivot that rounding turned
// into a tiny nonzero one; then the symmetric eigendecomposition M = V diag(l) V^T gives
// G = V diag(sqrt(max(l, 0))), which exists for every symmetric M that is PSD to rounding.
MatrixXd PsdFactor(const MatrixXd& M, const char* what) {
  Eigen::LDLT<MatrixXd> ldlt(M);
  if (ldlt.info() != Eigen::Success) {
    Eigen::SelfAdjointEigenSolver<MatrixXd> eig(M);
    if (eig.info() != Eigen::Success) {
      throw NumericalError(std::string(what) + ": neither LDL^T nor the eigendecomposition succeeded");
    }
    return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  }
  const VectorXd sqrt_d = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
  MatrixXd L = ldlt.matrixL();
  L = L * sqrt_d.asDiagonal();
  return ldlt.transpositionsP().transpose() * L;
}

// Thornton's modified weighted Gram-Schmidt: U D U^T = W diag(dw) W^T, U unit upper triangular.
void Mwgs(MatrixXd W, const VectorXd& dw, MatrixXd* U, VectorXd* d) {
  const Index n = W.rows();
  U->setIdentity(n, n);
  d->resize(n);
  for (Index j = n - 1; j >= 0; --j) {
    const VectorXd c = dw.cwiseProduct(W.row(j).transpose());
    const double dj = W.row(j).dot(c);
    (*d)(j) = dj;
    if (!(dj > 0.0)) {
      (*d)(j) = 0.0;  // P' singular in this direction: the column of U is irrelevant
      continue;
    }
    const VectorXd v = c / dj;
    for (Index i = 0; i < j; ++i) {
      const double uij = W.row(i).dot(v);
      (*U)(i, j) = uij;
      W.row(i) -= uij * W.row(j);
    }
  }
}

// Bierman's scalar update of U, d with measurement row h and noise variance 1. Returns the gain k
// (x+ = x + k (y - h x)) and the innovation variance alpha = h P h^T + 1.
double BiermanScalar(MatrixXd& U, VectorXd& d, const VectorXd& h, VectorXd* k) {
  const Index n = U.rows();
  const VectorXd f = U.transpose() * h;
  const VectorXd v = d.cwiseProduct(f);
  VectorXd b = VectorXd::Zero(n);
  double alpha = 1.0 + f(0) * v(0);
  d(0) /= alpha;
  b(0) = v(0);
  for (Index j = 1; j < n; ++j) {
    const double beta = alpha;
    alpha += f(j) * v(j);
    const double lambda = -f(j) / beta;
    d(j) *= beta / alpha;
    for (Index i = 0; i < j; ++i) {
      const double t = U(i, j);
      U(i, j) = t + b(i) * lambda;
      b(i) += t * v(j);
    }
    b(j) = v(j);
  }
  *k = b / alpha;
  return alpha;
}

std::string FormName(FilterForm f) {
  switch (f) {
    case FilterForm::kSquareRoot:
      return "square-root form";
    case FilterForm::kUD:
      return "UD form";
    case FilterForm::kInformation:
      return "information form";
    default:
      return "conventional form";
  }
}

struct MeasurementUpdate {
  MatrixXd K;  // n x m_o
  MatrixXd S;  // m_o x m_o
  double log_det_S = 0.0;
  double nis = 0.0;  // nu^T S^{-1} nu
  VectorXd dx;       // K nu
};

std::vector<Index> ObservedEntries(const Eigen::Ref<const VectorXd>& y) {
  std::vector<Index> observed;
  for (Index i = 0; i < y.size(); ++i) {
    if (std::isinf(y(i))) throw Error("y: expected finite entries or NaN (missing), got inf at " + std::to_string(i));
    if (!std::isnan(y(i))) observed.push_back(i);
  }
  return observed;
}

}  // namespace

// The covariance of one form, kept factored between steps.
class FactoredCovariance {
 public:
  FactoredCovariance(FilterForm form, const MatrixXd& P) : form_(form), n_(P.rows()) {
    switch (form_) {
      case FilterForm::kSquareRoot:
        L_ = PsdFactor(P, "P");
        break;
      case FilterForm::kUD:
        Mwgs(PsdFactor(P, "P"), VectorXd::Ones(n_), &U_, &d_);
        break;
      case FilterForm::kInformation: {
        Eigen::LLT<MatrixXd> llt(P);
        if (llt.info() != Eigen::Success) {
          throw NumericalError("information form: expected a positive definite covariance P (Cholesky failed)");
        }
        Y_ = llt.solve(MatrixXd::Identity(n_, n_));
        Symmetrize(Y_);
        break;
      }
      default:
        throw InternalError("FactoredCovariance: conventional form");
    }
  }

  // The step's matrices change: the factor of Q is made anew at the next Predict.
  void NewStep() { noise_factor_.resize(0, 0); }

  MatrixXd Covariance() const {
    MatrixXd P;
    switch (form_) {
      case FilterForm::kSquareRoot:
        P.noalias() = L_ * L_.transpose();
        break;
      case FilterForm::kUD:
        P.noalias() = U_ * d_.asDiagonal() * U_.transpose();
        break;
      default: {
        Eigen::LLT<MatrixXd> llt(Y_);
        if (llt.info() != Eigen::Success) {
          throw NumericalError("information matrix not positive definite (Cholesky failed)");
        }
        P = llt.solve(MatrixXd::Identity(n_, n_));
        break;
      }
    }
    Symmetrize(P);
    return P;
  }

  void Predict(const ModelStep& s) {
    const MatrixXd& A = s.A;
    if (form_ == FilterForm::kInformation) {
      PredictInformation(s);
      return;
    }
    const MatrixXd& G = NoiseFactor(s);
    if (form_ == FilterForm::kSquareRoot) {
      MatrixXd pre(L_.cols() + G.cols(), n_);
      pre.topRows(L_.cols()).noalias() = (A * L_).transpose();
      pre.bottomRows(G.cols()) = G.transpose();
      Eigen::HouseholderQR<MatrixXd> qr(pre);
      L_ = qr.matrixQR().topRows(n_).triangularView<Eigen::Upper>().transpose();
    } else {
      MatrixXd W(n_, n_ + G.cols());
      W.leftCols(n_).noalias() = A * U_;
      W.rightCols(G.cols()) = G;
      VectorXd dw(n_ + G.cols());
      dw << d_, VectorXd::Ones(G.cols());
      Mwgs(std::move(W), dw, &U_, &d_);
    }
  }

  // Update with the observed rows C (m_o x n), their noise covariance R and innovation nu.
  MeasurementUpdate Update(const MatrixXd& C, const MatrixXd& R, const VectorXd& nu) {
    const Index m = C.rows();
    Eigen::LLT<MatrixXd> r_llt(R);
    if (r_llt.info() != Eigen::Success) {
      throw NumericalError("measurement noise covariance R: not positive definite (Cholesky failed)");
    }
    const MatrixXd Lr = r_llt.matrixL();
    MeasurementUpdate u;
    if (form_ == FilterForm::kSquareRoot) {
      const Index p = L_.cols();
      MatrixXd pre = MatrixXd::Zero(m + p, m + n_);
      pre.topLeftCorner(m, m) = Lr.transpose();
      pre.bottomLeftCorner(p, m).noalias() = (C * L_).transpose();
      pre.bottomRightCorner(p, n_) = L_.transpose();
      Eigen::HouseholderQR<MatrixXd> qr(pre);
      const MatrixXd& Rq = qr.matrixQR();
      const MatrixXd R11 = Rq.topLeftCorner(m, m).triangularView<Eigen::Upper>();
      if (!(R11.diagonal().cwiseAbs().minCoeff() > 0.0)) {
        throw NumericalError("innovation covariance S: singular square-root factor");
      }
      const MatrixXd R12 = Rq.topRightCorner(m, n_);
      u.K = R11.triangularView<Eigen::Upper>().solve(R12).transpose();
      u.S.noalias() = R11.transpose() * R11;
      u.log_det_S = 2.0 * R11.diagonal().cwiseAbs().array().log().sum();
      const VectorXd w = R11.transpose().triangularView<Eigen::Lower>().solve(nu);
      u.nis = w.squaredNorm();
      // L+ = R22^T: n x n lower triangular (rows m.. of the triangular factor exist when p >= n).
      MatrixXd R22 = MatrixXd::Zero(n_, n_);
      const Index rows = std::min<Index>(n_, Rq.rows() - m);
      R22.topRows(rows) = Rq.block(m, m, rows, n_).triangularView<Eigen::Upper>();
      L_ = R22.transpose();
    } else if (form_ == FilterForm::kUD) {
      const MatrixXd CU = C * U_;
      u.S = R;
      u.S.noalias() += CU * d_.asDiagonal() * CU.transpose();
      const MatrixXd Ct = Lr.triangularView<Eigen::Lower>().solve(C);  // decorrelated rows
      const VectorXd nut = Lr.triangularView<Eigen::Lower>().solve(nu);
      MatrixXd Gw(n_, m);  // gain for the decorrelated innovations
      VectorXd dx = VectorXd::Zero(n_), k;
      double log_alpha = 0.0;
      for (Index i = 0; i < m; ++i) {
        const VectorXd h = Ct.row(i).transpose();
        const double e = nut(i) - h.dot(dx);
        const double alpha = BiermanScalar(U_, d_, h, &k);
        log_alpha += std::log(alpha);
        u.nis += e * e / alpha;
        dx += k * e;
        if (i > 0) {
          const Eigen::RowVectorXd hG = h.transpose() * Gw.leftCols(i);
          Gw.leftCols(i).noalias() -= k * hG;
        }
        Gw.col(i) = k;
      }
      // K = Gw L_R^{-1}
      u.K = Lr.transpose().triangularView<Eigen::Upper>().solve(Gw.transpose()).transpose();
      u.log_det_S = log_alpha + 2.0 * Lr.diagonal().array().log().sum();
    } else {
      Eigen::LLT<MatrixXd> y_llt(Y_);
      if (y_llt.info() != Eigen::Success) {
        throw NumericalError("information matrix not positive definite (Cholesky failed)");
      }
      const MatrixXd Z = y_llt.matrixL().solve(C.transpose());  // L_Y^{-1} C^T
      u.S = R;
      u.S.noalias() += Z.transpose() * Z;
      Symmetrize(u.S);
      Eigen::LLT<MatrixXd> s_llt(u.S);
      if (s_llt.info() != Eigen::Success) {
        throw NumericalError("innovation covariance S = C P C^T + R: not positive definite (Cholesky failed)");
      }
      u.log_det_S = 2.0 * s_llt.matrixLLT().diagonal().array().log().sum();
      u.nis = s_llt.matrixL().solve(nu).squaredNorm();
      const MatrixXd Ct = Lr.triangularView<Eigen::Lower>().solve(C);
      Y_.noalias() += Ct.transpose() * Ct;
      Symmetrize(Y_);
      Eigen::LLT<MatrixXd> yp_llt(Y_);
      if (yp_llt.info() != Eigen::Success) {
        throw NumericalError("updated information matrix not positive definite (Cholesky failed)");
      }
      const MatrixXd KLr = yp_llt.solve(Ct.transpose());  // P+ C^T L_R^{-T}
      u.K = Lr.transpose().triangularView<Eigen::Upper>().solve(KLr.transpose()).transpose();
    }
    u.dx.noalias() = u.K * nu;
    return u;
  }

 private:
  // The factor of s.Q, made at the first Predict after NewStep (once per run for a time-invariant model).
  const MatrixXd& NoiseFactor(const ModelStep& s) {
    if (noise_factor_.rows() != n_) noise_factor_ = PsdFactor(s.Q, "process noise covariance Q");
    return noise_factor_;
  }

  void PredictInformation(const ModelStep& s) {
    const MatrixXd& A = s.A;
    const MatrixXd I = MatrixXd::Identity(n_, n_);
    Eigen::PartialPivLU<MatrixXd> a_lu(A);
    const VectorXd pivots = a_lu.matrixLU().diagonal().cwiseAbs();
    if (pivots.minCoeff() > 1e-12 * pivots.maxCoeff() && a_lu.rcond() > 1e-12) {
      const MatrixXd Ainv = a_lu.inverse();
      const MatrixXd M = Ainv.transpose() * Y_ * Ainv;
      MatrixXd IMQ = I;
      IMQ.noalias() += M * s.Q;
      Y_ = Eigen::PartialPivLU<MatrixXd>(IMQ).solve(M);
    } else {
      Eigen::LLT<MatrixXd> q_llt(s.Q);
      if (q_llt.info() != Eigen::Success) {
        throw Error(
            "information form: expected A_k invertible or Q_k positive definite (A_k is singular, Q_k is not "
            "positive definite)");
      }
      const MatrixXd Qi = q_llt.solve(I);
      const MatrixXd QiA = Qi * A;
      MatrixXd W = Y_;
      W.noalias() += A.transpose() * QiA;
      Symmetrize(W);
      Eigen::LLT<MatrixXd> w_llt(W);
      if (w_llt.info() != Eigen::Success) throw NumericalError("Y + A^T Q^{-1} A not positive definite");
      Y_ = Qi;
      Y_.noalias() -= QiA * w_llt.solve(QiA.transpose());
    }
    Symmetrize(Y_);
  }

  FilterForm form_;
  Index n_;
  MatrixXd L_;  // square root: P = L L^T (n x n, lower triangular after the first step)
  MatrixXd U_;  // UD
  VectorXd d_;
  MatrixXd Y_;             // information
  MatrixXd noise_factor_;  // of the current step's Q; empty until the first Predict of a step
};

FactoredForm::FactoredForm(const KalmanFilterOptions& options, Index n) : form_(options.form), n_(n) {}

FactoredForm::~FactoredForm() = default;

std::string FactoredForm::context() const { return FormName(form_) + ": "; }

void FactoredForm::Start(const VectorXd& x, const MatrixXd& P) {
  cov_ = std::make_unique<FactoredCovariance>(form_, P);
  x_ = x;
  P_ = P;
}

void FactoredForm::SetStep(const ModelStep& s) {
  step_ = &s;
  cov_->NewStep();
}

void FactoredForm::Predict() {
  VectorXd x;
  x.noalias() = step_->A * x_;
  cov_->Predict(*step_);
  P_ = cov_->Covariance();
  x_ = std::move(x);
}

bool FactoredForm::Update(const Eigen::Ref<const VectorXd>& y) {
  observed_ = ObservedEntries(y);
  log_likelihood_ = 0.0;
  if (observed_.empty()) {
    innovation_.resize(0);
    innovation_cov_.resize(0, 0);
    gain_.resize(n_, 0);
    return false;
  }
  const ModelStep& s = *step_;
  if (s.has_cross_covariance()) return CorrelatedUpdate(y);
  const bool all = static_cast<Index>(observed_.size()) == s.C.rows();
  const MatrixXd Co = all ? s.C : MatrixXd(s.C(observed_, Eigen::all));
  const MatrixXd Ro = all ? s.R : MatrixXd(s.R(observed_, observed_));
  innovation_ = y(observed_) - Co * x_;
  MeasurementUpdate u = cov_->Update(Co, Ro, innovation_);
  x_ += u.dx;
  log_likelihood_ = -0.5 * (static_cast<double>(observed_.size()) * kLog2Pi + u.log_det_S + u.nis);
  innovation_cov_ = std::move(u.S);
  gain_ = std::move(u.K);
  P_ = cov_->Covariance();
  return true;
}

// With a cross-covariance S (issue 22) the factored forms do the measurement update on P itself: the
// conventional form's correlated Joseph update (conventional_form.hpp, the one implementation of it), and
// the result is factored again for the next time update (O(n^3) per step, as the factored updates are).
// There is no factored correlated update here: in kfx's convention S pairs the noise producing x_k with
// the measurement of x_k, and no transformation of the model removes it (docs/notation.md, 1.6).
bool FactoredForm::CorrelatedUpdate(const Eigen::Ref<const VectorXd>& y) {
  KalmanFilterOptions joseph;
  joseph.update_form = CovarianceUpdateForm::kJoseph;
  conventional::StepWorkspace<MatrixXd, VectorXd> w;
  if (!conventional::UpdateInPlace(step_->C, step_->R, step_->S, y, joseph, x_, P_, w)) return false;
  cov_ = std::make_unique<FactoredCovariance>(form_, P_);
  observed_ = std::move(w.observed);
  innovation_ = std::move(w.nu);
  innovation_cov_ = std::move(w.S);
  gain_ = std::move(w.K);
  log_likelihood_ = w.log_likelihood;
  return true;
}

}  // namespace kfx::detail
