#!/usr/bin/env bash
# Side-by-side hard-wall contact benchmark: the contact crate (Polonsky-Keer, 1 and 2 threads),
# tamaas 2.9 (PolonskyKeerRey, single-threaded) and ContactMechanics on the same problems (square
# model sampled on the same grid, p = 0.3 p_fc), judged by one accuracy metric (see
# contact_peers.py), in one run, interleaved per grid size, with CPU-time ratios.
#
#   bench/peers/contact.sh                     # n = 2^8 ... 2^11
#   CONTACT_NS=9,10 bench/peers/contact.sh
#
# Needs the venv made by bench/peers/setup-venv.sh. Fields go to bench/out/contact/ (not
# committed). The machine may be shared: CPU seconds are the measure to trust, wall is printed too.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
py="${PYTHON:-$root/.venv-peers/bin/python}"
out="$root/bench/out/contact"
mkdir -p "$out"
log="$out/run.log"
: > "$log"
IFS=, read -r -a ns <<< "${CONTACT_NS:-8,9,10,11}"
# The peers single-threaded: tamaas parallelises with OpenMP, numpy/scipy with BLAS threads.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
echo "== peers: $("$py" -c 'import importlib.metadata as m; print("tamaas", m.version("tamaas"), "| ContactMechanics", m.version("ContactMechanics"))')"
for e in "${ns[@]}"; do
  size=$((1 << e))
  echo "== n = $size: contact crate (cargo bench -p contact --bench hardwall, 1 and 2 threads)"
  HARDWALL_NS="$e" HARDWALL_FIRE= HARDWALL_DUMP="$out" \
    cargo bench -q -p contact --bench hardwall 2>"$out/bench.err" | tee -a "$log" | grep -v '^RESULT' \
    || { cat "$out/bench.err" >&2; exit 1; }
  echo "== n = $size: peers"
  "$py" "$root/bench/peers/contact_peers.py" "$out" "$size" | tee -a "$log" | grep -v '^RESULT'
done
echo
echo "== summary: CPU seconds (wall in the RESULT lines of $log), iterations, violation (one metric"
echo "   for all, from each pressure field: max |gap| where p > 0, max penetration elsewhere);"
echo "   ratios = peer CPU / ours CPU (> 1: ours is faster)"
python3 - "$log" <<'PY'
import sys, collections
rows = collections.defaultdict(dict)
for line in open(sys.argv[1]):
    if line.startswith("RESULT "):
        r = dict(kv.split("=", 1) for kv in line.split()[1:])
        if r["solver"] == "pk":
            rows[int(r["n"])][f"ours{r['threads']}"] = r
        else:
            rows[int(r["n"])][r["solver"]] = r
def cell(r, metric=True):
    if r is None:
        return f"{'-':>8} {'-':>5} {'-':>9}"
    v = r.get("violation", "-")
    return f"{float(r['cpu_s']):>8.3f} {r['iterations']:>5} {v:>9}"
hdr = (f"{'n':>5} | {'ours 1t: cpu':>14} {'it':>5} {'viol':>9} | {'ours 2t: cpu':>14} {'it':>5} {'viol':>9} | "
       f"{'tamaas: cpu':>14} {'it':>5} {'viol':>9} | {'CM: cpu':>14} {'it':>5} {'viol':>9} | "
       f"{'tam/1t':>7} {'tam/2t':>7} {'CM/1t':>7} {'CM/2t':>7}")
print(hdr)
for n in sorted(rows):
    d = rows[n]
    o1, o2, tm, cm = d.get("ours1"), d.get("ours2"), d.get("tamaas"), d.get("contactmechanics")
    # Our violation by the common metric (same for 1 and 2 threads: results are bit-identical).
    om = d.get("ours-metric")
    for o in (o1, o2):
        if o and om:
            o["violation"] = om["violation"]
    ratio = lambda a, b: f"{float(a['cpu_s']) / float(b['cpu_s']):>7.1f}" if a and b else f"{'-':>7}"
    note = lambda r: "" if r is None or r.get("reached", "True") == "True" else " (target not reached)"
    print(f"{n:>5} | {'':>6}{cell(o1)} | {'':>6}{cell(o2)} | {'':>6}{cell(tm)} | {'':>6}{cell(cm)} | "
          f"{ratio(tm, o1)} {ratio(tm, o2)} {ratio(cm, o1)} {ratio(cm, o2)}{note(tm)}{note(cm)}")
PY
