#pragma once
// Private helpers shared by the file readers and writers of src/io/ (not installed).
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace kfx::detail {

/// " (No such file or directory)" for the current errno, or "" when errno is 0: the tail of a
/// "cannot open/read/write" message.
inline std::string ErrnoDetail() {
  const int e = errno;
  return e != 0 ? std::string(" (") + std::strerror(e) + ")" : std::string();
}

/// The shape of an N-dimensional array as NumPy prints it, a Python tuple: "(2, 3)", "(4,)", "()".
/// (A matrix shape in a message is "2x3": kfx::ShapeString.)
inline std::string NpyShapeText(const std::vector<std::int64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) s += ", ";
    s += std::to_string(shape[i]);
  }
  if (shape.size() == 1) s += ",";
  return s + ")";
}

}  // namespace kfx::detail
