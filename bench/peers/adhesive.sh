#!/usr/bin/env bash
# Side-by-side adhesive contact benchmark: tamaas 2.9's gap-primal solver at mean gaps 0.3, 0.5, 0.8 (its
# tolerance 1e-10), then the contact crate (nonlinear CG and FIRE, cargo bench -p contact --bench
# adhesive) at the mean pressure tamaas found, judged by one metric computed by one routine
# from each code's gap field (adhesive_peers.py: force residual as our residuals(), mean gap,
# area). Square model, γ0 = 0.2, ρ = 0.04. Ours solves twice: to residual 1e-10 (tighter than
# tamaas, whose own 1e-10 stops at 0.3–2e-9 by the common metric) and to the residual tamaas
# reached (equal accuracy). Both codes single-threaded (CPU seconds).
#
#   bench/peers/adhesive.sh                 # n = 2^8, 2^9
#   ADHESIVE_PEER_NS=8 ADHESIVE_PEER_GAPS=0.5 bench/peers/adhesive.sh
#   ADHESIVE_PEER_NS=10 ADHESIVE_PEER_FIRE= bench/peers/adhesive.sh   # without FIRE
#
# At mean gap 0.5 (p = 0.84, where patches coalesce) a cold start has two minima; our nonlinear
# CG may reach the other one (see crates/contact/src/nonlinear_cg.rs), the metric lines show it.
#
# Needs the venv made by bench/peers/setup-venv.sh. Fields go to bench/out/adhesive/ (not
# committed). CPU seconds are the measure to trust on a shared machine.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
py="${PYTHON:-$root/.venv-peers/bin/python}"
out="$root/bench/out/adhesive"
mkdir -p "$out"
IFS=, read -r -a gaps <<< "${ADHESIVE_PEER_GAPS:-0.3,0.5,0.8}"
IFS=, read -r -a ns <<< "${ADHESIVE_PEER_NS:-8,9}"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
for e in "${ns[@]}"; do
 for gap in "${gaps[@]}"; do
  size=$((1 << e))
  echo "== n = $size: heights (contact crate)"
  ADHESIVE_NS="$e" ADHESIVE_FIRE= ADHESIVE_DUMP="$out" cargo bench -q -p contact --bench adhesive >/dev/null
  echo "== n = $size: tamaas at mean gap $gap"
  read -r p res < <(cd bench/peers && "$py" adhesive_peers.py tamaas "$out" "$size" "$gap")
  echo "== n = $size: contact crate at p = $p, to residual 1e-10 and to $res (tamaas's, common metric)"
  ADHESIVE_NS="$e" ADHESIVE_FIRE="${ADHESIVE_PEER_FIRE-$e}" ADHESIVE_PRESSURE="$p" ADHESIVE_DUMP="$out" ADHESIVE_TOL="1e-10,$res" \
    cargo bench -q -p contact --bench adhesive | tee "$out/ours_n$size.txt" | grep -v '^RESULT'
  echo "== n = $size: one metric from each gap field (ours = the cold nonlinear-CG solve), CPU ratios"
  (cd bench/peers && "$py" adhesive_peers.py metric "$out" "$size" "$out/ours_n$size.txt")
 done
done
