#!/usr/bin/env bash
# Creates (if missing) and completes the peers' venv .venv-peers used by bench/peers/contact.sh and
# bench/peers/flow.sh: numpy, scipy, tamaas 2.9, ContactMechanics, pyamg. Idempotent: an existing
# venv is kept and only what is missing is installed (pip skips satisfied requirements).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
venv="${PEERS_VENV:-$root/.venv-peers}"
if [ ! -x "$venv/bin/python" ]; then
  echo "creating $venv"
  python3 -m venv "$venv"
fi
py="$venv/bin/python"
# tamaas 2.9 ships manylinux wheels with its own FFTW/OpenMP; ContactMechanics is pure Python on
# top of muFFT (pulled in as a dependency).
want=(numpy scipy "tamaas>=2.9,<2.10" ContactMechanics pyamg)
if "$py" - <<'PY' 2>/dev/null
import importlib.metadata as m, sys
need = {"numpy": None, "scipy": None, "tamaas": "2.9", "ContactMechanics": None, "pyamg": None}
for name, prefix in need.items():
    v = m.version(name)
    if prefix and not v.startswith(prefix):
        sys.exit(1)
PY
then
  echo "$venv: numpy, scipy, tamaas 2.9, ContactMechanics, pyamg present"
else
  "$py" -m pip install --disable-pip-version-check -q "${want[@]}"
fi
"$py" - <<'PY'
import importlib.metadata as m
for name in ["numpy", "scipy", "tamaas", "ContactMechanics", "muFFT", "pyamg"]:
    try:
        print(f"  {name} {m.version(name)}")
    except m.PackageNotFoundError:
        print(f"  {name} (missing)")
PY
