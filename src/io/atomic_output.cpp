// AtomicOutputFile (include/kfx/io.hpp): every file kfx writes goes to a temporary name beside the target
// and is renamed into place on success (docs/formats.md); OutputDirectory: a directory of outputs is one
// complete run (its completion marker, written last) or visibly incomplete (no marker).
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <filesystem>
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

OutputDirectory::OutputDirectory(std::string dir, std::string marker, bool owner, const std::string& option)
    : dir_(std::move(dir)), marker_(std::move(marker)), owner_(owner) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    throw Error(option + ": cannot create directory '" + dir_ + "'" + (ec ? ": " + ec.message() : std::string()));
  }
  if (!owner_) return;
  // The old run's marker goes first: from here until Commit the directory is visibly incomplete.
  const fs::path marker_path = fs::path(dir_) / marker_;
  if (fs::is_directory(marker_path, ec))
    Fail(marker_path.string(), "expected a file (the completion marker), got a directory");
  fs::remove(marker_path, ec);
  if (ec) Fail(marker_path.string(), "cannot remove the completion marker of the previous run: " + ec.message());
}

std::string OutputDirectory::Path(const std::string& name) const {
  return (std::filesystem::path(dir_) / name).string();
}

void OutputDirectory::Commit(const std::string& marker_text) {
  if (!owner_) throw Error(Path(marker_) + ": only the directory's owner writes the completion marker");
  AtomicOutputFile file(Path(marker_));
  file.stream() << marker_text << "\n";
  file.Commit();
}

}  // namespace kfx
