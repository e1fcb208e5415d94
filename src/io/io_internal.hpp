#pragma once
// Private helpers shared by the file readers and writers of src/io/ (not installed).
#include <sys/stat.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "kfx/error.hpp"

namespace kfx::detail {

/// Every reader calls this before it opens `path`: a FIFO with no writer would block the open forever,
/// a directory or device is not a file of kfx. @throws kfx::Error "<path>: is a FIFO (named pipe), not a
/// regular file, expected <expected>" (likewise a directory, device or socket). A path that does not exist
/// passes (the open names it).
inline void RequireRegularFile(const std::string& path, const std::string& expected) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || S_ISREG(st.st_mode)) return;
  const char* kind = S_ISDIR(st.st_mode)    ? "a directory"
                     : S_ISFIFO(st.st_mode) ? "a FIFO (named pipe), not a regular file"
                     : S_ISSOCK(st.st_mode) ? "a socket, not a regular file"
                                            : "a device, not a regular file";
  throw Error(path + ": is " + kind + ", expected " + expected);
}

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
