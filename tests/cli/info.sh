#!/usr/bin/env bash
# `kfx info`: every field present, a positive finite DGEMM rate, the kernel self-test passed, and the
# kernel choice made before the library loads (docs/performance.md): kept when the user sets
# OPENBLAS_CORETYPE or KFX_BLAS_KERNEL=library, taken when the library's own kernel is below the CPU,
# and dropped when the asked-for kernel does not load. Usage: info.sh KFX SOURCE_DIR
set -u
kfx=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
unset OPENBLAS_CORETYPE KFX_BLAS_KERNEL KFX_BLAS_KERNEL_CHECK KFX_BLAS_KERNEL_CHOSEN KFX_BLAS_KERNEL_REJECTED

info_json() {  # info_json FILE [ENV=VALUE...]: kfx info --json under the given environment
  local file=$1
  shift
  env "$@" "$kfx" info --json --seconds 0.05 > "$file" 2> "$tmp/err"
  local rc=$?
  if [[ $rc -ne 0 ]]; then echo "FAIL: kfx info ($*) exit code $rc: $(cat "$tmp/err")"; fail=1; fi
}
field() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }
check() {  # check DESCRIPTION PYTHON_CONDITION FILE
  if python3 -c "import json,math,sys; j=json.load(open(sys.argv[1])); sys.exit(0 if ($2) else 1)" "$3"; then
    echo "ok: $1"
  else
    echo "FAIL: $1: $(cat "$3")"; fail=1
  fi
}

"$kfx" info --seconds 0.05 > "$tmp/text" || { echo "FAIL: kfx info"; fail=1; }
for key in kfx_version cpu_simd blas_library lapack_library lapack_version kernel kernel_source threads \
           kernel_self_test dgemm_gflops; do
  grep -q "^$key:" "$tmp/text" || { echo "FAIL: no '$key:' line in kfx info"; cat "$tmp/text"; fail=1; }
done

info_json "$tmp/default.json"
check "fields, rate and self-test" "all(k in j for k in ['blas_library','lapack_library','lapack_version','kernel',
  'threads','cpu_simd','kernel_simd','advice']) and j['blas_library'] != '' and math.isfinite(j['dgemm_gflops'])
  and j['dgemm_gflops'] > 0 and j['kernel_self_test'] == 'passed' and j['threads'] >= 1" "$tmp/default.json"

info_json "$tmp/library.json" KFX_BLAS_KERNEL=library
check "KFX_BLAS_KERNEL=library keeps the library's kernel" "j['kernel_source'] == \"the library's own choice\"" \
  "$tmp/library.json"
if [[ -n "$(field "$tmp/library.json" advice)" ]]; then
  # The library's kernel is below this CPU: by default kfx runs on the advised kernel, and advises nothing.
  want=$(python3 -c "import sys,re; print(re.search(r'OPENBLAS_CORETYPE=(\w+)', sys.argv[1]).group(1))" \
         "$(field "$tmp/library.json" advice)")
  check "the library's kernel is below the CPU: kfx loads $want" \
    "j['kernel'].lower() == '$want'.lower() and j['kernel_source'].startswith('chosen by kfx') and j['advice'] == ''" \
    "$tmp/default.json"
else
  check "the library's kernel fits the CPU: kept" "j['kernel_source'] == \"the library's own choice\"" \
    "$tmp/default.json"
fi

info_json "$tmp/user.json" OPENBLAS_CORETYPE=Haswell
check "OPENBLAS_CORETYPE set by the user is kept" \
  "j['kernel'] == 'Haswell' and 'set by the user' in j['kernel_source']" "$tmp/user.json"

# The check in the re-executed process accepts a kernel that loaded as asked and passes the self-test.
info_json "$tmp/accepted.json" OPENBLAS_CORETYPE=Haswell KFX_BLAS_KERNEL_CHECK=Haswell
check "a kernel that passes the check is kept" \
  "j['kernel'] == 'Haswell' and j['kernel_source'].startswith('chosen by kfx')" "$tmp/accepted.json"

# A kernel that does not load as asked (the check in the re-executed process): back to the library's own.
info_json "$tmp/rejected.json" OPENBLAS_CORETYPE=Prescott KFX_BLAS_KERNEL_CHECK=NoSuchKernel
check "a kernel that fails the check is dropped" \
  "'failed its self-test' in j['kernel_source'] and j['openblas_coretype'] == ''" "$tmp/rejected.json"
grep -q "kfx: note: OpenBLAS kernel NoSuchKernel not used" "$tmp/err" || { echo "FAIL: no note on stderr"; fail=1; }

exit $fail
