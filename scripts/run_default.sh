#!/usr/bin/env bash
# Builds lbdem and runs the default case (Poiseuille channel); results in runs/channel.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$here/build" -j"$(nproc)" --target lbdem
cd "$here"
./build/cases/lbdem run cases/channel.yaml --overwrite "$@"
