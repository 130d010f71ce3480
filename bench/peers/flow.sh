#!/usr/bin/env bash
# Side-by-side flow benchmark: the reynolds crate and PyAMG (smoothed aggregation and
# Ruge-Stueben preconditioned CG) on the same gap fields, in one run, with the time ratios.
#
#   bench/peers/flow.sh            # 2048², eps = 1e-3 (the issue's target case)
#   FLOW_NS=9,10,11 FLOW_EPS=1e-3,1e-6 bench/peers/flow.sh
#
# Needs the venv .venv-peers (python3 -m venv .venv-peers && .venv-peers/bin/pip install
# pyamg numpy scipy). Fields are written to bench/out/flow/ (not committed).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
py="${PYTHON:-$root/.venv-peers/bin/python}"
out="$root/bench/out/flow"
mkdir -p "$out"
export FLOW_NS="${FLOW_NS:-11}" FLOW_EPS="${FLOW_EPS:-1e-3}" FLOW_THREADS="${FLOW_THREADS:-1,2}"
log="$out/run.log"
: > "$log"
echo "== reynolds (cargo bench -p reynolds --bench flow): n=2^{$FLOW_NS}, eps={$FLOW_EPS}, threads={$FLOW_THREADS}"
FLOW_DUMP="$out" cargo bench -q -p reynolds --bench flow 2>"$out/bench.err" | tee -a "$log" | grep -v '^RESULT' \
  || { cat "$out/bench.err" >&2; exit 1; }
mapfile -t files < <(sed -n 's/^wrote //p' "$out/bench.err")
# PyAMG is single-threaded (scipy sparse); keep BLAS from spinning extra threads on 2 cores.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
echo "== PyAMG ($("$py" -c 'import pyamg; print(pyamg.__version__)'))"
"$py" "$root/bench/peers/flow_pyamg.py" "${files[@]}" | tee -a "$log" | grep -v '^RESULT'
echo "== ratios: PyAMG time / reynolds time (> 1: reynolds is faster), wall clock and CPU"
echo "   (PyAMG: its set-up + solve, without assembling the matrix; reynolds: everything, from the"
echo "   gap field to the checked flux. On a loaded machine trust CPU more than wall.)"
python3 - "$log" <<'PY'
import sys, collections
rows = []
for line in open(sys.argv[1]):
    if line.startswith("RESULT "):
        rows.append(dict(kv.split("=", 1) for kv in line.split()[1:]))
key = lambda r: (int(r["n"]), float(r["eps"]))
ours = collections.defaultdict(dict)
peers = collections.defaultdict(dict)
for r in rows:
    if r["solver"] == "reynolds":
        ours[key(r)][int(r["threads"])] = r
    else:
        peers[key(r)][r["solver"]] = r
threads = sorted({t for d in ours.values() for t in d})
head = f"{'n':>5} {'eps':>7} {'peer':>12} {'wall_s':>7} {'cpu_s':>7} {'it':>3} |"
for t in threads:
    head += f" {'ours' + str(t) + 't_wall':>12} {'ratio':>6} {'cpu_s':>6} {'ratio':>6} |"
print(head + f" {'ours_it':>7} {'dK/K':>8}")
for k in sorted(peers):
    o = ours.get(k, {})
    for name, p in sorted(peers[k].items()):
        line = (f"{k[0]:>5} {k[1]:>7.0e} {name:>12} {float(p['wall_s']):>7.2f} "
                f"{float(p['cpu_s']):>7.2f} {p['iterations']:>3} |")
        for t in threads:
            if t in o:
                w, c = float(o[t]["wall_s"]), float(o[t]["cpu_s"])
                line += (f" {w:>12.3f} {float(p['wall_s']) / w:>6.2f} {c:>6.2f} "
                         f"{float(p['cpu_s']) / max(c, 1e-9):>6.2f} |")
            else:
                line += f" {'-':>12} {'-':>6} {'-':>6} {'-':>6} |"
        any_o = next(iter(o.values()), None)
        dk = abs(float(p["flux"]) / float(any_o["flux"]) - 1) if any_o else float("nan")
        print(line + f" {any_o['iterations'] if any_o else '-':>7} {dk:>8.1e}")
PY
