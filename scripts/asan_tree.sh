#!/usr/bin/env bash
# Sourced by scripts/sanitize.sh and scripts/fuzz.sh: configures and builds
# targets of build-asan/, the sanitizer tree. clang++ with
# -fsanitize=address,undefined (any finding aborts: -fno-sanitize-recover) and
# libFuzzer's coverage instrumentation (fuzzer-no-link), so that one tree holds
# both the sanitized unit tests and the fuzz harnesses (tests/fuzz).
# Usage: asan_build TARGET...
ASAN_DIR="${HRAD_ASAN_DIR:-build-asan}"
asan_build() {
  bash scripts/setup.sh
  local jobs="${HRAD_JOBS:-$(nproc)}"
  local launcher=()
  if command -v ccache >/dev/null 2>&1; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
  if [ ! -f "$ASAN_DIR/CMakeCache.txt" ]; then
    cmake -S . -B "$ASAN_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
      -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=undefined -fno-omit-frame-pointer" \
      -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
      -DHRAD_FUZZ=ON -DHRAD_BUILD_BENCH=OFF "${launcher[@]}" >/dev/null
  fi
  cmake --build "$ASAN_DIR" -j "$jobs" --target "$@"
}
# Sanitizer settings for every run from this tree: stop at the first finding,
# with a stack; the suppressions name each false positive and why.
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$(pwd)/scripts/lsan.supp:print_suppressions=0"
