#!/usr/bin/env bash
# Installs the Debian 12 packages hrad needs, only when some are missing.
# Idempotent and non-interactive; a no-op (well under a second) when all are present.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libembree-dev libglm-dev libopenexr-dev libtbb-dev libeigen3-dev
  libtomlplusplus-dev libcli11-dev nlohmann-json3-dev libfmt-dev libspdlog-dev
  libtinyobjloader-dev libsqlite3-dev sqlite3 libpng-dev zlib1g-dev libpugixml-dev
  libtinygltf-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3 python3-dev python3-matplotlib python3-numpy python3-pandas python3-pytest
  pybind11-dev python3-pybind11
  clang libclang-rt-14-dev
  slurm-wlm munge
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# npm (Debian's, with nodejs) for the glTF validator below, unless the
# machine already has an npm of its own.
if ! command -v npm >/dev/null 2>&1; then missing+=(npm); fi

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# The Khronos glTF validator (npm `gltf-validator`), with which the tests check
# every .glb they write (tests/gltf_validate.h; they skip the check without
# it). Installed globally with npm.
have_validator() {
  for d in /usr/lib/node_modules /usr/local/lib/node_modules; do
    [ -f "$d/gltf-validator/package.json" ] && return 0
  done
  [ -f "$(npm root -g 2>/dev/null)/gltf-validator/package.json" ]
}
if command -v npm >/dev/null 2>&1; then
  if ! have_validator; then
    echo "setup: npm install -g gltf-validator" >&2
    NPM_SUDO=""
    if [ "$(id -u)" -ne 0 ] && [ ! -w "$(npm root -g)" ]; then NPM_SUDO="sudo"; fi
    $NPM_SUDO npm install -g --no-fund --no-audit gltf-validator >/dev/null
  fi
else
  echo "setup: npm not found; glTF outputs will not be validated" >&2
fi

