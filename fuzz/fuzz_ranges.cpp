// libFuzzer target: the error-ranges file of `kfx mismatch` (002), read against a fixed 2-state,
// 1-measurement design. Ranges that load must have the design's shapes (or be empty) and be finite
// and non-negative.
#include "fuzz_common.hpp"
#include "kfx/error.hpp"
#include "kfx/error_ranges_file.hpp"

namespace {
bool Fits(const Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols) {
  return m.size() == 0 || (m.rows() == rows && m.cols() == cols && m.allFinite() && (m.array() >= 0).all());
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const kfx::ModelStep design =
      kfx::MakeStep((Eigen::MatrixXd(2, 2) << 1, 1, 0, 1).finished(), (Eigen::MatrixXd(1, 2) << 1, 0).finished(),
                    (Eigen::MatrixXd(2, 2) << 0.25, 0.5, 0.5, 1).finished(), Eigen::MatrixXd::Ones(1, 1));
  const std::string path = kfx::fuzz::WriteInput("ranges.json", data, size);
  try {
    const kfx::ErrorRanges r = kfx::LoadErrorRanges(path, design);
    if (!Fits(r.A, 2, 2) || !Fits(r.C, 1, 2) || !Fits(r.Q, 2, 2) || !Fits(r.R, 1, 1)) __builtin_trap();
  } catch (const kfx::Error&) {
  } catch (const kfx::NumericalError&) {
  }
  return 0;
}
