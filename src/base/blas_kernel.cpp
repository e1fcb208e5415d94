// The CPU's vector level and the choice of an OpenBLAS kernel for it (kfx/blas_info.hpp; the rule is
// explained in docs/performance.md).
#include <algorithm>
#include <cctype>
#include <cstring>
#include <string>

#include "kfx/blas_info.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#define KFX_HAVE_CPUID 1
#endif

namespace kfx {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Trim(std::string s) {
  const auto b = s.find_first_not_of(' ');
  const auto e = s.find_last_not_of(' ');
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

}  // namespace

const char* ToString(SimdLevel level) {
  switch (level) {
    case SimdLevel::kSse:
      return "SSE";
    case SimdLevel::kAvx:
      return "AVX";
    case SimdLevel::kAvx2:
      return "AVX2";
    case SimdLevel::kAvx512:
      return "AVX-512";
    case SimdLevel::kUnknown:
      break;
  }
  return "unknown";
}

CpuInfo DetectCpu() {
  CpuInfo cpu;
#ifdef KFX_HAVE_CPUID
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (!__get_cpuid(0, &a, &b, &c, &d)) return cpu;
  const unsigned max_leaf = a;
  char vendor[13] = {};
  std::memcpy(vendor, &b, 4), std::memcpy(vendor + 4, &d, 4), std::memcpy(vendor + 8, &c, 4);
  cpu.vendor = vendor;
  unsigned brand[12] = {};
  if (__get_cpuid(0x80000000u, &a, &b, &c, &d) && a >= 0x80000004u) {
    for (unsigned i = 0; i < 3; ++i)
      __get_cpuid(0x80000002u + i, &brand[4 * i], &brand[4 * i + 1], &brand[4 * i + 2], &brand[4 * i + 3]);
    char text[49] = {};
    std::memcpy(text, brand, 48);
    cpu.model = Trim(text);
  }
  __get_cpuid(1, &a, &b, &c, &d);
  cpu.best = SimdLevel::kSse;  // every x86-64 CPU
  const bool osxsave = (c >> 27) & 1u, avx = (c >> 28) & 1u, fma = (c >> 12) & 1u;
  if (!osxsave || !avx) return cpu;
  unsigned xcr0_lo = 0, xcr0_hi = 0;
  __asm__ volatile("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
  if ((xcr0_lo & 0x6u) != 0x6u) return cpu;  // the OS saves XMM and YMM state
  cpu.best = SimdLevel::kAvx;
  if (max_leaf < 7) return cpu;
  __cpuid_count(7, 0, a, b, c, d);
  const bool avx2 = (b >> 5) & 1u;
  const bool avx512 = ((b >> 16) & 1u) && ((b >> 17) & 1u) && ((b >> 30) & 1u) && ((b >> 31) & 1u);  // F DQ BW VL
  if (avx2 && fma) cpu.best = SimdLevel::kAvx2;
  if (cpu.best == SimdLevel::kAvx2 && avx512 && (xcr0_lo & 0xe0u) == 0xe0u) {  // opmask, ZMM state
    cpu.best = SimdLevel::kAvx512;
  }
#endif
  return cpu;
}

SimdLevel KernelSimdLevel(const std::string& core_name) {
  const std::string k = Lower(core_name);
  for (const char* name : {"skylakex", "cooperlake", "sapphirerapids"})
    if (k == name) return SimdLevel::kAvx512;
  for (const char* name : {"haswell", "zen"})
    if (k == name) return SimdLevel::kAvx2;
  for (const char* name : {"sandybridge", "bulldozer", "piledriver", "steamroller", "excavator"})
    if (k == name) return SimdLevel::kAvx;
  for (const char* name : {"prescott", "core2", "penryn", "dunnington", "nehalem", "atom", "katmai", "coppermine",
                           "northwood", "banias", "opteron", "opteron_sse3", "barcelona", "bobcat", "nano"})
    if (k == name) return SimdLevel::kSse;
  return SimdLevel::kUnknown;
}

BlasKernelChoice ChooseBlasKernel(const std::string& core_name, const CpuInfo& cpu, const std::string& user_coretype,
                                  bool disabled) {
  if (core_name.empty()) return {"", "the BLAS is not OpenBLAS: its own kernel choice is kept"};
  if (!user_coretype.empty()) return {"", "OPENBLAS_CORETYPE=" + user_coretype + " is set: kept"};
  if (disabled) return {"", "KFX_BLAS_KERNEL=library: the library's own choice is kept"};
  const SimdLevel kernel = KernelSimdLevel(core_name);
  if (kernel == SimdLevel::kUnknown || cpu.best == SimdLevel::kUnknown)
    return {"", "kernel " + core_name + " or the CPU not classified: the library's choice is kept"};
  if (kernel >= cpu.best)
    return {"", std::string("kernel ") + core_name + " matches the CPU's best level (" + ToString(cpu.best) + ")"};
  std::string want;
  if (cpu.best == SimdLevel::kAvx512)
    want = "SkylakeX";
  else if (cpu.best == SimdLevel::kAvx2)
    want = cpu.vendor == "AuthenticAMD" ? "Zen" : "Haswell";
  else
    want = "Sandybridge";
  return {want, std::string("kernel ") + core_name + " (" + ToString(kernel) + ") is below the CPU's " +
                    ToString(cpu.best) + ": " + want + " kernels of the same library"};
}

}  // namespace kfx
