// libFuzzer target: the model-file reader (JSON; matrices inline or in .npy files beside it). The
// scratch directory holds a valid and a truncated .npy file that inputs may reference as
// {"npy": "a.npy"} / {"npy": "bad.npy"}.
#include <vector>

#include "fuzz_common.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace {
void Setup() {
  static const bool done = [] {
    const std::string dir = kfx::fuzz::ScratchDir().string();
    const double v[4] = {1.0, 0.0, 0.0, 1.0};
    kfx::WriteNpy(dir + "/a.npy", {2, 2}, v);
    kfx::WriteNpy(dir + "/v.npy", {2}, v);
    kfx::WriteNpy(dir + "/t.npy", {2, 2, 1}, v);
    const std::uint8_t bad[] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, 0x40, 0};
    kfx::fuzz::WriteInput("bad.npy", bad, sizeof bad);
    return true;
  }();
  (void)done;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Setup();
  const std::string path = kfx::fuzz::WriteInput("model.json", data, size);
  try {
    const kfx::Model m = kfx::LoadModel(path);
    if (m.state_dim() <= 0 || m.meas_dim() <= 0) __builtin_trap();
    (void)m.step(1);
  } catch (const kfx::Error&) {
  } catch (const kfx::NumericalError&) {
  }
  return 0;
}
