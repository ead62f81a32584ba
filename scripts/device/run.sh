#!/usr/bin/env bash
# Device run (the `device` tool's machine, an H100 or H200 with 16 cores): the GPU targets of
# issue 23 (`run.sh gpu`), then the MPI scaling rows of issue 25 beside LAMMPS (`run.sh mpi`).
# Made by scripts/device/pack.sh (copied to .devrun/dev.sh); the device tool's command is
# `bash .devrun/dev.sh gpu` (or `both`: the targets of both issues in one call) with carry [".gl", ".devrun"]. Each stage has its own timeout;
# the logs go to $OUT/all.log and a summary to $OUT/summary.txt (at most 8 files come back).
# MPI: the machine's own Open MPI is used when it has one (it had 4.1.6); unpacking the
# carried Debian 4.1.4 over it crashed mpirun, so that is only the fallback.
# Every stage has its own timeout and logs under $OUT; a summary is printed as it goes.
set -u
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s]"; }
log() { echo "$(el) $*" | tee -a $OUT/summary.txt; }
root=$PWD
L=/tmp/logs; mkdir -p $L
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
mkdir -p /opt/cl
tar -xJf .devrun/bins.tar.xz -C /opt/cl || python3 -c "import tarfile;tarfile.open('.devrun/bins.tar.xz').extractall('/opt/cl')"
if [ ! -e /work/main ]; then mkdir -p /work; ln -s "$root" /work/main; fi
if ! ls /usr/share/vulkan/icd.d/*nvidia* /etc/vulkan/icd.d/*nvidia* >/dev/null 2>&1; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
nvidia-smi --query-gpu=name,clocks.max.sm,clocks.max.mem,memory.total --format=csv | tee -a $OUT/summary.txt
nproc | tee -a $OUT/summary.txt
C=/opt/cl/clatter
PC=/tmp/pc
# Pile caches carried from an earlier call (xz, as `both` sends them back) skip the pouring.
mkdir -p $PC; for f in .devrun/pc/*.xz; do [ -f "$f" ] && xz -dc "$f" > $PC/$(basename "$f" .xz); done
G="$C bench --backend gpu --pile-cache $PC"
stage() { # name timeout cmd...
  local name=$1 t=$2; shift 2
  local s=$(date +%s.%N)
  timeout $t "$@" > $L/$name.log 2>&1
  local rc=$?
  local e=$(python3 -c "import sys;print(round($(date +%s.%N)-$s,2))")
  log "$name rc=$rc ${e}s"
  { echo "===== $name rc=$rc ${e}s: $*"; cat $L/$name.log; } >> $OUT/all.log
  grep -vE "^#   step|^$" $L/$name.log | grep -v '^ *"' | tail -n 8 | sed 's/^/    /' | tee -a $OUT/summary.txt
}
if [ "${1:-gpu}" = final ]; then
# A short re-check after fixes: the 4M-sphere row, run against bench, the GPU tests.
stage sph4M_lat 120 $G --shape sphere --pile lattice --bodies 4194304 --steps 500 --settle 200
stage default_bench 60 $G --scene default --settle 0 --steps 5000
stage default_run 60 $C run --backend gpu --steps 5000 -q --out /tmp/run1
stage default_run_sparse 60 $C run --backend gpu --steps 5000 -q --energy-every 1000 --check-every 1000 --out /tmp/run2
for t in stages memory_steps; do CI=1 stage test_$t 90 /opt/cl/$t --test-threads 4; done
log "final gpu part done"; set -- mixmpi
fi
# `ab`: `check`, plus the CPU targets timed on this machine's quiet cores (2 pinned), the
# issue's baseline binary, the last merge's base and this build alternated (carried in
# .devrun/extra.tar.xz with their pile caches: clatter-8c9edd6, clatter-base, pc/). `AB=1` adds
# the same A/B to `both`.
AB=${AB:-0}; if [ "${1:-gpu}" = ab ]; then AB=1; set -- check; fi
if [ "${1:-gpu}" = check ]; then
# A short re-check after merges: the machine's cores, the GPU tests, the default scene, then
# the weak-scaling end rows (1 and 16 ranks) and 8 ranks of the 16.
{ lscpu | grep -E "^(Model name|Socket|Core|Thread|CPU\(s\)|NUMA node\(s\)|L2|L3)"; } 2>&1 | tee -a $OUT/summary.txt
for t in stages memory_steps; do CI=1 stage test_$t 70 /opt/cl/$t --test-threads 8; done
stage default_bench 40 $G --scene default --settle 0 --steps 5000
stage default_run 40 $C run --backend gpu --steps 5000 -q --out /tmp/run1
stage default_run_sparse 40 $C run --backend gpu --steps 5000 -q --energy-every 5000 --check-every 5000 --out /tmp/run2
log "gpu part done"; W="16384 262144"; S=16384; NPS="1 2"; WNP="1 16"; set -- mpi
fi
if [ "${1:-gpu}" = lease15 ]; then
# Session 26's second call: `run` against `bench` on the GPU three times alternated, then
# (below, after MPI starts) the machine's own ceiling for weak scaling and the merged build
# against the base one at 1 and 16 ranks.
for r in 1 2 3; do
  stage default_bench_$r 30 $G --scene default --settle 0 --steps 5000
  stage default_run_$r 30 $C run --backend gpu --steps 5000 -q --out /tmp/run$r
done
log "gpu part done"; LEASE15=1; set -- mpi
fi
if [ "${1:-gpu}" = lease14 ]; then
# Session 26's one call: the H100 targets of issue 23 first (the poured 80,000 pile, then 13
# tiles of it: 1,040,000 bodies), the GPU tests on NVIDIA's compiler (with the lanes and narrow
# batches), run against bench, then the MPI rows: LAMMPS beside clatter at 1 and 16 ranks (and
# 4 for weak scaling), and the exchange overlap on and off (mpi13.sh). 4M spheres only if
# time is left (their kernels are unchanged since they were last timed).
stage mixed80k 200 $G --shape mixed --pile poured --bodies 80000 --steps 1000 --settle 200
for f in $PC/mixed-n80000-*.ckpt; do [ -f "$f" ] && xz -T8 -c "$f" > $OUT/$(basename "$f").xz; done
stage mixed1M_tiles 150 $G --shape mixed --pile poured --bodies 80000 --tiles 13 --steps 300 --settle 200
for t in stages memory_steps poly_lanes narrow; do CI=1 stage test_$t 60 /opt/cl/$t --test-threads 8; done
stage default_bench 30 $G --scene default --settle 0 --steps 5000
stage default_run 30 $C run --backend gpu --steps 5000 -q --out /tmp/run1
stage default_run_sparse 30 $C run --backend gpu --steps 5000 -q --energy-every 5000 --check-every 5000 --out /tmp/run2
log "gpu part done"; W="16384 65536 262144"; NPS="1 16"; WNP="1 4 16"; OVERLAP_AB=1; set -- mpi
fi
if [ "${1:-gpu}" = both ]; then
# One call for a 15-minute lease: the H100 targets of issue 23 first, then the 16-rank rows of
# issue 25 (weak scaling at 1, 4, 16 ranks and the strong row at 16; LAMMPS beside each).
stage sph4M_lat 100 $G --shape sphere --pile lattice --bodies 4194304 --steps 500 --settle 200
stage mixed80k 200 $G --shape mixed --pile poured --bodies 80000 --steps 1000 --settle 200
# The poured pile comes back (xz) so that a later call can carry it in .devrun/pc/ and skip pouring.
for f in $PC/mixed-n80000-*.ckpt; do [ -f "$f" ] && xz -T8 -c "$f" > $OUT/$(basename "$f").xz; done
stage mixed80k_prof 45 $G --shape mixed --pile poured --bodies 80000 --steps 300 --settle 0 --profile --profile-steps 100
# Issue 23's 1,000,000-body row: the 80,000 pile just settled, 13 tiles side by side (1,040,000).
stage mixed1M_tiles 120 $G --shape mixed --pile poured --bodies 80000 --tiles 13 --steps 300 --settle 200
stage default_bench 40 $G --scene default --settle 0 --steps 5000
stage default_run 40 $C run --backend gpu --steps 5000 -q --out /tmp/run1
stage default_run_sparse 40 $C run --backend gpu --steps 5000 -q --energy-every 5000 --check-every 5000 --out /tmp/run2
for t in stages memory_steps; do CI=1 stage test_$t 70 /opt/cl/$t --test-threads 8; done
log "gpu part done"; W="16384 65536 262144"; NPS="1 16"; WNP="1 4 16"; set -- mpi
fi
if [ "${1:-gpu}" = gpu ]; then
# 1. H100 targets (issue 23).
stage mixed80k 260 $G --shape mixed --pile poured --bodies 80000 --steps 1000 --settle 200
stage mixed80k_prof 60 $G --shape mixed --pile poured --bodies 80000 --steps 300 --settle 0 --profile --profile-steps 100
stage mixed1M_lat 90 $G --shape mixed --pile lattice --bodies 1048576 --steps 200 --settle 100
stage mixed1M_tiles 120 $G --shape mixed --pile poured --bodies 80000 --tiles 13 --steps 300 --settle 200
stage sph4M_lat 90 $G --shape sphere --pile lattice --bodies 4194304 --steps 500 --settle 200
stage default_bench 60 $G --scene default --settle 0 --steps 5000
stage default_run 60 $C run --backend gpu --steps 5000 -q --out /tmp/run1
stage default_prof 60 $G --scene default --settle 10000 --steps 500 --profile --profile-steps 200
# 2. GPU correctness on the H100.
for t in stages memory_steps; do CI=1 stage test_$t 90 /opt/cl/$t --test-threads 4; done
log "gpu part done"; exit 0; fi
# 3. MPI scaling (issue 25), 1 thread per rank (`mpi`), or only the poured mixed pile (`mixmpi`).
MODE_ARG=${1:-mpi}
W=${W:-16384 32768 65536 131072 262144}; S=${S:-65536}; MX=${MX:-16384}; NPS=${NPS:-1 2 4 8 16}
{ echo "== probe"; command -v mpirun mpiexec orterun prterun; mpirun --version 2>&1 | head -3; ls /usr/lib/x86_64-linux-gnu/pmix2/lib/pmix 2>&1 | head -20; ldconfig -p | grep -E "libmpi\.so|libpmix|libhwloc|libevent_core"; cat /etc/os-release | head -2; } 2>&1 | tee -a $OUT/summary.txt
mkdir -p /opt/or && tar -xJf .devrun/ompi.tar.xz -C /opt/or
MODE=ours
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
if command -v mpirun >/dev/null && timeout 30 mpirun --allow-run-as-root --oversubscribe -np 2 true; then
  MODE=system; mkdir -p /opt/need
  for f in /opt/or/opt/dl/lib/*; do n=$(basename $f); ldconfig -p | grep -q "^[[:space:]]*$n " || ln -sf $f /opt/need/$n; done
  ln -sf /opt/or/usr/lib/x86_64-linux-gnu/liblammps.so.0 /opt/need/liblammps.so.0
  export LD_LIBRARY_PATH=/opt/need; LMP=/opt/or/usr/bin/lmp
  M="mpirun --allow-run-as-root --oversubscribe --bind-to core -x LD_LIBRARY_PATH"
  timeout 60 $M -np 2 /opt/cl/clatter-mpi bench --shape sphere --pile lattice --bodies 1024 --steps 10 --settle 0 --threads 1 > /tmp/logs/sys_try.log 2>&1 || { MODE=ours; tail -5 /tmp/logs/sys_try.log | tee -a $OUT/summary.txt; }
fi
if [ $MODE = ours ]; then
  tar -xJf .devrun/ompi.tar.xz -C /
  export LD_LIBRARY_PATH=/opt/dl/lib PMIX_MCA_gds=hash PMIX_MCA_preg=native; LMP=lmp
  M="mpirun --oversubscribe --bind-to core --mca btl self,vader --mca pml ob1 -x LD_LIBRARY_PATH -x PMIX_MCA_gds -x PMIX_MCA_preg"
fi
log "MPI mode $MODE"
CM=/opt/cl/clatter-mpi
stage mpi_hello 30 $M -np 2 $CM bench --shape sphere --pile lattice --bodies 1024 --steps 10 --settle 0 --threads 1
grep -q "MPI ranks" $L/mpi_hello.log || { log "MPI does not start; stopping"; exit 0; }
if [ "${LEASE15:-0}" = 1 ]; then
  { lscpu | grep -E "^(Model name|Socket|Core|Thread|CPU\(s\)|NUMA|L2|L3|On-line)"; } 2>&1 | tee -a $OUT/summary.txt
  mkdir -p /opt/base; for b in clatter clatter-mpi; do [ -f .devrun/base/$b.xz ] && xz -dc .devrun/base/$b.xz > /opt/base/$b && chmod +x /opt/base/$b; done
  stage sph_pour 60 $G --shape sphere --pile poured --bodies 16384,262144 --steps 10 --settle 0
  mkdir -p /tmp/l16384 /tmp/l262144
  stage emit16384 30 $C bench --shape sphere --bodies 16384 --steps 500 --settle 0 --threads 16 --pile-cache $PC --emit-lammps /tmp/l16384
  stage emit262144 30 $C bench --shape sphere --bodies 262144 --steps 500 --settle 0 --threads 16 --pile-cache $PC --emit-lammps /tmp/l262144
  sps() { grep -h -o '"steps_per_s": *[0-9.e+-]*' "$1" 2>/dev/null | head -1 | sed 's/.*: *//'; }
  lsps() { grep "^Loop time" "$1" 2>/dev/null | tail -1 | awk '{print $9/$4}'; }
  # The machine's ceiling: the one-rank bench alone on core 0, then 16 copies at once, one per
  # core (no MPI, nothing exchanged): what 16 busy cores cost each process by themselves.
  for bin in /opt/base/clatter $C; do
    taskset -c 0 $bin bench --backend cpu --shape sphere --bodies 16384 --steps 500 --settle 0 --threads 1 --pile-cache $PC --json > /tmp/solo.json 2>&1
    log "ceiling $bin alone: $(sps /tmp/solo.json) steps/s"
    mkdir -p /tmp/six; for i in $(seq 0 15); do taskset -c $i $bin bench --backend cpu --shape sphere --bodies 16384 --steps 500 --settle 0 --threads 1 --pile-cache $PC --json > /tmp/six/$i.json 2>&1 & done; wait
    log "ceiling $bin 16 at once: $(for i in $(seq 0 15); do sps /tmp/six/$i.json; done | tr '\n' ' ')"
  done
  (cd /tmp/l16384 && taskset -c 0 timeout 60 $LMP -in in.pile -log /tmp/lsolo.log > /dev/null 2>&1); log "ceiling lammps alone: $(lsps /tmp/lsolo.log) steps/s"
  (cd /tmp/l16384 && for i in $(seq 0 15); do taskset -c $i timeout 90 $LMP -in in.pile -log /tmp/six/l$i.log > /dev/null 2>&1 & done; wait)
  log "ceiling lammps 16 at once: $(for i in $(seq 0 15); do lsps /tmp/six/l$i.log; done | tr '\n' ' ')"
  one() { # label env binary np
    local l=$1 e=$2 b=$3 np=$4 n=$(( $4 * 16384 ))
    env $e timeout 60 $M -x CLATTER_MPI_BALANCE -np $np $b bench --backend cpu --shape sphere --bodies $n --steps 500 --settle 0 --threads 1 --pile-cache $PC --json > /tmp/one.log 2>&1
    log "mpi $l np $np bodies $n: $(sps /tmp/one.log) steps/s"
    grep -h "^# per rank" /tmp/one.log | cut -c1-600 >> $OUT/summary.txt
  }
  for np in 1 16 16; do
    one base CLATTER_MPI_BALANCE=bodies /opt/base/clatter-mpi $np
    one new-bodies CLATTER_MPI_BALANCE=bodies $CM $np
    one new-work CLATTER_MPI_BALANCE=work $CM $np
  done
  for np in 1 16; do n=$(( np * 16384 )); (cd /tmp/l$n && timeout 90 $M -np $np $LMP -in in.pile -log /tmp/lm$np.log > /dev/null 2>&1); log "lammps np $np bodies $n: $(lsps /tmp/lm$np.log) steps/s"; done
  log "done"; exit 0
fi
if [ $AB = 1 ]; then
  mkdir -p /opt/ex $PC && tar -xJf .devrun/extra.tar.xz -C /opt/ex
  PQ=/tmp/pcq; mkdir -p $PQ; cp /opt/ex/pc/*.ckpt $PQ/; cp $PQ/sphere-n16384* $PC/
  TS="taskset -c 2,3"; command -v taskset > /dev/null || TS=""
  O=/opt/ex/clatter-8c9edd6; B=/opt/ex/clatter-base
  ab() { # label binary bench-args...
    local l=$1 b=$2; shift 2
    local v=$($TS $b bench --backend cpu --pile-cache $PQ --json "$@" 2>/dev/null | python3 -c "import json,sys; print(round(json.load(sys.stdin)[0]['steps_per_s'],1))" 2>&1)
    log "ab $l: $v steps/s ($*)"
  }
  for r in 1 2; do
    for x in "issue:$O" "base:$B" "new:$C"; do
      ab "${x%%:*} mixed" ${x#*:} --shape mixed --pile poured --bodies 2048 --steps 200 --threads 2
      ab "${x%%:*} cube" ${x#*:} --shape cube --pile poured --bodies 2048 --steps 200 --threads 2
    done
    for x in "base:$B" "new:$C"; do
      ab "${x%%:*} sphere t1" ${x#*:} --shape sphere --pile poured --bodies 16384 --steps 1000 --threads 1
      ab "${x%%:*} sphere t2" ${x#*:} --shape sphere --pile poured --bodies 16384 --steps 1000 --threads 2
    done
  done
  for x in "issue:$O" "base:$B" "new:$C"; do
    TIMEFORMAT="%R s wall, %U s user"; { time $TS ${x#*:} run --backend cpu --threads 2 --out /tmp/r-${x%%:*} -q > /dev/null 2>&1; } 2> /tmp/t.txt
    log "default run ${x%%:*}: $(cat /tmp/t.txt | tail -1), final.csv $(md5sum < /tmp/r-${x%%:*}/final.csv | cut -c1-8)"
  done
fi
if [ "$MODE_ARG" = mixmpi ]; then
  stage mix_pour 150 $G --shape mixed --pile poured --bodies $MX --steps 10 --settle 0
  for np in 1 4 16; do stage mp_np${np} 120 $M -np $np $CM bench --backend cpu --shape mixed --bodies $MX --steps 100 --settle 0 --threads 1 --pile-cache $PC --json; grep -h -E "steps_per_s|contacts_per_body" $L/mp_np${np}.log | sed "s/^/mixed poured np $np /" | tee -a $OUT/summary.txt; done
  log "done"; exit 0
fi
stage sph_pour 120 $G --shape sphere --pile poured --bodies $(echo $W | tr " " ,) --steps 10 --settle 0
for n in $W; do
  mkdir -p /tmp/l$n
  stage emit$n 60 $C bench --shape sphere --bodies $n --steps 500 --settle 0 --threads 16 --pile-cache $PC --emit-lammps /tmp/l$n
done
run_pair() { # np bodies
  local np=$1 n=$2
  stage c_np${np}_n$n 120 $M -np $np $CM bench --backend cpu --shape sphere --bodies $n --steps 500 --settle 0 --threads 1 --pile-cache $PC --json > /dev/null
  grep -h steps_per_s $L/c_np${np}_n$n.log | sed "s/^/clatter np $np n $n /" | tee -a $OUT/summary.txt
  grep -h "^# per rank, ms" $L/c_np${np}_n$n.log | sed "s/^/clatter np $np n $n /" | tee -a $OUT/summary.txt
  (cd /tmp/l$n && timeout 120 $M -np $np $LMP -in in.pile -log l$np.log > /dev/null 2>&1; grep "^Loop time" l$np.log | tail -1 | awk -v np=$np -v n=$n '{print "lammps np", np, "n", n, $9/$4, "steps/s"}' | tee -a $OUT/summary.txt)
}
for np in $NPS; do run_pair $np $S; done
if [ -n "${WNP:-}" ]; then
  set -- $WNP; for n in $W; do np=$1; shift; [ $n = $S ] && echo " $NPS " | grep -q " $np " && continue; run_pair $np $n; done
  if [ "${OVERLAP_AB:-0}" = 1 ]; then
    export M CM PC; LEFT=$(( 480 - $(date +%s) + T0 )) bash "$root/scripts/device/mpi13.sh" 2>&1 | tee -a $OUT/summary.txt
    if [ $(( $(date +%s) - T0 )) -lt 440 ]; then stage sph4M_lat 90 $G --shape sphere --pile lattice --bodies 4194304 --steps 500 --settle 200; fi
  fi
  log "done"; exit 0
fi
i=0; for n in $W; do np=$((1<<i)); i=$((i+1)); [ $n = $S ] && continue; run_pair $np $n; done
for np in 1 4 16; do stage m_np${np} 120 $M -np $np $CM bench --backend cpu --shape mixed --pile lattice --bodies $MX --steps 100 --settle 0 --threads 1 --pile-cache $PC --json; grep -h steps_per_s $L/m_np${np}.log | tee -a $OUT/summary.txt; done
log "done"
