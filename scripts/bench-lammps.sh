#!/usr/bin/env bash
# Times the same settled sphere pile in clatter and in LAMMPS (pair_style gran/hooke/history),
# one after the other on this machine, and prints clatter's steps/s over LAMMPS's.
#
# Usage: scripts/bench-lammps.sh [BODIES] [STEPS] [NPROCS]
#   BODIES  number of spheres (default 16384)
#   STEPS   timed steps (default 1000)
#   NPROCS  MPI ranks for LAMMPS and threads for clatter (default: number of cores)
# Installs LAMMPS with apt-get when `lmp` is missing (Debian package `lammps`).
set -euo pipefail
bodies=${1:-16384}
steps=${2:-1000}
nprocs=${3:-$(nproc)}
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

if ! command -v lmp >/dev/null 2>&1; then
  echo "installing LAMMPS (apt-get install lammps)..." >&2
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq lammps >/dev/null
fi
cargo build --release -q -p clatter-cli --manifest-path "$root/Cargo.toml"
clatter="$root/target/release/clatter"

echo "== clatter: $bodies spheres, $steps steps, $nprocs threads"
"$clatter" bench --shape sphere --bodies "$bodies" --steps "$steps" --threads "$nprocs" \
  --emit-lammps "$work" --json > "$work/clatter.json"
ours=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[0]['steps_per_s'])" "$work/clatter.json")
echo "clatter steps/s: $ours"

echo "== LAMMPS: same pile (pile.data, in.pile), $nprocs MPI ranks"
cd "$work"
if [ "$nprocs" -gt 1 ] && command -v mpirun >/dev/null 2>&1; then
  mpirun --allow-run-as-root --oversubscribe -np "$nprocs" lmp -in in.pile -log lammps.log > lammps.out
else
  lmp -in in.pile -log lammps.log > lammps.out
fi
# The last "Loop time of T on P procs for N steps" is the timed run.
theirs=$(grep "^Loop time" lammps.log | tail -n 1 | awk '{print $9 / $4}')
echo "LAMMPS steps/s: $theirs"
python3 - "$ours" "$theirs" "$bodies" <<'PY'
import sys
ours, theirs, n = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
print(f"bodies {n}: clatter {ours:.1f} steps/s ({ours*n:.3e} body-steps/s), "
      f"LAMMPS {theirs:.1f} steps/s ({theirs*n:.3e} body-steps/s), ratio clatter/LAMMPS = {ours/theirs:.2f}")
PY
