#!/usr/bin/env bash
# Builds lbdem and runs the default case: a sphere settling through a viscous
# oil in a periodic box, in physical units (cases/settling_sphere_periodic.yaml;
# about a minute on 2 CPU cores, seconds on a GPU). The run prints its terminal
# slip against the Stokes drag of a periodic array of spheres (Sangani &
# Acrivos 1982) and leaves runs/settling_sphere_periodic/ with fields.xdmf and
# particles.xdmf (ParaView), series.csv, summary.json, snapshots.png and
# series.png (scripts/plot_suspension.py, with the python3-matplotlib, -h5py
# and -numpy that scripts/setup.sh installs).
# Extra arguments go to `lbdem run` (e.g. --backend cpu, --steps N).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$here/build" -j"$(nproc)" --target lbdem
cd "$here"
./build/cases/lbdem run cases/settling_sphere_periodic.yaml --overwrite "$@"
out=runs/settling_sphere_periodic
source scripts/lib.sh
py="$(plot_python)"
if [ -n "$py" ]; then
  "$py" scripts/plot_suspension.py "$out"
else
  echo "pictures: no python3 with matplotlib, h5py and numpy (scripts/setup.sh could not install"
  echo "python3-matplotlib python3-h5py python3-numpy); with them: python3 scripts/plot_suspension.py $out"
fi
