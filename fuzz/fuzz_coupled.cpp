// libFuzzer target: the coupled-model reader of `kfx blockdiag` (the header, and a slice read by offset).
// The scratch directory holds per-subsystem .npy fields of n = 3 subsystems (c = 2, d = 1, r = 1) that
// inputs may reference ({"npy": "F.npy"}, "G.npy", "m0.npy"), one of 4 subsystems ("F4.npy") and a
// truncated one ("bad.npy"). A loaded slice must have the requested subsystems and the header's sizes.
#include <algorithm>
#include <vector>

#include "fuzz_common.hpp"
#include "kfx/block_diagonal.hpp"
#include "kfx/coupled_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace {
void Setup() {
  static const bool done = [] {
    const std::string dir = kfx::fuzz::ScratchDir().string();
    const std::vector<double> eye3 = {0.9, 0.0, 0.0, 0.9, 0.9, 0.0, 0.0, 0.9, 0.9, 0.0, 0.0, 0.9, 0.9, 0, 0, 0.9};
    kfx::WriteNpy(dir + "/F.npy", {3, 2, 2}, eye3.data());
    kfx::WriteNpy(dir + "/F4.npy", {4, 2, 2}, eye3.data());
    kfx::WriteNpy(dir + "/G.npy", {3, 2, 1}, eye3.data());
    kfx::WriteNpy(dir + "/m0.npy", {3, 2}, eye3.data());
    const std::uint8_t bad[] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, 0x40, 0};
    kfx::fuzz::WriteInput("bad.npy", bad, sizeof bad);
    return true;
  }();
  (void)done;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Setup();
  const std::string path = kfx::fuzz::WriteInput("coupled.json", data, size);
  try {
    const kfx::CoupledModelHeader h = kfx::ReadCoupledModelHeader(path);
    if (h.n < 1 || h.c < 1 || h.d < 1 || h.r < 0 || h.U.rows() != h.r || h.U.cols() != h.r) __builtin_trap();
    // Inline fields are repeated for every subsystem of the slice: keep the slice and the blocks small.
    if (h.c > 64 || h.d > 64 || h.r > 64) return 0;
    const Eigen::Index first = h.n / 2, count = std::min<Eigen::Index>(h.n - first, 3);
    const kfx::CoupledSystem s = kfx::LoadCoupledModelSlice(path, first, count);
    if (s.n() != count || s.c() != h.c || s.d() != h.d || s.r() != h.r) __builtin_trap();
  } catch (const kfx::Error&) {
  } catch (const kfx::NumericalError&) {
  }
  return 0;
}
