#!/usr/bin/env bash
# Weak scaling of the MPI sphere step (issue 25), branch `mpi12` against its base, on the
# device machine's 16 cores: 16,384 settled spheres a rank at 1, 4 and 16 ranks, one thread
# a rank, base and new alternated (16 ranks twice, the row the target is about).
# Needs, from the caller (scripts/device/run.sh sets the first and the last):
#   M   the mpirun prefix, e.g. "mpirun --allow-run-as-root --oversubscribe --bind-to core"
#   CM  the new clatter binary built with `--features mpi`
#   CB  the base clatter binary built with `--features mpi`
#   PC  a pile cache holding the 16,384 x N sphere piles (N = 1, 4, 16: 16,384, 65,536 and
#       262,144 bodies; `bench --pile-cache` pours a missing one, which takes minutes)
# Prints one line per run: "mpi12 LABEL np N bodies B: S steps/s" and the per-rank split,
# and stops starting runs after 130 s (under 150 s in all with the piles present).
set -u
: "${M:?the mpirun prefix}" "${CM:?the new binary}" "${CB:?the base binary}" "${PC:?the pile cache}"
T0=$(date +%s)
one() { # label binary ranks
  local label=$1 bin=$2 np=$3 n=$(( $3 * 16384 ))
  if [ $(( $(date +%s) - T0 )) -gt 130 ]; then
    echo "mpi12 $label np $np bodies $n: skipped (past 130 s)"
    return
  fi
  local log=/tmp/mpi12-$label-np$np.log
  timeout 60 $M -np "$np" "$bin" bench --backend cpu --shape sphere --bodies $n --steps 500 \
    --settle 0 --threads 1 --pile-cache "$PC" --json > "$log" 2>&1
  local rc=$?
  local sps
  sps=$(grep -h -o '"steps_per_s": *[0-9.e+-]*' "$log" | head -1 | sed 's/.*: *//')
  echo "mpi12 $label np $np bodies $n: ${sps:-none} steps/s (rc $rc, $(( $(date +%s) - T0 )) s)"
  grep -h "^# per rank, ms" "$log" | sed "s/^/mpi12 $label np $np /"
}
for np in 1 4 16; do
  one base "$CB" $np
  one new "$CM" $np
done
one new "$CM" 16
one base "$CB" 16
