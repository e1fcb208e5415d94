// The method-specification grammar (kfx/method_spec.hpp): what parses into what, and one test per class
// of bad spec, each a kfx::Error naming the spec.
#include "kfx/method_spec.hpp"

#include <gtest/gtest.h>

#include "support/expect_error.hpp"

namespace kfx {
namespace {

using testing::ThrowsErrorStartingWith;

TEST(MethodSpec, ParsesNameAndParametersInOrder) {
  const MethodSpec s = ParseMethodSpec("tau:order=4,step=two-da,modes=least-damped");
  EXPECT_EQ(s.name, "tau");
  ASSERT_EQ(s.params.size(), 3u);
  EXPECT_EQ(s.params[0].first, "order");
  EXPECT_EQ(s.Get("step"), "two-da");
  EXPECT_EQ(s.GetPositive("order", 0), 4);
  EXPECT_EQ(s.Get("basis", "none"), "none");
  EXPECT_FALSE(s.Has("basis"));
}

TEST(MethodSpec, BareNamesAndPositionalValues) {
  EXPECT_TRUE(ParseMethodSpec("steady").params.empty());
  EXPECT_EQ(ParseMethodSpec("kalman:sqrt").Get("form"), "sqrt");
  const MethodSpec d = ParseMethodSpec("design:models/low q.json,gain=schedule");
  EXPECT_EQ(d.Get("model"), "models/low q.json");
  EXPECT_EQ(d.Get("gain"), "schedule");
  EXPECT_EQ(ParseMethodSpec("sampled:0.25").GetPositiveNumber("dt"), 0.25);
  for (const std::string& name : MethodNames()) {
    if (name == "design" || name == "coarse" || name == "subspace" || name == "subspace61" || name == "tau" ||
        name == "mu" || name == "sampled") {
      continue;  // these need parameters
    }
    EXPECT_EQ(ParseMethodSpec(name).name, name);
  }
}

TEST(MethodSpec, KalmanFormsAreTheLibrarysEnumNames) {
  EXPECT_EQ(KalmanFormNames(), (std::vector<std::string>{"joseph", "standard", "sqrt", "ud", "information"}));
  EXPECT_EQ(ParseKalmanForm("f", "standard").update_form, CovarianceUpdateForm::kStandard);
  EXPECT_EQ(ParseKalmanForm("f", "ud").form, FilterForm::kUD);
}

TEST(MethodSpec, EveryBadSpecIsOneErrorNamingIt) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"", "expected NAME"},
      {"kalmann", "unknown method 'kalmann'"},
      {"tau:ordr=4", "unknown parameter 'ordr'"},
      {"steady:x", "steady takes no parameters"},
      {"tau:4", "expected KEY=VALUE"},
      {"tau:order=", "order: expected a value"},
      {"tau:order=4,order=5", "given twice"},
      {"tau:order=four", "expected a positive integer"},
      {"tau:order=0", "expected a positive integer"},
      {"tau:order=-3", "expected a positive integer"},
      {"tau:step=one", "needs order=N"},
      {"tau:order=2,step=three", "step: expected one of 'one', 'two-da', 'two-forecast'"},
      {"kalman:form=cholesky", "form: expected one of 'joseph'"},
      {"design", "design needs model=..."},
      {"coarse:model=c.json", "coarse needs prolongation=..."},
      {"subspace:gram=W.npy", "subspace needs basis=FILE or mesh=N"},
      {"subspace:mesh=3,basis=E.npy", "subspace needs basis=FILE or mesh=N (one of them)"},
      {"subspace61:mesh=two", "mesh: expected a positive integer"},
      {"sampled", "sampled needs dt=..."},
      {"sampled:dt=0", "dt: expected a finite number > 0, got '0'"},
      {"sampled:-0.5", "dt: expected a finite number > 0, got '-0.5'"},
      {"sampled:dt=1e999", "dt: expected a finite number > 0"},
      {"subspace:basis=E.npy,gain=steady", "gain: expected one of 'schedule', 'converged'"},
  };
  for (const auto& [spec, what] : bad) {
    const std::string text = spec;  // C++17: a lambda cannot capture a structured binding (clang rejects it)
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { ParseMethodSpec(text); }, "method '" + text + "': ", {what})) << text;
  }
}

}  // namespace
}  // namespace kfx
