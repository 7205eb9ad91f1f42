#!/bin/sh
# CPU-time ratio (perf stat task-clock) of meshlod clustering on one thread against
# meshoptimizer's simplify_sloppy, robust to load on a shared machine:
#   (ours N runs − load) / (meshopt N runs − load), per mesh and ratio, each the
#   least of ROUNDS (default 4) alternating runs.
# Usage: bench/cluster_cpu_ratio.sh [N] [MESH...]   (build the example first:
#   cargo build --release -p meshlod --example cluster_ratio)
set -e
N=${1:-40}
[ $# -gt 0 ] && shift
MESHES=${*:-bunny fandisk armadillo lucy turbine}
BIN=${CARGO_TARGET_DIR:-target}/release/examples/cluster_ratio
ms() { # task-clock milliseconds of one run of the example with MESHLOD_PROFILE=$1
  MESHLOD_PROFILE=$1 perf stat -x, -e task-clock "$BIN" 2>&1 >/dev/null | awk -F, '/task-clock/{print $1}'
}
R=${ROUNDS:-4}
min() { awk -v a="$1" -v b="$2" 'BEGIN{print (a=="" || b<a) ? b : a}'; }
echo "| mesh | ratio | meshopt ms/run | ours ms/run | CPU time ours / meshopt |"
echo "|---|---:|---:|---:|---:|"
for m in $MESHES; do
  for r in 0.1 0.01; do
    L=; A=; B=
    for i in $(seq $R); do
      L=$(min "$L" "$(ms "$m:$r:0")")
      A=$(min "$A" "$(ms "$m:$r:$N:meshopt")")
      B=$(min "$B" "$(ms "$m:$r:$N")")
    done
    awk -v m="$m" -v r="$r" -v n="$N" -v l="$L" -v a="$A" -v b="$B" 'BEGIN{
      A=a-l; B=b-l; printf "| %s | %s | %.2f | %.2f | %.2f |\n", m, r, A/n, B/n, B/A }'
  done
done
