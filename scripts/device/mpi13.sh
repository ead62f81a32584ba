#!/usr/bin/env bash
# Weak scaling of the MPI sphere step (issue 25) with the ghost states' exchange overlapped
# with the contacts that need no ghost (branch `mpi13`) against the same binary with it off
# (CLATTER_MPI_OVERLAP=0: the blocking exchange of mpi12, the same bits), on the device
# machine's 16 cores: 16,384 settled spheres a rank at 1, 4 and 16 ranks, one thread a rank,
# on and off alternated (16 ranks twice, the row the target is about). With CB set, the base
# binary's row too (at 16 ranks only).
# Needs, from the caller (as mpi12.sh; scripts/device/final13.sh sets them):
#   M   the mpirun prefix, e.g. "mpirun --allow-run-as-root --oversubscribe --bind-to core"
#   CM  the clatter binary of `mpi13` built with `--features mpi`
#   PC  a pile cache holding the 16,384 x N sphere piles (N = 1, 4, 16)
# Prints one line per run: "mpi13 LABEL np N bodies B: S steps/s", the per-rank time split
# (with the work overlapped with the ghost states) and the per-rank overlap counts; stops
# starting runs after LEFT s (default 130).
set -u
: "${M:?the mpirun prefix}" "${CM:?the new binary}" "${PC:?the pile cache}"
LEFT=${LEFT:-130}
T0=$(date +%s)
one() { # label binary overlap(0|1) ranks
  local label=$1 bin=$2 ov=$3 np=$4 n=$(( $4 * 16384 ))
  if [ $(( $(date +%s) - T0 )) -gt $LEFT ]; then
    echo "mpi13 $label np $np bodies $n: skipped (past $LEFT s)"
    return
  fi
  local log=/tmp/mpi13-$label-np$np.log
  CLATTER_MPI_OVERLAP=$ov timeout 60 $M -x CLATTER_MPI_OVERLAP -np "$np" "$bin" bench \
    --backend cpu --shape sphere --bodies $n --steps 500 --settle 0 --threads 1 \
    --pile-cache "$PC" --json > "$log" 2>&1
  local rc=$?
  local sps
  sps=$(grep -h -o '"steps_per_s": *[0-9.e+-]*' "$log" | head -1 | sed 's/.*: *//')
  echo "mpi13 $label np $np bodies $n: ${sps:-none} steps/s (rc $rc, $(( $(date +%s) - T0 )) s)"
  grep -h "^# per rank, ms\|^# per rank, overlap" "$log" | sed "s/^/mpi13 $label np $np /"
}
for np in 1 4 16; do
  one off "$CM" 0 $np
  one on "$CM" 1 $np
done
one on "$CM" 1 16
one off "$CM" 0 16
if [ -n "${CB:-}" ]; then one base "$CB" 1 16; fi
