#!/usr/bin/env bash
# Set up, build, and run the main job: hierarchical radiosity on the built-in
# Cornell box. Writes out/cornell/{image.png,image.exr,solution.ply,summary.json}.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
./build/apps/hrad solve cornell -o out/cornell "$@"
echo "image: $(pwd)/out/cornell/image.png (linear HDR: out/cornell/image.exr)"
