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
echo "== PyAMG ($("$py" -c 'import pyamg; print(pyamg.__version__)'))"
"$py" "$root/bench/peers/flow_pyamg.py" "${files[@]}" | tee -a "$log" | grep -v '^RESULT'
echo "== ratios (PyAMG wall time / reynolds wall time; > 1 means reynolds is faster)"
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
    (ours if r["solver"] == "reynolds" else peers)[key(r)][r["solver"] if r["solver"] != "reynolds" else int(r["threads"])] = r
print(f"{'n':>5} {'eps':>7} {'peer':>12} {'peer_s':>8} {'peer_it':>7} | " +
      " ".join(f"{'ours_'+str(t)+'t_s':>10} {'ratio':>6}" for t in sorted({t for d in ours.values() for t in d})) +
      f" {'ours_it':>7} {'dK/K':>8}")
for k in sorted(peers):
    for name, p in sorted(peers[k].items()):
        o = ours.get(k, {})
        cells = []
        for t in sorted({t for d in ours.values() for t in d}):
            if t in o:
                w = float(o[t]["wall_s"])
                cells.append(f"{w:>10.3f} {float(p['wall_s'])/w:>6.2f}")
            else:
                cells.append(f"{'-':>10} {'-':>6}")
        anyo = next(iter(o.values()), None)
        dk = abs(float(p["flux"]) / float(anyo["flux"]) - 1) if anyo else float("nan")
        print(f"{k[0]:>5} {k[1]:>7.0e} {name:>12} {float(p['wall_s']):>8.3f} {p['iterations']:>7} | "
              + " ".join(cells) + f" {anyo['iterations'] if anyo else '-':>7} {dk:>8.1e}")
PY
