// AtomicOutputFile (include/kfx/io.hpp): every file kfx writes goes to a temporary name beside the target
// and is renamed into place on success (docs/formats.md).
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <string>

#include "io/io_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace kfx {

namespace {

using detail::ErrnoDetail;

[[noreturn]] void Fail(const std::string& path, const std::string& what) { throw Error(path + ": " + what); }

}  // namespace

AtomicOutputFile::AtomicOutputFile(std::string path) : path_(std::move(path)) {
  static std::atomic<unsigned long> counter{0};
  temp_ = path_ + ".tmp-" + std::to_string(static_cast<long>(::getpid())) + "-" + std::to_string(counter++);
  errno = 0;
  out_.open(temp_, std::ios::binary | std::ios::trunc);
  if (!out_) Fail(path_, "cannot open file for writing" + ErrnoDetail());
}

AtomicOutputFile::~AtomicOutputFile() {
  if (committed_) return;
  if (out_.is_open()) out_.close();
  std::remove(temp_.c_str());
}

void AtomicOutputFile::Commit() {
  errno = 0;
  out_.close();
  if (!out_) {
    const std::string detail = ErrnoDetail();
    std::remove(temp_.c_str());
    committed_ = true;
    Fail(path_, "cannot write file" + detail);
  }
  errno = 0;
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
    const std::string detail = ErrnoDetail();
    std::remove(temp_.c_str());
    committed_ = true;
    Fail(path_, "cannot rename the written file into place" + detail);
  }
  committed_ = true;
}

}  // namespace kfx
