#!/usr/bin/env bash
# Builds the sanitizer tree (build-asan: clang, AddressSanitizer +
# UndefinedBehaviorSanitizer) and runs the fast unit tests under it (ctest
# label "fast": core, scene, oracles, experiments, the hrad command line).
# Any sanitizer finding aborts the test and fails this script.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/asan_tree.sh
asan_build hrad hrad_core_test hrad_sampling_test hrad_scene_test hrad_oracles_test hrad_experiments_test hrad_cli_test
ctest --test-dir "$ASAN_DIR" -L fast --output-on-failure -j "${HRAD_JOBS:-$(nproc)}"
