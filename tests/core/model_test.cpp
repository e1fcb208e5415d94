// Model validation: every precondition throws kfx::Error naming the argument.
#include "kfx/model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "kfx/error.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

ModelStep GoodStep() {
  MatrixXd A(2, 2);
  A << 1, 1, 0, 1;
  MatrixXd C(1, 2);
  C << 1, 0;
  MatrixXd Q(2, 2);
  Q << 1.0 / 3, 0.5, 0.5, 1;
  return MakeStep(A, C, Q, MatrixXd::Identity(1, 1));
}

TEST(Model, TimeInvariantAccessors) {
  Model m(GoodStep(), VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  EXPECT_EQ(m.state_dim(), 2);
  EXPECT_EQ(m.meas_dim(), 1);
  EXPECT_TRUE(m.time_invariant());
  EXPECT_EQ(m.horizon(), -1);
  EXPECT_EQ(m.step(1).get(), m.step(1000).get());  // shared, not copied
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { m.step(0); }, "k"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { m.ResolveSteps(-1); }, "steps"));
}

TEST(Model, SequenceAndCallbackAgree) {
  std::vector<ModelStep> steps;
  for (int k = 1; k <= 4; ++k) {
    ModelStep s = GoodStep();
    s.A(0, 1) = 0.1 * k;
    steps.push_back(s);
  }
  Model seq(steps, VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  Model fun(
      2, 1, [&](int k) { return steps[static_cast<size_t>(k - 1)]; }, VectorXd::Zero(2), MatrixXd::Identity(2, 2), 4);
  EXPECT_EQ(seq.horizon(), 4);
  for (int k = 1; k <= 4; ++k) EXPECT_MATRICES_NEAR(seq.step(k)->A, fun.step(k)->A, 0.0);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { seq.step(5); }, "k"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { seq.ResolveSteps(5); }, "steps"));
}

TEST(Model, NoiseInputSetsQ) {
  MatrixXd A = MatrixXd::Identity(3, 3), B(3, 1), C = MatrixXd::Ones(1, 3);
  B << 1, 2, 3;
  ModelStep s = MakeStepWithNoiseInput(A, B, MatrixXd::Constant(1, 1, 2.0), C, MatrixXd::Identity(1, 1));
  EXPECT_MATRICES_NEAR(s.Q, 2.0 * B * B.transpose(), 1e-15);
  Model m(s, VectorXd::Zero(3), MatrixXd::Zero(3, 3));  // P0 = 0 is allowed (PSD)
  ModelStep bad = s;
  bad.Q(0, 0) += 1.0;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(bad, VectorXd::Zero(3), MatrixXd::Zero(3, 3)); }, "Q"));
}

TEST(Model, EveryValidationErrorNamesItsArgument) {
  const VectorXd m0 = VectorXd::Zero(2);
  const MatrixXd P0 = MatrixXd::Identity(2, 2);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto with = [&](auto mutate) {
    ModelStep s = GoodStep();
    mutate(s);
    return s;
  };
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] { Model(with([](ModelStep& s) { s.A = MatrixXd::Identity(2, 3); }), m0, P0); }, "A"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(with([&](ModelStep& s) { s.A(1, 0) = nan; }), m0, P0); }, "A"));
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { Model(with([](ModelStep& s) { s.C = MatrixXd::Ones(1, 3); }), m0, P0); }, "C"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(with([&](ModelStep& s) { s.C(0, 1) = inf; }), m0, P0); }, "C"));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] { Model(with([](ModelStep& s) { s.Q = MatrixXd::Identity(3, 3); }), m0, P0); }, "Q"));
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { Model(with([](ModelStep& s) { s.Q(0, 1) = 0.9; }), m0, P0); }, "symmetric"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(with([](ModelStep& s) { s.Q(0, 0) = -1; }), m0, P0); }, "Q"));
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { Model(with([](ModelStep& s) { s.Q(0, 0) = -1; }), m0, P0); }, "semidefinite"));
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { Model(with([](ModelStep& s) { s.R = MatrixXd::Zero(1, 1); }), m0, P0); }, "R"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(with([](ModelStep& s) { s.R = MatrixXd::Zero(1, 1); }), m0, P0); },
                                         "positive definite"));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] { Model(with([](ModelStep& s) { s.R = MatrixXd::Identity(2, 2); }), m0, P0); }, "R"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(with([&](ModelStep& s) { s.R(0, 0) = nan; }), m0, P0); }, "R"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(GoodStep(), VectorXd::Zero(3), P0); }, "m0"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(GoodStep(), VectorXd::Constant(2, nan), P0); }, "m0"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(GoodStep(), m0, MatrixXd::Identity(3, 3)); }, "P0"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(GoodStep(), m0, -MatrixXd::Identity(2, 2)); }, "P0"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(std::vector<ModelStep>{}, m0, P0); }, "steps"));
  // A bad step in a sequence is named by its index.
  std::vector<ModelStep> steps(3, GoodStep());
  steps[2].R(0, 0) = -1;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(steps, m0, P0); }, "step 3: R"));
  // Callback steps are validated when asked for.
  Model fun(
      2, 1, [&](int) { return steps[2]; }, m0, P0);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { fun.step(1); }, "step 1: R"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Model(2, 1, Model::StepFunction(), m0, P0); }, "function"));
}

// Issue 20, class 3: zero dimensions are rejected at validation, naming the matrix, by every constructor
// (before, a 0 x 0 model was accepted and the smoother segfaulted, the simulator called BLAS with n = 0).
TEST(Model, ZeroDimensionsAreRejectedNamingTheMatrix) {
  const MatrixXd none(0, 0);
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] { Model(MakeStep(none, MatrixXd(1, 0), none, MatrixXd::Identity(1, 1)), VectorXd(0), none); }, "A",
      {"n = 0"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] {
        Model(MakeStep(MatrixXd::Identity(2, 2), MatrixXd(0, 2), MatrixXd::Identity(2, 2), none), VectorXd::Zero(2),
              MatrixXd::Identity(2, 2));
      },
      "C", {"m = 0"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] {
        Model(std::vector<ModelStep>{MakeStep(none, MatrixXd(1, 0), none, MatrixXd::Identity(1, 1))}, VectorXd(0),
              none);
      },
      "step 1: A"));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] {
        Model(
            0, 1, [](int) { return GoodStep(); }, VectorXd(0), none);
      },
      "n", {"n = 0"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] {
        Model(
            2, 0, [](int) { return GoodStep(); }, VectorXd::Zero(2), MatrixXd::Identity(2, 2));
      },
      "m", {"m = 0"}));
  // The smallest model (n = m = 1) is valid.
  EXPECT_EQ(Model(MakeStep(MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1)),
                  VectorXd::Zero(1), MatrixXd::Ones(1, 1))
                .state_dim(),
            1);
}

// Class 12 of docs/robustness.md: a message blames the matrix at fault and states the threshold.
TEST(Model, MessagesBlameTheMatrixAtFaultAndStateTheThreshold) {
  const VectorXd m0 = VectorXd::Zero(2);
  const MatrixXd P0 = MatrixXd::Identity(2, 2);
  const ModelStep g = GoodStep();
  // An indefinite U: Q = B U B^T is derived from it, so U is named, not Q.
  const ModelStep noise =
      MakeStepWithNoiseInput(g.A, (MatrixXd(2, 1) << 0, 1).finished(), -MatrixXd::Ones(1, 1), g.C, g.R);
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { Model(noise, m0, P0); }, "U:", {"semidefinite"}));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { Model(std::vector<ModelStep>{g, noise}, m0, P0); }, "step 2: U:"));
  // R with condition number 1e13 (smallest eigenvalue 1e-13 > 0) is rejected by the relative
  // threshold 1e-12, and the message says so.
  ModelStep r = g;
  r.C = MatrixXd::Identity(2, 2);
  r.R = (VectorXd(2) << 1.0, 1e-13).finished().asDiagonal();
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(
      [&] { Model(r, m0, P0); }, "R:", {"positive definite", "condition number below about 1e+12", "1e-13"}));
  r.R(1, 1) = 1e-11;  // condition number 1e11: accepted
  EXPECT_NO_THROW(Model(r, m0, P0));
}

}  // namespace
}  // namespace kfx
