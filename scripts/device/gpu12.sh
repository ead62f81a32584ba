#!/usr/bin/env bash
# gpu12 (issue 23): the full polyhedron narrow phase with one thread per pair
# (`contacts_full_poly`, CLATTER_GPU_POLY_LANES=0) against 8 and 16 lanes per pair
# (`contacts_full_poly_lanes`), on the 80,000-body mixed poured pile, in one device call
# (after run.sh's setup: binary /opt/cl/clatter, piles in $PC, the 80,000 pile carried).
# Per variant: the bench (1,000 steps, no settling), then --profile (100 steps, per kernel);
# then a bitwise check of the variants (the default scene, 3,000 GPU steps, cmp of the
# outputs), and the poly_lanes test binary if it was packed (/opt/cl/poly_lanes).
# About 60-90 s on an H100. Prints one summary line per run; logs under $OUT (or /tmp).
set -u
C=${C:-/opt/cl/clatter}
PC=${PC:-/tmp/pc}
O=${OUT:-/tmp}/gpu12; mkdir -p $O
B="$C bench --backend gpu --pile-cache $PC --shape mixed --pile poured --bodies 80000 --settle 0"
for L in 0 8 16 0; do
  CLATTER_GPU_POLY_LANES=$L timeout 60 $B --steps 1000 > $O/bench-$L.log 2>&1
  echo "lanes=$L rc=$? bench: $(grep -E '^ +80000 ' $O/bench-$L.log | tail -1)"
done
for L in 0 8 16; do
  CLATTER_GPU_POLY_LANES=$L timeout 60 $B --steps 200 --profile --profile-steps 100 > $O/prof-$L.log 2>&1
  echo "lanes=$L rc=$? profile: $(grep -E '^# +kernels' $O/prof-$L.log | tail -1 | tr -s ' ')"
done
for L in 0 8 16; do
  CLATTER_GPU_POLY_LANES=$L timeout 60 $C run --backend gpu --steps 3000 -q --out $O/run-$L > $O/run-$L.log 2>&1
  echo "lanes=$L rc=$? run"
done
for L in 8 16; do
  for f in final.csv energy.csv; do
    cmp -s $O/run-0/$f $O/run-$L/$f && echo "same bits: $f, 0 and $L lanes" || echo "DIFFERENT: $f, 0 and $L lanes"
  done
done
if [ -x /opt/cl/poly_lanes ]; then
  CI=1 timeout 90 /opt/cl/poly_lanes --nocapture > $O/test.log 2>&1
  echo "poly_lanes test rc=$? $(grep -E 'test result|touching|differs' $O/test.log | tr '\n' ';')"
fi
