#include "kfx/discretize.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "kfx/error.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;

TEST(Discretize, ScalarClosedForms) {
  for (double a : {-0.7, 0.3, 0.0}) {
    const double b = 1.7, q = 0.9, dt = 0.25;
    MatrixXd A(1, 1), B(1, 1), Q(1, 1);
    A << a;
    B << b;
    Q << q;
    const ZohDiscretization zoh = DiscretizeZoh(A, B, dt);
    const NoiseDiscretization noise = DiscretizeProcessNoise(A, Q, dt);
    const double ad = std::exp(a * dt);
    const double bd = a == 0.0 ? b * dt : (ad - 1.0) / a * b;
    const double qd = a == 0.0 ? q * dt : q * (std::exp(2 * a * dt) - 1.0) / (2 * a);
    EXPECT_NEAR(zoh.Ad(0, 0), ad, 1e-15);
    EXPECT_NEAR(noise.Ad(0, 0), ad, 1e-15);
    EXPECT_NEAR(zoh.Bd(0, 0), bd, 1e-14);
    EXPECT_NEAR(noise.Qd(0, 0), qd, 1e-14);
  }
}

TEST(Discretize, RotationClosedForm) {
  const double w = 3.0, dt = 0.4;
  MatrixXd A(2, 2);
  A << 0, w, -w, 0;
  MatrixXd R(2, 2);
  R << std::cos(w * dt), std::sin(w * dt), -std::sin(w * dt), std::cos(w * dt);
  EXPECT_LT((MatrixExponential(A * dt) - R).norm(), 1e-14);
}

// Independent identities: A Bd = (Ad - I) B, and Q(t) = int_0^t e^{As} Qc e^{A^T s} ds solves
// A Q + Q A^T + Qc = e^{At} Qc e^{A^T t}; the semigroup property Q(2h) = Q(h) + Ad(h) Q(h) Ad(h)^T
// compares one step against two half steps (the fine-step reference).
TEST(Discretize, IdentitiesAndSemigroupOnRandomSystems) {
  testing::TestRng rng(11);
  for (int trial = 0; trial < 10; ++trial) {
    const int n = 1 + trial % 5, m = 1 + trial % 3;
    const MatrixXd A = rng.Gaussian(n, n);
    const MatrixXd B = rng.Gaussian(n, m);
    const MatrixXd G = rng.Gaussian(n, n);
    const MatrixXd Qc = G * G.transpose();
    const double dt = 0.3;
    const ZohDiscretization zoh = DiscretizeZoh(A, B, dt);
    EXPECT_LT((A * zoh.Bd - (zoh.Ad - MatrixXd::Identity(n, n)) * B).norm(), 1e-12 * (1 + zoh.Bd.norm()));
    const NoiseDiscretization full = DiscretizeProcessNoise(A, Qc, dt);
    EXPECT_LT((full.Ad - zoh.Ad).norm(), 1e-13 * zoh.Ad.norm());
    const MatrixXd lyap = A * full.Qd + full.Qd * A.transpose() + Qc - full.Ad * Qc * full.Ad.transpose();
    EXPECT_LT(lyap.norm(), 1e-12 * (1 + Qc.norm() * full.Ad.squaredNorm()));
    MatrixXd Qh = DiscretizeProcessNoise(A, Qc, dt / 64).Qd;
    MatrixXd Ah = MatrixExponential(A * (dt / 64));
    for (int i = 0; i < 6; ++i) {
      Qh = Qh + Ah * Qh * Ah.transpose();
      Ah = Ah * Ah;
    }
    EXPECT_LT((Qh - full.Qd).norm(), 1e-12 * full.Qd.norm());
    EXPECT_TRUE(full.Qd.isApprox(full.Qd.transpose(), 0.0));
  }
}

TEST(Discretize, BadInputNamesTheArgument) {
  MatrixXd A = MatrixXd::Identity(2, 2), B = MatrixXd::Ones(3, 1);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { DiscretizeZoh(A, B, 0.1); }, "B"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { DiscretizeZoh(A, MatrixXd::Ones(2, 1), -1.0); }, "dt"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { DiscretizeZoh(A, MatrixXd::Ones(2, 1), std::nan("")); }, "dt"));
  MatrixXd Q(2, 2);
  Q << 1, 0, 0, -1;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { DiscretizeProcessNoise(A, Q, 0.1); }, "Qc"));
  A(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { MatrixExponential(A); }, "M"));
}

}  // namespace
}  // namespace kfx
