#!/bin/sh
# CPU-time ratio (perf stat task-clock) of meshlod clustering on one thread against
# meshoptimizer's simplify_sloppy, robust to load on a shared machine:
#   (ours N runs − load) / (meshopt N runs − load), per mesh and ratio.
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
echo "| mesh | ratio | meshopt ms/run | ours ms/run | CPU time ours / meshopt |"
echo "|---|---:|---:|---:|---:|"
for m in $MESHES; do
  for r in 0.1 0.01; do
    l=$(ms "$m:$r:0"); a=$(ms "$m:$r:$N:meshopt"); b=$(ms "$m:$r:$N")
    l2=$(ms "$m:$r:0"); a2=$(ms "$m:$r:$N:meshopt"); b2=$(ms "$m:$r:$N")
    awk -v m="$m" -v r="$r" -v n="$N" -v l="$l" -v a="$a" -v b="$b" -v l2="$l2" -v a2="$a2" -v b2="$b2" 'BEGIN{
      L=(l<l2?l:l2); A=(a<a2?a:a2)-L; B=(b<b2?b:b2)-L;
      printf "| %s | %s | %.2f | %.2f | %.2f |\n", m, r, A/n, B/n, B/A }'
  done
done
