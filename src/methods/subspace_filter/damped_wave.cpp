// The damped wave equation of paper 000 Sec. 5: P1 finite elements and implicit Euler (damped_wave.hpp).
#include "kfx/damped_wave.hpp"

#include <Eigen/Sparse>
#include <cmath>
#include <memory>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"

extern "C" {
// LAPACK band LU (Debian liblapack).
void dgbtrf_(const int* m, const int* n, const int* kl, const int* ku, double* ab, const int* ldab, int* ipiv,
             int* info);
void dgbtrs_(const char* trans, const int* n, const int* kl, const int* ku, const int* nrhs, const double* ab,
             const int* ldab, const int* ipiv, double* b, const int* ldb, int* info, std::size_t trans_len);
}

namespace kfx {

namespace {

using Eigen::MatrixXd;
using SpMat = Eigen::SparseMatrix<double>;

// The implicit-Euler matrix G = M_aug - dt A_cont in the interleaved ordering (z_1, v_1, z_2, v_2, ...),
// where it is banded with kl = ku = 3, factored once by LAPACK dgbtrf; Solve applies G^{-1} to a block
// given in kfx's (z, v) ordering.
class BandedImplicitEuler {
 public:
  BandedImplicitEuler(const SpMat& G, int n) : n_(n), N_(2 * n), ldab_(2 * kKl + kKu + 1) {
    ab_.assign(static_cast<std::size_t>(ldab_) * N_, 0.0);
    ipiv_.assign(static_cast<std::size_t>(N_), 0);
    for (int k = 0; k < G.outerSize(); ++k) {
      for (SpMat::InnerIterator it(G, k); it; ++it) {
        const int i = Interleaved(static_cast<int>(it.row())), j = Interleaved(static_cast<int>(it.col()));
        KFX_ASSERT(i - j <= kKl && j - i <= kKu);
        ab_[static_cast<std::size_t>(kKl + kKu + i - j) + static_cast<std::size_t>(j) * ldab_] = it.value();
      }
    }
    int info = 0;
    dgbtrf_(&N_, &N_, &kKl, &kKu, ab_.data(), &ldab_, ipiv_.data(), &info);
    if (info != 0) throw NumericalError("M_aug - dt A_cont: band LU failed (dgbtrf info " + std::to_string(info) + ")");
  }
  // X (2n x c) in (z, v) ordering -> G^{-1} X in the same ordering.
  MatrixXd Solve(const MatrixXd& X) const {
    const int c = static_cast<int>(X.cols());
    MatrixXd B(N_, c);
    for (int i = 0; i < N_; ++i) B.row(Interleaved(i)) = X.row(i);
    int info = 0;
    const char trans = 'N';
    dgbtrs_(&trans, &N_, &kKl, &kKu, &c, ab_.data(), &ldab_, ipiv_.data(), B.data(), &N_, &info, 1);
    KFX_ASSERT(info == 0);
    MatrixXd Y(N_, c);
    for (int i = 0; i < N_; ++i) Y.row(i) = B.row(Interleaved(i));
    return Y;
  }

 private:
  static constexpr int kKl = 3, kKu = 3;
  int Interleaved(int i) const { return i < n_ ? 2 * i : 2 * (i - n_) + 1; }
  int n_, N_, ldab_;
  std::vector<double> ab_;
  std::vector<int> ipiv_;
};

void RequireNodes(int nodes) {
  if (nodes < 1) throw Error("nodes: expected at least 1 interior node, got " + std::to_string(nodes));
}

// Gauss-Legendre nodes and weights on [-1, 1] (Golub-Welsch).
void GaussLegendre(int q, Eigen::VectorXd* x, Eigen::VectorXd* w) {
  MatrixXd J = MatrixXd::Zero(q, q);
  for (int i = 1; i < q; ++i) {
    const double b = i / std::sqrt(4.0 * i * i - 1.0);
    J(i, i - 1) = J(i - 1, i) = b;
  }
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(J);
  *x = es.eigenvalues();
  *w = 2.0 * es.eigenvectors().row(0).transpose().array().square();
}

SpMat Tridiagonal(int n, double diag, double off) {
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, diag);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, off);
      t.emplace_back(i + 1, i, off);
    }
  }
  SpMat S(n, n);
  S.setFromTriplets(t.begin(), t.end());
  return S;
}

}  // namespace

MatrixXd P1Stiffness(int nodes) {
  RequireNodes(nodes);
  const double h = 1.0 / (nodes + 1);
  return MatrixXd(Tridiagonal(nodes, 2.0 / h, -1.0 / h));
}

MatrixXd P1Mass(int nodes) {
  RequireNodes(nodes);
  const double h = 1.0 / (nodes + 1);
  return MatrixXd(Tridiagonal(nodes, 4.0 * h / 6.0, h / 6.0));
}

MatrixXd P1Load(int nodes, const std::vector<std::function<double(double)>>& f) {
  RequireNodes(nodes);
  const double h = 1.0 / (nodes + 1);
  const int sub = std::max(1, static_cast<int>(std::ceil(h * 1024.0)));
  Eigen::VectorXd gx, gw;
  GaussLegendre(8, &gx, &gw);
  MatrixXd F = MatrixXd::Zero(nodes, static_cast<Eigen::Index>(f.size()));
  for (int e = 0; e <= nodes; ++e) {  // element [e h, (e + 1) h]; left node e - 1, right node e (0-based)
    const double x0 = e * h;
    const double hs = h / sub;
    for (int s = 0; s < sub; ++s) {
      const double a = x0 + s * hs;
      for (int g = 0; g < gx.size(); ++g) {
        const double x = a + 0.5 * hs * (gx(g) + 1.0);
        const double wq = 0.5 * hs * gw(g);
        const double t = (x - x0) / h;  // local coordinate in [0, 1]
        for (size_t j = 0; j < f.size(); ++j) {
          const double fx = f[j](x) * wq;
          if (e - 1 >= 0) F(e - 1, static_cast<Eigen::Index>(j)) += fx * (1.0 - t);
          if (e < nodes) F(e, static_cast<Eigen::Index>(j)) += fx * t;
        }
      }
    }
  }
  return F;
}

MatrixXd P1Prolongation(int fine_nodes, int coarse_nodes) {
  RequireNodes(fine_nodes);
  RequireNodes(coarse_nodes);
  if ((fine_nodes + 1) % (coarse_nodes + 1) != 0) {
    throw Error("coarse_nodes: expected (fine_nodes + 1) to be a multiple of (coarse_nodes + 1) (nested meshes), got " +
                std::to_string(fine_nodes) + " and " + std::to_string(coarse_nodes));
  }
  const double hf = 1.0 / (fine_nodes + 1), hc = 1.0 / (coarse_nodes + 1);
  MatrixXd E = MatrixXd::Zero(fine_nodes, coarse_nodes);
  for (int i = 0; i < fine_nodes; ++i) {
    const double x = (i + 1) * hf;
    for (int J = 0; J < coarse_nodes; ++J) {
      const double X = (J + 1) * hc;
      E(i, J) = std::max(0.0, 1.0 - std::abs(x - X) / hc);
    }
  }
  return E;
}

bool DampedWaveOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (fine_nodes < 1) return fail("fine_nodes: expected >= 1");
  if (coarse_nodes < 1) return fail("coarse_nodes: expected >= 1");
  if ((fine_nodes + 1) % (coarse_nodes + 1) != 0) {
    return fail("coarse_nodes: expected (fine_nodes + 1) to be a multiple of (coarse_nodes + 1), got " +
                std::to_string(fine_nodes) + " and " + std::to_string(coarse_nodes));
  }
  if (!(eps >= 0 && std::isfinite(eps))) return fail("eps: expected a finite value >= 0");
  if (!(dt > 0 && std::isfinite(dt))) return fail("dt: expected a finite value > 0");
  if (U.size() > 0 && (U.rows() != 3 || U.cols() != 3)) return fail("U: expected 3x3, got " + ShapeString(U));
  if (R.size() > 0 && (R.rows() != 2 || R.cols() != 2)) return fail("R: expected 2x2, got " + ShapeString(R));
  return true;
}

WaveDiscretization DiscretizeDampedWave(int nodes, const DampedWaveOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  RequireNodes(nodes);
  const int n = nodes;
  const double h = 1.0 / (n + 1);
  WaveDiscretization d;
  d.nodes = n;
  const SpMat K = Tridiagonal(n, 2.0 / h, -1.0 / h);
  const SpMat M = Tridiagonal(n, 4.0 * h / 6.0, h / 6.0);
  d.stiffness = MatrixXd(K);
  d.mass = MatrixXd(M);
  const double pi = 3.14159265358979323846;
  d.load = P1Load(
      n, {[pi](double x) { return (1.0 - x) * std::sin(pi * x); }, [](double x) { return 7.0 * x * x * (1.0 - x); },
          [pi](double x) {
            const double s = std::sin(6.0 * pi * x);
            return x > 0 ? s * s / x : 0.0;
          }});
  d.output = P1Load(n, {[](double x) { return 1.4 / std::pow(x + 1.0, 1.7); },
                        [](double x) { return 1.0 / std::pow(2.0 - x, 1.3); }})
                 .transpose();
  // G = M_aug - dt A_cont = [[I, -dt I], [dt K, (1 + dt eps) M]].
  const double dt = options.dt, eps = options.eps;
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 1.0);
    t.emplace_back(i, n + i, -dt);
  }
  for (int k = 0; k < K.outerSize(); ++k) {
    for (SpMat::InnerIterator it(K, k); it; ++it) t.emplace_back(n + it.row(), it.col(), dt * it.value());
  }
  for (int k = 0; k < M.outerSize(); ++k) {
    for (SpMat::InnerIterator it(M, k); it; ++it)
      t.emplace_back(n + it.row(), n + it.col(), (1.0 + dt * eps) * it.value());
  }
  SpMat G(2 * n, 2 * n);
  G.setFromTriplets(t.begin(), t.end());
  G.makeCompressed();
  auto lu = std::make_shared<const BandedImplicitEuler>(G, n);
  auto Mp = std::make_shared<SpMat>(M);
  d.apply_A = [lu, Mp, n](const MatrixXd& X) -> MatrixXd {
    MatrixXd rhs(X.rows(), X.cols());
    rhs.topRows(n) = X.topRows(n);
    rhs.bottomRows(n) = (*Mp) * X.bottomRows(n);
    return lu->Solve(rhs);
  };
  const MatrixXd U = options.U.size() > 0 ? options.U : MatrixXd(Eigen::Vector3d(1.0, 1.0, 0.25).asDiagonal());
  const MatrixXd R = options.R.size() > 0 ? options.R : MatrixXd(Eigen::Vector2d(0.3, 0.15).asDiagonal());
  MatrixXd B = MatrixXd::Zero(2 * n, 3);
  if (options.noise_before_implicit_step) {
    MatrixXd F0 = MatrixXd::Zero(2 * n, 3);
    F0.bottomRows(n) = d.load;
    B = lu->Solve(F0);
  } else {
    B.bottomRows(n) = d.mass.llt().solve(d.load);
  }
  MatrixXd C = MatrixXd::Zero(2, 2 * n);
  C.leftCols(n) = d.output;
  MatrixXd A;
  if (options.build_dense_A) {
    A = d.apply_A(MatrixXd::Identity(2 * n, 2 * n));
  } else {
    A = MatrixXd::Zero(2 * n, 2 * n);  // placeholder: callers use apply_A
  }
  d.step = MakeStepWithNoiseInput(A, B, dt * U, C, R);
  d.gram = MatrixXd::Zero(2 * n, 2 * n);
  d.gram.topLeftCorner(n, n) = d.stiffness;
  d.gram.bottomRightCorner(n, n) = d.mass;
  d.gram_position = MatrixXd::Zero(2 * n, 2 * n);
  d.gram_position.topLeftCorner(n, n) = d.stiffness;
  d.gram_velocity = MatrixXd::Zero(2 * n, 2 * n);
  d.gram_velocity.bottomRightCorner(n, n) = d.mass;
  return d;
}

DampedWaveProblem BuildDampedWave(const DampedWaveOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  DampedWaveProblem p;
  p.fine = DiscretizeDampedWave(options.fine_nodes, options);
  DampedWaveOptions coarse_options = options;
  coarse_options.build_dense_A = true;
  p.coarse = DiscretizeDampedWave(options.coarse_nodes, coarse_options);
  const MatrixXd E = P1Prolongation(options.fine_nodes, options.coarse_nodes);
  const int nf = options.fine_nodes, nc = options.coarse_nodes;
  p.prolongation = MatrixXd::Zero(2 * nf, 2 * nc);
  p.prolongation.topLeftCorner(nf, nc) = E;
  p.prolongation.bottomRightCorner(nf, nc) = E;
  p.subspace = SubspaceFromBasis(p.prolongation, p.fine.gram);
  return p;
}

}  // namespace kfx
