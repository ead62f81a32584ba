#!/usr/bin/env bash
# Branch gpurun12 (issue 23): the whole `clatter run --backend gpu` process against the whole
# `clatter bench --backend gpu --scene` process on the default scene, 5,000 steps, twice each,
# alternated, one line each (wall seconds of the process, from start to exit). Then once the run
# with checks and samples only at the end (what the checks cost), and bench and run with at most
# 2 batches in flight (CLATTER_GPU_IN_FLIGHT=2, default 8: a stopped pipeline runs every batch
# already submitted as no-ops, so fewer cost less per stop, if the GPU does not idle between
# them). About 40 s on an H100.
# Binary: $C (default /opt/cl/clatter, as scripts/device/run.sh unpacks it); STEPS (default 5000).
set -u
C=${C:-/opt/cl/clatter}
N=${STEPS:-5000}
secs() { python3 -c "import sys;print(f'{float(sys.argv[2])-float(sys.argv[1]):.3f}')" "$1" "$2"; }
timed() { # label cmd...
  local label=$1; shift
  local s=$(date +%s.%N)
  timeout 60 "$@" > /tmp/gpurun12-$label.log 2>&1
  local rc=$?
  local e=$(date +%s.%N)
  echo "$label rc=$rc $(secs $s $e) s whole process"
}
for k in 1 2; do
  timed bench$k $C bench --backend gpu --scene default --settle 0 --steps $N
  timed run$k $C run --backend gpu --steps $N -q --out /tmp/r
done
timed run_sparse $C run --backend gpu --steps $N -q --energy-every $N --check-every $N --out /tmp/r2
timed bench_depth2 env CLATTER_GPU_IN_FLIGHT=2 $C bench --backend gpu --scene default --settle 0 --steps $N
timed run_depth2 env CLATTER_GPU_IN_FLIGHT=2 $C run --backend gpu --steps $N -q --out /tmp/r3
for l in bench2 bench_depth2; do echo "$l: $(tail -n 1 /tmp/gpurun12-$l.log)"; done
