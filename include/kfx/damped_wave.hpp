#pragma once
// The damped wave equation of paper 000 (Aalto, IMA J. Math. Control Inf.; docs/papers/README.md),
// Sec. 5, discretized by P1 finite elements on nested uniform meshes of [0, 1] (Dirichlet) and
// implicit Euler in time:
//   z_tt = -eps z_t + z_xx + sum_j b_j(x) u_j,   y = (<c_1, z>, <c_2, z>) + v
// with the reading of the issue (docs/papers/000.md): state x = (z, v) in fine nodal coordinates
// (2 N_f numbers), M_aug = blkdiag(I, M), A_cont = [[0, I], [-K, -eps M]],
//   x_k = (M_aug - dt A_cont)^{-1} M_aug x_{k-1} + B_d u_k,  B_d = [0; M^{-1} F],  u_k ~ N(0, dt U),
//   F_ij = int b_j phi_i,  y_k = [C_z, 0] x_k + v_k,  (C_z)_ij = int c_i phi_j,  v_k ~ N(0, R),
// the norm of H_0^1 x L^2: W = blkdiag(K, M) (K the stiffness, M the mass matrix), and the coarse
// space (N_c interior nodes, (N_f + 1) = j (N_c + 1)) as the subspace of Algorithm 2.3.
#include <Eigen/Dense>
#include <functional>
#include <vector>

#include "kfx/model.hpp"
#include "kfx/subspace_filter.hpp"

namespace kfx {

/// P1 finite elements on the uniform mesh of [0, 1] with `nodes` interior nodes (h = 1 / (nodes + 1)),
/// Dirichlet at both ends. Dense matrices (the builder keeps a band LU factorization for A).
Eigen::MatrixXd P1Stiffness(int nodes);  ///< K_ij = int phi_i' phi_j' (tridiag(-1, 2, -1) / h)
Eigen::MatrixXd P1Mass(int nodes);       ///< M_ij = int phi_i phi_j (tridiag(1, 4, 1) h / 6)
/// F_ij = int_0^1 f_j(x) phi_i(x) dx (nodes x f.size()) by composite Gauss-Legendre quadrature
/// (sub-intervals of length <= 1/1024 within each element, 8 points each).
Eigen::MatrixXd P1Load(int nodes, const std::vector<std::function<double(double)>>& f);
/// Coarse-to-fine prolongation E (fine x coarse): column J holds the coarse hat phi_J at the fine
/// nodes. @throws kfx::Error unless (fine + 1) is a multiple of (coarse + 1).
Eigen::MatrixXd P1Prolongation(int fine_nodes, int coarse_nodes);

struct DampedWaveOptions {
  int fine_nodes = 65;   ///< N_f
  int coarse_nodes = 5;  ///< N_c
  double eps = 0.4;      ///< damping
  double dt = 0.01;      ///< time step
  Eigen::MatrixXd U;     ///< 3 x 3 input intensity (empty: diag(1, 1, 0.25)); U_d = dt U
  Eigen::MatrixXd R;     ///< 2 x 2 measurement noise covariance (empty: diag(0.3, 0.15)), not divided by dt
  /// Another reading (not the issue's): the noise enters the implicit step,
  /// (M_aug - dt A_cont) x_k = M_aug x_{k-1} + [0; F] u_k, i.e. B_d = (M_aug - dt A_cont)^{-1} [0; F].
  bool noise_before_implicit_step = false;
  bool build_dense_A = true;  ///< also form the dense A (2 N_f)^2 (needed by ModelStep; O(N_f^2) memory)
  bool IsValid(std::string* error) const;
};

/// The semi-discrete matrices on one mesh and the implicit-Euler step built from them.
struct WaveDiscretization {
  int nodes = 0;
  Eigen::MatrixXd stiffness, mass, load, output;  ///< K, M, F (nodes x 3), C_z (2 x nodes)
  ModelStep step;                                 ///< A, B = B_d, U = U_d, Q = B_d U_d B_d^T, C, R
  BlockOperator apply_A;                          ///< X -> A X by a band LU solve (LAPACK dgbtrs)
  Eigen::MatrixXd gram;                           ///< W = blkdiag(K, M)
  Eigen::MatrixXd gram_position, gram_velocity;   ///< blkdiag(K, 0), blkdiag(0, M)
};

/// @throws kfx::Error on invalid options.
WaveDiscretization DiscretizeDampedWave(int nodes, const DampedWaveOptions& options);

struct DampedWaveProblem {       ///< The damped wave problem of 000: fine and coarse models, the subspace.
  WaveDiscretization fine;       ///< the "true" system
  WaveDiscretization coarse;     ///< the coarse Galerkin model (method C of Table 1)
  Eigen::MatrixXd prolongation;  ///< 2 N_f x 2 N_c: blkdiag(E, E), coarse nodal -> fine nodal
  Subspace subspace;             ///< Pi from the coarse space, orthonormal in W
};

/// @throws kfx::Error on invalid options (including non-nested meshes).
DampedWaveProblem BuildDampedWave(const DampedWaveOptions& options = DampedWaveOptions());

}  // namespace kfx
