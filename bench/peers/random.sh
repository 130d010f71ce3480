#!/usr/bin/env bash
# tamaas beside the contact crate on a self-affine random surface (issue 14): the same surface,
# written to .npy by `saddleflow surface generate` (H = 0.8, q_r = 2, q_s = 64, rms slope 1,
# exact amplitudes, seed 1, L = 1), the same hard-wall load (RANDOM_LOAD × p_fc), one run:
# contact area and CPU time of both, and their ratio.
#
#   bench/peers/random.sh                  # 1024², load 0.05 p_fc
#   RANDOM_N=9 RANDOM_LOAD=0.1 bench/peers/random.sh
#
# Needs the saddleflow binary (`just build`) and a venv with numpy and tamaas 2.9
# (bench/peers/setup-venv.sh). Output in bench/out/random/ (not committed). Both single-threaded
# (RANDOM_THREADS=1, OMP_NUM_THREADS=1); CPU seconds are the measure on a shared machine.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
py="${PYTHON:-$root/.venv-peers/bin/python}"
bin="${SADDLEFLOW:-${CARGO_TARGET_DIR:-$root/target}/release/saddleflow}"
e="${RANDOM_N:-10}"
load="${RANDOM_LOAD:-0.05}"
n=$((1 << e))
out="$root/bench/out/random"
mkdir -p "$out"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
echo "== the surface, $n²: $out/surface_n$n.npy"
"$bin" surface generate --n "$e" --hurst 0.8 --qr 2 --qs 64 --rms-slope 1 --seed 1 \
  --out "$out/surface_n$n.npy" > "$out/surface_n$n.json"
echo "== ours: cargo bench -p contact --bench random_surface (1 thread)"
RANDOM_NS="$e" RANDOM_LOAD="$load" RANDOM_THREADS=1 RANDOM_DUMP="$out" \
  cargo bench -q -p contact --bench random_surface 2>"$out/bench.err" | tee "$out/ours.log" \
  || { cat "$out/bench.err" >&2; exit 1; }
ours_cpu="$(sed -n 's/^RESULT .* cpu_s=\([0-9.]*\).*/\1/p' "$out/ours.log" | tail -1)"
echo "== tamaas"
RANDOM_OURS_CPU="$ours_cpu" "$py" "$root/bench/peers/random_peers.py" "$out" "$n" | tee "$out/peers.log"
