#!/usr/bin/env bash
# scripts/fuzz.sh TARGET SECONDS: builds the libFuzzer harness
# hrad_fuzz_TARGET in build-asan/ (scripts/asan_tree.sh) and runs it for
# SECONDS. TARGET: a harness of tests/fuzz/CMakeLists.txt, or "all": every
# harness, HRAD_FUZZ_PARALLEL (2) at a time, so that the wall time is about
# ceil(10 / 2) x SECONDS; the summaries print in order and any finding fails. The corpus grows in build-asan/fuzz/corpus/TARGET,
# seeded from tests/fuzz/seeds/TARGET (and experiments/studies for study);
# findings (crash-*, timeout-*, leak-*, oom-*) go to build-asan/fuzz/findings/
# and fail the script. One input may take 10 s and 2 GiB at most.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -ne 2 ]; then echo "usage: scripts/fuzz.sh TARGET SECONDS" >&2; exit 2; fi
TARGET="$1"
SECONDS_PER="$2"
ALL=(obj mgf ply gltf glb mitsuba mitsuba_include serialized study hrsol)
source scripts/asan_tree.sh
if [ "$TARGET" = all ]; then
  # Build every harness first (one cmake call), then run them in batches.
  asan_build "${ALL[@]/#/hrad_fuzz_}" >/dev/null
  par="${HRAD_FUZZ_PARALLEL:-2}"
  out="$(mktemp -d)"
  failed=0
  for ((i = 0; i < ${#ALL[@]}; i += par)); do
    pids=()
    for t in "${ALL[@]:i:par}"; do
      HRAD_FUZZ_BUILT=1 bash "$0" "$t" "$SECONDS_PER" >"$out/$t" 2>&1 &
      pids+=($!)
    done
    for p in "${pids[@]}"; do wait "$p" || failed=1; done
    for t in "${ALL[@]:i:par}"; do cat "$out/$t"; done
  done
  rm -rf "$out"
  exit $failed
fi
if [ -z "${HRAD_FUZZ_BUILT:-}" ]; then asan_build "hrad_fuzz_$TARGET" >/dev/null; fi
corpus="$ASAN_DIR/fuzz/corpus/$TARGET"
findings="$ASAN_DIR/fuzz/findings"
mkdir -p "$corpus" "$findings"
seeds=(tests/fuzz/seeds/"$TARGET")
if [ "$TARGET" = study ]; then seeds+=(experiments/studies); fi
log="$ASAN_DIR/fuzz/$TARGET.log"
# Run a copy, so that rebuilding the tree during a long run leaves it alone.
mkdir -p "$ASAN_DIR/fuzz/bin"
bin="$ASAN_DIR/fuzz/bin/hrad_fuzz_$TARGET.$$"
cp "$ASAN_DIR/tests/fuzz/hrad_fuzz_$TARGET" "$bin"
# libFuzzer ends with _Exit, past the harness's own cleanup: its temporary
# files go to a folder removed here.
export TMPDIR="$(mktemp -d)"
trap 'rm -f "$bin"; rm -rf "$TMPDIR"' EXIT
set +e
"$bin" "$corpus" "${seeds[@]}" \
  -max_total_time="$SECONDS_PER" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
  -artifact_prefix="$findings/$TARGET-" -print_final_stats=1 >"$log" 2>&1
rc=$?
set -e
runs=$(grep -m1 'stat::number_of_executed_units' "$log" | awk '{print $2}')
cov=$(grep -E '^#[0-9]+' "$log" | tail -1 | grep -oE 'cov: [0-9]+' || true)
echo "fuzz $TARGET: ${runs:-?} inputs in ${SECONDS_PER} s, ${cov:-cov: ?}, corpus $(ls "$corpus" | wc -l) files, exit $rc (log: $log)"
if [ $rc -ne 0 ]; then
  grep -E 'ERROR|SUMMARY|Test unit written|unexpected exception' "$log" | head -20 >&2
  exit 1
fi
