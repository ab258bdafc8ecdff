#!/usr/bin/env bash
# The lattice kernels are compiled once per instruction set (src/backend/cpu/kernels_<set>.cpp). A
# function compiled for AVX-512 that the linker could take for a call from elsewhere (an inline or
# template function shared by name across files) would run AVX-512 instructions on a processor without
# them. So every function an object kernels_<set>.cpp.o defines must be the set's own: in namespace
# mca::cpu::<set>, or its table function mca::cpu::kernels_<set>(). (Data, such as constant tables, is
# the same bytes whichever file the linker keeps.)
# Usage: check_kernel_symbols.sh kernels_scalar.cpp.o kernels_sse2.cpp.o ...
set -euo pipefail
status=0
checked=0
for obj in "$@"; do
  base=$(basename "$obj")
  [[ "$base" =~ ^kernels_([a-z0-9]+)\.cpp\.o$ ]] || { echo "not a kernel object: $obj" >&2; exit 2; }
  set_name=${BASH_REMATCH[1]}
  # Global code symbols (local ones, t, cannot stand in for another file's): T (text), W/w (weak), i (indirect).
  bad=$(nm -C --defined-only "$obj" | awk '$2 ~ /^[TWwi]$/ { $1 = ""; $2 = ""; sub(/^  /, ""); print }' |
        grep -v -e "^mca::cpu::${set_name}::" -e "^mca::cpu::kernels_${set_name}()\$" || true)
  if [[ -n "$bad" ]]; then
    echo "$base defines functions outside mca::cpu::${set_name}:" >&2
    echo "$bad" >&2
    status=1
  fi
  checked=$((checked + 1))
done
[[ $checked -ge 4 ]] || { echo "expected the four kernel objects, got $checked" >&2; exit 2; }
[[ $status -eq 0 ]] && echo "checked $checked kernel objects: every function is its set's own"
exit $status
