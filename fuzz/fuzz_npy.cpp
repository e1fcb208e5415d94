// libFuzzer target: the .npy reader (ReadNpy, ReadNpyMatrix, ReadTimeSeries on .npy).
#include <cmath>

#include "fuzz_common.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = kfx::fuzz::WriteInput("input.npy", data, size);
  try {
    const kfx::NpyArray a = kfx::ReadNpy(path);
    std::size_t count = 1;
    for (std::int64_t d : a.shape) count *= static_cast<std::size_t>(d);
    if (count != a.data.size()) __builtin_trap();  // the documented invariant: size = product of shape
    const kfx::TimeSeries ts = kfx::ReadTimeSeries(path);
    if (ts.size() != static_cast<Eigen::Index>(a.data.size())) __builtin_trap();
  } catch (const kfx::Error&) {
  } catch (const kfx::NumericalError&) {
  }
  return 0;
}
