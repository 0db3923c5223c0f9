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
peer dask distributed numpy
peer drake drake numpy scipy
peer movement_primitives movement-primitives pytransform3d scipy numpy
peer toppra toppra numpy
# qpmpc: the ZMP MPC of the locomotion suite posed as a qpmpc MPCProblem, solved by ProxQP
peer qpmpc "qpmpc==3.3.0" qpsolvers proxsuite numpy
command -v apt-get >/dev/null && { dpkg -s liblapack3 >/dev/null 2>&1 || apt-get install -y -qq liblapack3 >/dev/null; } || true
peer robotic robotic numpy
# OMPL drives taskspace's own collision checker (same Pinocchio/coal as taskspace's .venv)
peer ompl ompl numpy scipy pin==4.1.0 coal==3.0.3 example-robot-data==5.0.0 example-robot-data-loaders==5.0.0 pyyaml
peer pyroboplan pyroboplan numpy pyyaml example-robot-data==5.0.0 example-robot-data-loaders==5.0.0
# TSID: the 1.10.0 wheel (pin 4.1.0) raises MemoryError in RobotWrapper and aborts with
# "free(): invalid pointer"; 1.9.0 does not install. The 1.7.1 wheel works with pin 3.4.0 and
# the urdfdom/tinyxml2 libraries it was linked against (its extension sits one directory down;
# the peer script imports it from there). The robot files are example-robot-data 5.0.0, as in
# taskspace's .venv (installed without dependencies: it would pull a newer pin).
peer tsid "tsid==1.7.1" "pin==3.4.0" "cmeel-urdfdom<5" "cmeel-tinyxml2<11" numpy
".venv-peers/tsid/bin/pip" install --quiet --no-deps "example-robot-data==5.0.0" || echo "!! tsid robot data"
# Stable-Baselines3 PPO and MuJoCo's Reacher (benchmarks/peers/sb3_ppo.py, mujoco_reacher.py):
# CPU torch from a local wheel when the machine has one (the PyTorch index may be unreachable);
# the peer scripts import taskspace from the checkout's src/, so its run-time dependencies too.
torch_wheel=$(ls /opt/wheels/torch-*+cpu-cp3*-manylinux*_x86_64.whl 2>/dev/null | head -1 || true)
peer sb3 ${torch_wheel:-torch} stable-baselines3 "gymnasium==1.4.0" mujoco imageio packaging \
    "pin==4.1.0" "coal==3.0.3" proxsuite qpsolvers osqp daqp quadprog scipy \
    "example-robot-data==5.0.0" "example-robot-data-loaders==5.0.0" pyyaml tqdm cma
# VAMP (benchmarks/peers/vamp_planning.py): PyPI has only the source of vamp-planner, whose build
# downloads header libraries from GitHub (CPM.cmake, nigh, pdqsort, SIMDxorshift) that no package
# registry serves, so this script does not build it: benchmarks/peers/build_vamp.sh does, from the
# sdist and git copies of those sources (see its header). An environment .venv-peers/vamp in which
# `import vamp` works is completed with the peer script's dependencies; without one the planning
# suite prints that VAMP was skipped.
if [ -x .venv-peers/vamp/bin/python ] && .venv-peers/vamp/bin/python -c "import vamp" 2>/dev/null; then
  peer vamp numpy scipy pin==4.1.0 coal==3.0.3 example-robot-data==5.0.0 example-robot-data-loaders==5.0.0 pyyaml
else
  echo "!! vamp is not installed: build it with benchmarks/peers/build_vamp.sh (needs git copies of the GitHub-only sources of CPM.cmake, nigh, pdqsort, SIMDxorshift, nanobind, robin-map), then run this script again"
fi
