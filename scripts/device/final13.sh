#!/usr/bin/env bash
# One device call for `mpi13` (issue 25): the overlap of the ghost states' exchange on and
# off at 1, 4 and 16 ranks (mpi13.sh), inside about 250 s of a 16-core machine. Needs the
# build packed by scripts/device/pack.sh (.devrun/bins.tar.xz, with clatter-mpi) and, for the
# base row, .devrun/base/clatter-mpi.xz (optional). Command: `bash scripts/device/final13.sh`
# with carry [".gl", ".devrun"]; logs and the summary under $OUT.
set -u
T0=$(date +%s)
S=$OUT/summary.txt
log() { echo "[$(( $(date +%s) - T0 )) s] $*" | tee -a $S; }
for f in .gl/*.deb; do [ -f "$f" ] && dpkg -x "$f" /; done; ldconfig
mkdir -p /opt/cl /opt/base
tar -xJf .devrun/bins.tar.xz -C /opt/cl
CB=""
if [ -f .devrun/base/clatter-mpi.xz ]; then
  xz -dc .devrun/base/clatter-mpi.xz > /opt/base/clatter-mpi; chmod +x /opt/base/clatter-mpi
  CB=/opt/base/clatter-mpi
fi
nproc | tee -a $S
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export M="mpirun --allow-run-as-root --oversubscribe --bind-to core" CM=/opt/cl/clatter-mpi CB
export PC=/tmp/pc; mkdir -p $PC
# The settled sphere piles (poured on the GPU, a minute), as final12.sh pours them.
timeout 60 /opt/cl/clatter bench --backend gpu --pile-cache $PC --shape sphere --pile poured \
  --bodies 16384,65536,262144 --steps 10 --settle 0 > $OUT/sph_pour.log 2>&1
log "spheres poured rc=$?"
export LEFT=$(( 250 - ($(date +%s) - T0) )); [ $LEFT -lt 20 ] && LEFT=20
timeout $(( LEFT + 25 )) bash scripts/device/mpi13.sh 2>&1 | tee -a $S
log "done"
