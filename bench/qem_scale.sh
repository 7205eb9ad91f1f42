#!/usr/bin/env bash
# QEM time and memory against input size, ours (1 and 2 threads) and meshoptimizer,
# each run a process of its own (crates/meshlod/examples/qem_scale.rs), on the
# course's Grand Canyon height field resampled to grids of 0.26M, 1.05M, 4.2M, 16.8M
# and 67M triangles.
#
#   bench/qem_scale.sh [SIZE…]      SIZE as WIDTHxHEIGHT, default all five
#
# Needs ../shared (the height field and tools/make_terrain.py, which needs numpy and
# Pillow: `pip install numpy pillow`). Grids are written once to $MESHLOD_SCALE_DATA
# (default /tmp/meshlod-scale; the largest is 1.3 GB) and kept. The 67M run peaks
# near 10 GiB (133 bytes per triangle at 10%, beside the 1.2 GB input); the whole
# script took 16 minutes on a 2-core machine (grids already written). Prints a Markdown table (see the example's docs for the columns).
set -euo pipefail
cd "$(dirname "$0")/.."
shared=../shared
image=$shared/meshes/hoppe-mesh-processing-library/gcanyon_elev_crop.bw.png
if [ ! -f "$image" ] || [ ! -f "$shared/tools/make_terrain.py" ]; then
    echo "bench/qem_scale.sh: needs $image and $shared/tools/make_terrain.py (absent here)" >&2
    exit 1
fi
data=${MESHLOD_SCALE_DATA:-/tmp/meshlod-scale}
mkdir -p "$data"
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(513x257 1025x513 2049x1025 4097x2049 8193x4097)
files=()
for s in "${sizes[@]}"; do
    w=${s%x*}; h=${s#*x}
    f=$data/gcanyon-${w}x${h}.ply
    if [ ! -f "$f" ]; then
        python3 "$shared/tools/make_terrain.py" "$image" "$f" --width "$w" --height "$h" --z-scale 2 >&2
    fi
    files+=("$(cd "$(dirname "$f")" && pwd)/$(basename "$f")")
done
echo "date $(date -u +%Y-%m-%d), commit $(git rev-parse --short HEAD), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
cargo run --release -q -p meshlod --example qem_scale -- "${files[@]}"
