// libFuzzer target: the CSV time-series reader.
#include "fuzz_common.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = kfx::fuzz::WriteInput("input.csv", data, size);
  try {
    std::vector<std::string> names;
    const kfx::TimeSeries ts = kfx::ReadTimeSeries(path, &names);
    if (!names.empty() && static_cast<Eigen::Index>(names.size()) != ts.cols()) __builtin_trap();
  } catch (const kfx::Error&) {
  } catch (const kfx::NumericalError&) {
  }
  return 0;
}
