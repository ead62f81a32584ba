#!/usr/bin/env bash
# Packs what scripts/device/run.sh needs on a lent device machine (x86-64, no Rust toolchain,
# no network) into .devrun/ and .gl/ (both ignored by git: add `/.devrun/` and `/.gl/` to
# .git/info/exclude, and name both in the device tool's `carry`):
#   .devrun/bins.tar.xz  clatter, clatter with --features mpi (as clatter-mpi), and the GPU test
#                        binaries stages and memory_steps, stripped;
#   .devrun/ompi.tar.xz  Debian's LAMMPS (lmp, liblammps) with Open MPI and every library they
#                        load that is not libc/libstdc++ (under /opt/dl/lib), for the MPI rows;
#   .gl/*.deb            the Vulkan/EGL loaders (the device README's recipe).
# Needs Debian's lammps, openmpi-bin and libopenmpi-dev installed here. Takes a few minutes.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p .devrun .gl "$work/bin"
cargo build --release -q -p clatter-cli --features mpi
cp target/release/clatter "$work/bin/clatter-mpi"
cargo build --release -q -p clatter-cli
cp target/release/clatter "$work/bin/clatter"
for t in stages memory_steps poly_lanes narrow; do
  exe=$(cargo test --release -q -p clatter-gpu --test "$t" --no-run --message-format=json 2>/dev/null \
    | python3 -c "import json,sys; print([j['executable'] for j in map(json.loads, sys.stdin) if j.get('executable')][-1])")
  cp "$exe" "$work/bin/$t"
done
strip "$work"/bin/*
tar -C "$work/bin" -cJf .devrun/bins.tar.xz .
# LAMMPS and Open MPI, with their libraries.
r="$work/root"
mkdir -p "$r/opt/dl/lib"
for p in openmpi-bin libopenmpi3:amd64 openmpi-common libpmix2:amd64 lammps liblammps0:amd64; do dpkg -L "$p"; done \
  | grep -vE "^/usr/share/(doc|man|lintian)" | sort -u > "$work/files"
while read -r f; do
  if [ -f "$f" ] || [ -L "$f" ]; then mkdir -p "$r$(dirname "$f")"; cp -a "$f" "$r$f"; fi
done < "$work/files"
ln -sf orterun "$r/usr/bin/mpirun"
core='^(libc|libm|libpthread|libdl|librt|ld-linux-x86-64|libstdc\+\+|libgcc_s|linux-vdso)\.'
ldd /usr/bin/lmp /usr/bin/orted /usr/bin/orterun /usr/lib/x86_64-linux-gnu/openmpi/lib/openmpi3/*.so 2>/dev/null \
  | awk '/=>/ {print $1, $3}' | sort -u > "$work/deps"
awk '{print $1}' "$work/deps" | grep -vE "$core" | sort -u | while read -r n; do
  p=$(awk -v n="$n" '$1==n {print $2; exit}' "$work/deps")
  if [ -f "$p" ] && ! grep -q "/$n$" "$work/files"; then cp -L "$p" "$r/opt/dl/lib/$n"; fi
done
tar -C "$r" -cJf .devrun/ompi.tar.xz .
cp scripts/device/run.sh .devrun/dev.sh
# The Vulkan loader (the device README's recipe).
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
mkdir -p /tmp/amd64/partial
# shellcheck disable=SC2086
apt-get $o update -qq
# shellcheck disable=SC2086
(cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
ls -la .devrun .gl
