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
peer filterpy filterpy numpy
peer toppra toppra numpy
command -v apt-get >/dev/null && { dpkg -s liblapack3 >/dev/null 2>&1 || apt-get install -y -qq liblapack3 >/dev/null; } || true
peer robotic robotic numpy
# OMPL drives taskspace's own collision checker (same Pinocchio/coal as taskspace's .venv)
peer ompl ompl numpy scipy pin==4.1.0 coal==3.0.3 example-robot-data==5.0.0 example-robot-data-loaders==5.0.0 pyyaml
peer pyroboplan pyroboplan numpy pyyaml example-robot-data==5.0.0 example-robot-data-loaders==5.0.0
# TSID: no PyPI build runs here (1.10.0 + pin 4.1.0: MemoryError in RobotWrapper; 1.9.0 does
# not install; 1.7.1 imports empty). The suite reports the published number instead.
peer tsid tsid example-robot-data example-robot-data-loaders numpy
