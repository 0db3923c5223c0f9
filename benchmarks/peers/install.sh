#!/usr/bin/env bash
# Creates one virtual environment per peer library in .venv-peers/<peer> (they pin other
# Pinocchio versions than taskspace, so they never share taskspace's .venv).
set -euo pipefail
cd "$(dirname "$0")/../.."
PY=${PYTHON:-python3}
mkdir -p .venv-peers

peer() {  # peer NAME PACKAGES...
  local name=$1; shift
  if [ ! -x ".venv-peers/$name/bin/python" ]; then
    "$PY" -m venv ".venv-peers/$name"
  fi
  echo "== $name: $*"
  ".venv-peers/$name/bin/pip" install --quiet "$@" || echo "!! $name could not be installed"
}

peer pink pin-pink daqp proxsuite qpsolvers example-robot-data example-robot-data-loaders numpy
peer placo placo example-robot-data numpy
