#!/usr/bin/python3
"""The BLAS kernel a benchmark runs with, chosen before any BLAS is loaded (docs/performance.md).

Asks the kfx_peers driver (`kfx_peers blas`) which OpenBLAS kernel the library picked and which one the
CPU supports (kfx::ChooseBlasKernel). When the picked one is below the CPU and neither OPENBLAS_CORETYPE
nor KFX_BLAS_KERNEL=library is set, runs the driver again with OPENBLAS_CORETYPE set to the better kernel
and keeps it only if that kernel loaded and passed kfx::CheckBlasKernel (DGEMM and DSYMV against loops):
the same rule as the kfx CLI. Every benchmark table then names the BLAS, the kernel and who chose it.

As a module: choose(driver) sets os.environ (call it before importing numpy) and returns the info dict;
line(info, gflops) is the sentence for the tables. As a script (bench/run.sh):
  blas_kernel.py DRIVER          prints `export OPENBLAS_CORETYPE=...` (or nothing) on stdout
  blas_kernel.py DRIVER GFLOPS   prints the table sentence with the given DGEMM rate
"""
import json
import os
import subprocess
import sys


def query(driver, env=None):
    r = subprocess.run([driver, "blas"], capture_output=True, text=True, env=env, check=True)
    return json.loads(r.stdout)


def choose(driver):
    info = query(driver)
    chosen = os.environ.get("KFX_BLAS_KERNEL_CHOSEN")
    if chosen and chosen == os.environ.get("OPENBLAS_CORETYPE"):  # chosen (and checked) by an earlier choose()
        info["source"] = f"chosen as for the kfx CLI: OPENBLAS_CORETYPE={chosen}, self-tested"
        return info
    if os.environ.get("OPENBLAS_CORETYPE"):
        info["source"] = f"OPENBLAS_CORETYPE={os.environ['OPENBLAS_CORETYPE']} set by the user"
        return info
    want = info.get("better_kernel", "")
    if not want or os.environ.get("KFX_BLAS_KERNEL") == "library":
        info["source"] = "the library's own choice"
        return info
    env = dict(os.environ, OPENBLAS_CORETYPE=want)
    checked = query(driver, env)
    if checked["kernel"].lower() == want.lower() and checked["kernel_self_test"]:
        os.environ["OPENBLAS_CORETYPE"] = want
        os.environ["KFX_BLAS_KERNEL_CHOSEN"] = want
        checked["source"] = (f"chosen as for the kfx CLI: OPENBLAS_CORETYPE={want}, self-tested; "
                             f"the library alone picks {info['kernel']}")
        return checked
    info["source"] = f"the library's own choice ({want} failed the self-test)"
    return info


def line(info, gflops):
    return (f"BLAS: {info['blas_library']} ({info['blas_config'] or 'not OpenBLAS'}), LAPACK "
            f"{info['lapack_version']}; kernel **{info['kernel'] or 'unknown'}** ({info['kernel_simd']}; CPU "
            f"{info['cpu_simd']}; {info['source']}); measured single-thread DGEMM **{gflops:.1f} GFLOP/s**.")


if __name__ == "__main__":
    if len(sys.argv) == 2:
        i = choose(sys.argv[1])
        if os.environ.get("KFX_BLAS_KERNEL_CHOSEN"):
            print(f"export OPENBLAS_CORETYPE={os.environ['OPENBLAS_CORETYPE']} "
                  f"KFX_BLAS_KERNEL_CHOSEN={os.environ['KFX_BLAS_KERNEL_CHOSEN']}")
        print(f"kernel: {i['kernel']} ({i['source']})", file=sys.stderr)
    elif len(sys.argv) == 3:
        i = choose(sys.argv[1])
        print(line(i, float(sys.argv[2])))
    else:
        sys.exit("usage: blas_kernel.py DRIVER [GFLOPS]")
