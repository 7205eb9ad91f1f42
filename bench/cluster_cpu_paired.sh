#!/bin/sh
# Paired CPU-time comparison (perf stat task-clock, least of ROUNDS rounds, load time
# subtracted) of a baseline build of examples/cluster_ratio (OLD=path) against this
# one (NEW, default the target dir's) and meshopt, one rayon thread, alternating.
# Usage: OLD=/path/to/old/cluster_ratio bench/cluster_cpu_paired.sh [N]
N=${1:-30}; R=${ROUNDS:-3}
OLD=${OLD:?set OLD to the baseline build of examples/cluster_ratio}
NEW=${NEW:-${CARGO_TARGET_DIR:-target}/release/examples/cluster_ratio}
ms() { MESHLOD_PROFILE=$2 perf stat -x, -e task-clock "$1" 2>&1 >/dev/null | awk -F, '/task-clock/{print $1}'; }
min() { awk -v a="$1" -v b="$2" 'BEGIN{print (a=="" || b<a) ? b : a}'; }
echo "| mesh | ratio | meshopt ms | before ms | after ms | before / meshopt | after / meshopt | after / before |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
for m in bunny fandisk armadillo lucy turbine; do for r in 0.1 0.01; do
  L=; A=; B=; C=
  for i in $(seq $R); do
    L=$(min "$L" "$(ms $NEW $m:$r:0)")
    A=$(min "$A" "$(ms $NEW $m:$r:$N:meshopt)")
    B=$(min "$B" "$(ms $OLD $m:$r:$N)")
    C=$(min "$C" "$(ms $NEW $m:$r:$N)")
  done
  awk -v m=$m -v r=$r -v n=$N -v l=$L -v a=$A -v b=$B -v c=$C 'BEGIN{A=(a-l)/n;B=(b-l)/n;C=(c-l)/n; printf "| %s | %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n",m,r,A,B,C,B/A,C/A,C/B}'
done; done
