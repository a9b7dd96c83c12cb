#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds hrad (Release)
# into ./build. Incremental: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
JOBS="${HRAD_JOBS:-$(nproc)}"
# ccache, where installed, shares compiled objects between clones and rebuilds.
LAUNCHER=()
if command -v ccache >/dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
if [ ! -f build/CMakeCache.txt ]; then
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${LAUNCHER[@]}" >/dev/null
fi
cmake --build build -j "$JOBS"
