#!/usr/bin/env bash
# The Khronos glTF validator over `meshlod lod` outputs: every glTF asset of
# ../shared/meshes/gltf-sample-models and the bunny, each written as a .glb chain
# with --geomorph. Prints errors / warnings / infos per file and the messages of
# severity error or warning; exits non-zero when any file has an error.
#
#   bench/lod_validate.sh [OUT_DIR]        (default /tmp/meshlod-lod-validate)
#
# Needs node and npm (the validator is installed from npm into OUT_DIR once).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/meshlod-lod-validate}
mkdir -p "$out"
if [ ! -d "$out/node_modules/gltf-validator" ]; then
    (cd "$out" && npm init -y >/dev/null && npm install --silent gltf-validator >/dev/null)
fi
cargo build --release -p meshlod-cli >&2
bin=target/release/meshlod
inputs=(tests/data/stanford-bunny.obj)
models=../shared/meshes/gltf-sample-models
if [ -d "$models" ]; then
    for d in "$models"/*/; do
        f=$(ls "$d"*.glb "$d"*.gltf 2>/dev/null | head -1 || true)
        [ -n "$f" ] && inputs+=("$f")
    done
else
    echo "bench/lod_validate.sh: $models is absent; validating the bunny only" >&2
fi
outs=()
for f in "${inputs[@]}"; do
    name=$(basename "$f"); name=${name%.*}
    "$bin" lod "$f" -o "$out/$name.glb" --geomorph --samples 200000 >/dev/null
    outs+=("$out/$name.glb")
done
cp bench/js/gltf_validate.js "$out/"
node "$out/gltf_validate.js" "${outs[@]}"
