#!/usr/bin/env bash
# Builds the imb tests and benchmark with CUDA on a GPU machine and runs them.
# Usage: bench/imb/run_gpu.sh OUTDIR [COMMIT]   (writes imb_tests.xml, bench_imb.json, logs)
# imb_tests is linked by hand without other modules' libraries when one of them
# does not build at the moment (it needs only lbdem_imb and lbdem_core).
set -u
out=${1:-out}
commit=${2:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}
mkdir -p "$out"
b=build-gpu-imb
cmake -S . -B $b -G Ninja -DLBDEM_ENABLE_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 > "$out/configure.log" 2>&1 || { tail -30 "$out/configure.log"; exit 1; }
cmake --build $b --target lbdem_bench_imb -j"$(nproc)" > "$out/build.log" 2>&1 || { grep -E "error" "$out/build.log" | head; exit 1; }
if ! cmake --build $b --target imb_tests -j"$(nproc)" >> "$out/build.log" 2>&1; then
  echo "imb_tests: linking by hand without other modules"
  ninja -C $b tests/imb/CMakeFiles/imb_tests.dir/test_cell_slots.cpp.o tests/imb/CMakeFiles/imb_tests.dir/test_solid_fraction.cpp.o >> "$out/build.log" 2>&1
  cmd=$(ninja -C $b -t commands imb_tests | tail -1 | sed -E 's#[^ ]*liblbdem_(cases|dem|lbm|cfd|halo)\.a##g')
  (cd $b && eval "$cmd") >> "$out/build.log" 2>&1 || { tail -20 "$out/build.log"; exit 1; }
fi
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"
$b/tests/imb/imb_tests --gtest_output=xml:"$out/imb_tests.xml" 2>&1 | tail -40
$b/bench/imb/lbdem_bench_imb --out "$out/bench_imb.json" --commit "$commit" 2>&1 | tee "$out/bench_imb.md"
