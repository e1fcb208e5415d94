// `kfx info`: the BLAS/LAPACK kfx runs on, its kernel against the CPU, a measured DGEMM rate; and the
// kernel choice made before the library does any work (ChooseKernelBeforeRun, docs/performance.md).
#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "kfx/blas_info.hpp"
#include "kfx/error.hpp"

#ifndef KFX_VERSION
#define KFX_VERSION "unknown"
#endif

namespace kfx::cli {
namespace {

std::string Env(const char* name) {
  const char* v = std::getenv(name);
  return v == nullptr ? "" : v;
}

bool SameName(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

// Who decided the kernel in use.
std::string KernelSource() {
  if (!Env("KFX_BLAS_KERNEL_CHOSEN").empty()) return "chosen by kfx (OPENBLAS_CORETYPE, self-tested)";
  if (!Env("KFX_BLAS_KERNEL_REJECTED").empty())
    return "the library's own choice (kfx's choice " + Env("KFX_BLAS_KERNEL_REJECTED") + " failed its self-test)";
  if (!Env("OPENBLAS_CORETYPE").empty()) return "OPENBLAS_CORETYPE=" + Env("OPENBLAS_CORETYPE") + " set by the user";
  return "the library's own choice";
}

}  // namespace

void ChooseKernelBeforeRun(char** argv) {
  const std::string checking = Env("KFX_BLAS_KERNEL_CHECK");
  if (!checking.empty()) {  // the re-executed process: keep the kernel only if it is the one asked for and correct
    unsetenv("KFX_BLAS_KERNEL_CHECK");
    double err = 0;
    const BlasInfo blas = QueryBlasInfo();
    if (SameName(blas.core_name, checking) && CheckBlasKernel(&err)) {
      setenv("KFX_BLAS_KERNEL_CHOSEN", checking.c_str(), 1);
      return;
    }
    std::fprintf(stderr,
                 "kfx: note: OpenBLAS kernel %s not used (loaded %s, self-test error %.3g of its bound); "
                 "running with the library's own choice\n",
                 checking.c_str(), blas.core_name.c_str(), err);
    unsetenv("OPENBLAS_CORETYPE");
    setenv("KFX_BLAS_KERNEL_REJECTED", checking.c_str(), 1);
    execv("/proc/self/exe", argv);
    return;  // exec failed: go on with the kernel loaded
  }
  if (!Env("KFX_BLAS_KERNEL_CHOSEN").empty() || !Env("KFX_BLAS_KERNEL_REJECTED").empty()) return;
  const BlasInfo blas = QueryBlasInfo();
  const BlasKernelChoice choice =
      ChooseBlasKernel(blas.core_name, DetectCpu(), Env("OPENBLAS_CORETYPE"), Env("KFX_BLAS_KERNEL") == "library");
  if (choice.coretype.empty()) return;
  setenv("OPENBLAS_CORETYPE", choice.coretype.c_str(), 1);
  setenv("KFX_BLAS_KERNEL_CHECK", choice.coretype.c_str(), 1);
  execv("/proc/self/exe", argv);
  unsetenv("OPENBLAS_CORETYPE");  // exec failed: nothing changed
  unsetenv("KFX_BLAS_KERNEL_CHECK");
}

int RunInfo(const InfoArgs& args) {
  if (!(args.seconds > 0 && args.seconds <= 60))
    throw Error("--seconds: expected a time in (0, 60], got " + std::to_string(args.seconds));
  const BlasInfo blas = QueryBlasInfo();
  const CpuInfo cpu = DetectCpu();
  const SimdLevel kernel = KernelSimdLevel(blas.core_name);
  double self_test = 0;
  const bool ok = CheckBlasKernel(&self_test);
  const double rate = MeasureDgemmRate(400, args.seconds);
  // What a better kernel would be, ignoring who set this one: the advice for any program on this BLAS.
  const BlasKernelChoice better = ChooseBlasKernel(blas.core_name, cpu, "", false);
  std::string advice;
  if (!better.coretype.empty())
    advice = "the BLAS kernel " + blas.core_name + " (" + ToString(kernel) + ") is below this CPU (" +
             ToString(cpu.best) + "): set OPENBLAS_CORETYPE=" + better.coretype +
             " before starting programs that load this BLAS (Python, numpy, SciPy, your own); kfx's CLI does it "
             "by itself unless KFX_BLAS_KERNEL=library";
  nlohmann::ordered_json j;
  j["kfx_version"] = KFX_VERSION;
  j["cpu"] = cpu.model;
  j["cpu_vendor"] = cpu.vendor;
  j["cpu_simd"] = ToString(cpu.best);
  j["blas_library"] = blas.blas_library;
  j["lapack_library"] = blas.lapack_library;
  j["lapack_version"] = blas.lapack_version;
  j["blas_config"] = blas.config;
  j["kernel"] = blas.core_name.empty() ? "unknown" : blas.core_name;
  j["kernel_simd"] = ToString(kernel);
  j["kernel_source"] = KernelSource();
  j["openblas_coretype"] = Env("OPENBLAS_CORETYPE");
  j["threads"] = blas.threads;
  j["kernel_self_test"] = ok ? "passed" : "FAILED";
  j["kernel_self_test_error"] = self_test;
  j["dgemm_gflops"] = rate;
  j["dgemm_n"] = 400;
  j["advice"] = advice;
  if (args.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key() == "advice" && advice.empty()) continue;
      const std::string value = it->is_string() ? it->get<std::string>() : it->dump();
      std::printf("%-24s %s\n", (it.key() + ":").c_str(), value.c_str());
    }
  }
  return ok ? 0 : 1;
}

}  // namespace kfx::cli
