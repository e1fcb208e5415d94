#pragma once
// A chain of masses connected by springs and dampers (paper 001, Chandrasekar, Kim, Bernstein;
// docs/papers/README.md; Fig. 1, Secs. V-VI):
//   wall --k_0,c_0-- m_1 --k_1,c_1-- m_2 -- ... -- m_N --k_N,c_N-- wall
// Element i (0..N) joins mass i and mass i + 1 (mass 0 and mass N + 1 are the walls). A free end
// drops its end element. With q the positions, M q'' + D q' + K q = 0, K and D tridiagonal:
//   K_ii = k_{i-1} + k_i,  K_{i,i+1} = -k_i  (masses 1-based, end elements only when fixed).
// The state is interleaved, x = (q_1, q_1', q_2, q_2', ...); the continuous A_c has blocks
// [[0, 1], [-K_ij / m_i, -D_ij / m_i]]. The discrete A_d = e^{A_c dt} is the zero-order-hold
// sampling (DiscretizeZoh, discretize.hpp). Optionally the pair of one mass comes first and the
// others keep their order (001 Sec. VI: x = (q_11, q_11', q_1, q_1', ..., q_20, q_20')).
#include <Eigen/Dense>
#include <string>

namespace kfx {

struct SpringMassChainOptions {
  Eigen::VectorXd masses{};     ///< N > 0 positive masses m_1..m_N
  Eigen::VectorXd stiffness{};  ///< N + 1 spring constants k_0..k_N (>= 0); end ones ignored when free
  Eigen::VectorXd damping{};    ///< N + 1 damper constants c_0..c_N (>= 0); end ones ignored when free
  bool left_fixed = true;
  bool right_fixed = true;
  double dt = 0.1;     ///< sampling step (> 0) of the zero-order hold
  int first_mass = 0;  ///< 1-based mass whose (q, q') pair is listed first; 0: natural order
  bool IsValid(std::string* error) const;
};

/// Uniform chain: N masses m, all N + 1 elements k, c.
SpringMassChainOptions UniformChain(int N, double m, double k, double c, bool left_fixed, bool right_fixed, double dt);

struct SpringMassChain {
  Eigen::MatrixXd Ac;     ///< 2N x 2N continuous-time matrix (in the listed order)
  Eigen::MatrixXd Ad;     ///< 2N x 2N e^{Ac dt}
  Eigen::MatrixXd K, D;   ///< N x N stiffness and damping matrices (natural mass order)
  Eigen::VectorXi order;  ///< state index i of the listed state lists natural state order(i)
};

/// @throws kfx::Error on invalid options (naming the field).
SpringMassChain BuildSpringMassChain(const SpringMassChainOptions& options);

}  // namespace kfx
