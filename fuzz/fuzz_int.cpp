// libFuzzer target: the one rule of every integer option of the CLI (kfx::cli::ParseIntegerOption,
// apps/kfx/cli_args.cpp) against an independent reading: the text is accepted exactly when it is an
// optional '-' and 1..20 decimal digits whose value (in 128-bit arithmetic) lies in [lo, hi], and the
// value returned is that value. The first byte picks the range (those of --steps, --seed, --granule,
// and a signed one).
#include <cstdint>
#include <string>

#include "cli_args.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  struct Range {
    long long lo;
    unsigned long long hi;
  };
  static const Range ranges[] = {
      {0, 2000000000ULL}, {0, 18446744073709551615ULL}, {1, 1000000000ULL}, {-5, 5}, {-9223372036854775807LL - 1, 7}};
  const Range r = ranges[data[0] % 5];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  unsigned long long got = 0;
  const bool ok = kfx::cli::ParseIntegerOption(text, r.lo, r.hi, &got);
  // The reference reading.
  const bool negative = !text.empty() && text[0] == '-';
  const std::string digits = negative ? text.substr(1) : text;
  bool valid = !digits.empty() && digits.size() <= 20;
  __int128 value = 0;
  for (const char c : digits) {
    if (c < '0' || c > '9') valid = false;
    if (valid) value = value * 10 + (c - '0');
  }
  if (negative) value = -value;
  valid = valid && value >= r.lo && value <= static_cast<__int128>(r.hi);
  if (ok != valid) __builtin_trap();
  if (ok && (value < 0 ? static_cast<long long>(got) != static_cast<long long>(value)
                       : got != static_cast<unsigned long long>(value))) {
    __builtin_trap();
  }
  return 0;
}
