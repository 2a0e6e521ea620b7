#!/usr/bin/env bash
# Builds lbdem and runs the default case: a sphere settling through a viscous
# oil in a periodic box, in physical units (cases/settling_sphere_periodic.yaml;
# about a minute on 2 CPU cores, seconds on a GPU). The run prints its terminal
# slip against the Stokes drag of a periodic array of spheres (Sangani &
# Acrivos 1982) and leaves runs/settling_sphere_periodic/ with fields.xdmf and
# particles.xdmf (ParaView), series.csv and summary.json; with matplotlib and
# h5py for python3 also snapshots.png and series.png (scripts/plot_suspension.py).
# Extra arguments go to `lbdem run` (e.g. --backend cpu, --steps N).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bash "$here/scripts/setup.sh"
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$here/build" -j"$(nproc)" --target lbdem
cd "$here"
./build/cases/lbdem run cases/settling_sphere_periodic.yaml --overwrite "$@"
out=runs/settling_sphere_periodic
for py in python3 /usr/bin/python3; do
  if "$py" -c 'import matplotlib, h5py, numpy' 2>/dev/null; then
    "$py" scripts/plot_suspension.py "$out"
    exit 0
  fi
done
echo "pictures: install python3-matplotlib and python3-h5py, then: python3 scripts/plot_suspension.py $out"
