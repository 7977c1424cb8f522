#!/usr/bin/env bash
# Rust planner vs CVXPY + Clarabel on the same exact scheme (see compare.py).
# Creates the venv on first use (VENV, default /tmp/venv-cvx) and passes its arguments on.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="${VENV:-/tmp/venv-cvx}"
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import cvxpy, clarabel, numpy" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet cvxpy clarabel numpy
fi
exec "$venv/bin/python" "$here/compare.py" "$@"
