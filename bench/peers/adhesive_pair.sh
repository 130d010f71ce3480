#!/usr/bin/env bash
# Before/after comparison of two builds of the contact crate's adhesive bench against tamaas 2.9
# (the README's "Adhesive solver" table, side by side): tamaas once per grid and mean gap (as
# bench/peers/adhesive.sh), then our cold and warm solves at tamaas's load by the BEFORE and
# AFTER bench binaries alternately, ADHESIVE_PAIR_REPS times each (default 3), to residual
# 1e-10 and to the residual tamaas reached; the smallest CPU time of each is reported
# (adhesive_peers.py pairs), with iterations, CPU per iteration and the ratios. FIRE runs once
# beside AFTER (ADHESIVE_PEER_FIRE= to skip it). The bench binaries are what
# `cargo bench -p contact --bench adhesive --no-run` prints (copy the before-one away first).
#
#   BEFORE=/tmp/adhesive-before-bench AFTER=target/release/deps/adhesive-<hash> \
#     ADHESIVE_PEER_NS=8,9 bench/peers/adhesive_pair.sh
#
# Needs the venv of bench/peers/setup-venv.sh. Fields and logs go to bench/out/adhesive_pair/.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
py="${PYTHON:-$root/.venv-peers/bin/python}"
: "${BEFORE:?BEFORE=path of the before-build's adhesive bench binary}"
: "${AFTER:?AFTER=path of the after-build's adhesive bench binary}"
out="$root/bench/out/adhesive_pair"
IFS=, read -r -a gaps <<< "${ADHESIVE_PEER_GAPS:-0.3,0.5,0.8}"
IFS=, read -r -a ns <<< "${ADHESIVE_PEER_NS:-8,9}"
reps="${ADHESIVE_PAIR_REPS:-3}"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
mkdir -p "$out"
log="$out/pairs.txt"
: > "$log"
for e in "${ns[@]}"; do
 size=$((1 << e))
 for gap in "${gaps[@]}"; do
  d="$out/n${size}_g$gap"
  mkdir -p "$d"
  ADHESIVE_NS="$e" ADHESIVE_FIRE= ADHESIVE_DUMP="$d" ADHESIVE_TOL=1e-3 "$BEFORE" >/dev/null
  echo "== n = $size, mean gap $gap: tamaas ($(uptime | sed 's/.*load/load/'))"
  read -r p res < <(cd "$root/bench/peers" && "$py" adhesive_peers.py tamaas "$d" "$size" "$gap")
  cp "$d/tamaas_n$size.json" "$out/tamaas_n${size}_g$gap.json"
  for r in $(seq "$reps"); do
   for who in before after; do
    bin="$BEFORE"; [ "$who" = after ] && bin="$AFTER"
    fire=; [ "$who" = after ] && [ "$r" = 1 ] && fire="${ADHESIVE_PEER_FIRE-$e}"
    ADHESIVE_NS="$e" ADHESIVE_FIRE="$fire" ADHESIVE_PRESSURE="$p" ADHESIVE_DUMP="$d" \
      ADHESIVE_TOL="1e-10,$res" "$bin" | grep '^RESULT' | sed "s/^RESULT/PAIR who=$who gap=$gap rep=$r/" >> "$log"
   done
  done
  # the metric of the last (after-) cold solve against tamaas's gap field
  (cd "$root/bench/peers" && "$py" adhesive_peers.py metric "$d" "$size")
 done
done
echo "== done ($(uptime | sed 's/.*load/load/'))"
(cd "$root/bench/peers" && "$py" adhesive_peers.py pairs "$out" "$log")
