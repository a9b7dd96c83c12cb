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

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "setup: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
