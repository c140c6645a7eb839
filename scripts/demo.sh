#!/usr/bin/env bash
# Installs the dependencies, builds the `softhom` program and runs the main job on its embedded default
# scenes. Results go to ./softhom-demo (or the directory given as $1).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target softhom
./build/apps/softhom demo --out "${1:-softhom-demo}"
