#!/usr/bin/env bash
# One device call for the merges of session 24 (issues 23 and 25), inside about 300 s of an H100
# machine: the new build (.devrun/bins.tar.xz) against the base (.devrun/base/*.xz, the build
# before the merges) where each branch changed something:
#   1. in the background on two pinned cores (14, 15): the default `clatter run` on the CPU,
#      base then new (the CPU target "the default run 2x", the pool-thread run loop);
#   2. gpurun12.sh: `run --backend gpu` against `bench --scene default` (whole processes);
#   3. gpu12.sh: the full polyhedron narrow phase with 0, 8 and 16 lanes a pair on the
#      40,000-body mixed poured pile (poured first);
#   4. mpi12.sh: weak scaling of the sphere step at 1, 4, 16 ranks, base against new.
# Logs and the summary under $OUT. Command: `bash .devrun/final12.sh` with carry [".gl", ".devrun"].
set -u
T0=$(date +%s)
el() { echo "[$(( $(date +%s) - T0 )) s]"; }
S=$OUT/summary.txt
log() { echo "$(el) $*" | tee -a $S; }
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
mkdir -p /opt/cl /opt/base
tar -xJf .devrun/bins.tar.xz -C /opt/cl
for b in clatter clatter-mpi; do xz -dc .devrun/base/$b.xz > /opt/base/$b; chmod +x /opt/base/$b; done
if ! ls /usr/share/vulkan/icd.d/*nvidia* /etc/vulkan/icd.d/*nvidia* >/dev/null 2>&1; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
nvidia-smi --query-gpu=name,clocks.max.sm --format=csv,noheader | tee -a $S
export PC=/tmp/pc OUT
mkdir -p $PC
# 1. The default CPU run, base then new, on cores 14 and 15 while the GPU works.
(
  for x in base:/opt/base/clatter new:/opt/cl/clatter; do
    TIMEFORMAT="%R s wall, %U s user"
    { time taskset -c 14,15 ${x#*:} run --backend cpu --threads 2 --out /tmp/cpu-${x%%:*} -q > /dev/null 2>&1; } 2> /tmp/cpu-${x%%:*}.time
    echo "cpu default run ${x%%:*}: $(cat /tmp/cpu-${x%%:*}.time | tail -1), final.csv $(md5sum < /tmp/cpu-${x%%:*}/final.csv | cut -c1-8)" >> /tmp/cpu.txt
  done
) &
CPU_PID=$!
TS="taskset -c 0-7"
# 2. run against bench on the GPU: new, then base (the same script with C set).
log "gpurun12 new"; C=/opt/cl/clatter $TS bash scripts/device/gpurun12.sh 2>&1 | tee -a $S
log "gpurun12 base"; C=/opt/base/clatter STEPS=5000 $TS bash -c 'for k in 1 2; do for c in "bench --backend gpu --scene default --settle 0 --steps 5000" "run --backend gpu --steps 5000 -q --out /tmp/rb"; do s=$(date +%s.%N); timeout 60 $C $c > /dev/null 2>&1; echo "base ${c%% *} $(python3 -c "import sys;print(round(float(sys.argv[2])-float(sys.argv[1]),3))" $s $(date +%s.%N)) s whole process"; done; done' 2>&1 | tee -a $S
# 3. gpu12 on 40,000 bodies (pouring 80,000 takes about 110 s, more than this call has).
N=${N:-40000}
log "gpu12 pour $N"
timeout 100 $TS /opt/cl/clatter bench --backend gpu --pile-cache $PC --shape mixed --pile poured --bodies $N --steps 10 --settle 0 > $OUT/pour.log 2>&1
log "gpu12 poured rc=$?"
sed "s/--bodies 80000/--bodies $N/; s/\^ +80000 /^ +$N /" scripts/device/gpu12.sh > /tmp/gpu12.sh
C=/opt/cl/clatter timeout 100 $TS bash /tmp/gpu12.sh 2>&1 | tee -a $S
log "gpu12 done"
wait $CPU_PID; cat /tmp/cpu.txt | tee -a $S
# 4. MPI weak scaling, base against new (the machine's own Open MPI, as run.sh's `system` mode).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export M="mpirun --allow-run-as-root --oversubscribe --bind-to core" CM=/opt/cl/clatter-mpi CB=/opt/base/clatter-mpi
timeout 60 /opt/cl/clatter bench --backend gpu --pile-cache $PC --shape sphere --pile poured --bodies 16384,65536,262144 --steps 10 --settle 0 > $OUT/sph_pour.log 2>&1
log "spheres poured rc=$?"
# Within the call's limit: mpi12.sh stops starting runs after LEFT s (it says 130 s).
LEFT=$(( 250 - ($(date +%s) - T0) )); [ $LEFT -lt 20 ] && LEFT=20
sed "s/-gt 130 /-gt $LEFT /" scripts/device/mpi12.sh > /tmp/mpi12.sh
timeout $(( LEFT + 25 )) bash /tmp/mpi12.sh 2>&1 | tee -a $S
log "done"
