// libFuzzer target: the CSV time-series reader, every dialect (line ends \n, \r\n, lone \r; headers or
// none; blank lines; other separators). A series that reads has at least one row and one column, the
// header (if any) one name per column, and it survives a write and a read unchanged, bit for bit
// (NaN as NaN): the reader's rules and the writer's agree.
#include <cmath>
#include <cstring>

#include "fuzz_common.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = kfx::fuzz::WriteInput("input.csv", data, size);
  try {
    std::vector<std::string> names;
    const kfx::TimeSeries ts = kfx::ReadTimeSeries(path, &names);
    if (!names.empty() && static_cast<Eigen::Index>(names.size()) != ts.cols()) __builtin_trap();
    if (ts.rows() < 1 || ts.cols() < 1) __builtin_trap();
    const std::string copy = (kfx::fuzz::ScratchDir() / "copy.csv").string();
    kfx::WriteTimeSeries(copy, ts);
    const kfx::TimeSeries back = kfx::ReadTimeSeries(copy);
    if (back.rows() != ts.rows() || back.cols() != ts.cols()) __builtin_trap();
    for (Eigen::Index i = 0; i < ts.size(); ++i) {
      const double a = ts.data()[i], b = back.data()[i];
      if (!(std::isnan(a) && std::isnan(b)) && std::memcmp(&a, &b, sizeof a) != 0) __builtin_trap();
    }
  } catch (const kfx::Error&) {
  } catch (const kfx::NumericalError&) {
  }
  return 0;
}
