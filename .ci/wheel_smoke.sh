#!/usr/bin/env bash
# The installed package, not the checkout (make wheel-smoke, part of make test):
#   1. `pip wheel` builds taskspace (kernels built by CMakeLists.txt) with the build venv, in a
#      build directory of its own that starts with the editable build's object files (below);
#   2. a fresh virtual environment installs the wheel, constrained to the pin, coal, eigenpy,
#      Boost and NumPy versions of the build venv (the kernels refuse other versions);
#   3. from a temporary directory outside the checkout: `taskspace info` must report both
#      kernels in use, then the README's quick example and a smoke subset of the tests run
#      against the installed copy (a copy of tests/ and README.md; no source tree on the path).
# Usage: .ci/wheel_smoke.sh BUILD_VENV TEST_FILE...
set -euo pipefail
cd "$(dirname "$0")/.."
checkout=$(pwd)
build_venv="$1"
build_py="$build_venv/bin/python"
shift
python=${PYTHON:-python3}
work=$(mktemp -d "${TMPDIR:-/tmp}/taskspace-wheel-smoke.XXXXXX")
trap 'rm -rf "$work"' EXIT
t0=$(date +%s)

echo "wheel-smoke: building the wheel"
# Portable code whatever NATIVE_ARCH says, in a build directory of its own ($work/build:
# configured, linked and installed by CMake for this wheel). The editable build (build/<tag>)
# made with make's default NATIVE_ARCH=0 ran the same compile commands on the same sources:
# its object files are copied in with ninja's records of them (.ninja_log: a hash of the
# command that made each object; .ninja_deps: every header it read). Ninja then recompiles
# exactly the objects whose command, source or headers differ (all of them when the flags
# differ, as with NATIVE_ARCH=1), as for any incremental build; the rest are not compiled twice.
tag=$("$build_py" -c 'import sys, sysconfig
v = "%d%d" % sys.version_info[:2]
print(f"cp{v}-cp{v}-" + sysconfig.get_platform().replace("-", "_").replace(".", "_"))')
seed="build/$tag"
objects=()
if [ -f "$seed/.ninja_log" ] && [ -f "$seed/.ninja_deps" ]; then
    mkdir "$work/build"
    # under the lock of the editable rebuild on import, so that no object is copied half-written
    lock=()
    command -v flock >/dev/null 2>&1 && lock=(flock "$seed/editable_rebuild.lock")
    "${lock[@]}" bash -c 'cd "$1" && cp -p .ninja_log .ninja_deps "$2/" &&
        find CMakeFiles -name "*.o" -exec cp -p --parents -t "$2/" {} +' _ "$seed" "$work/build"
    mapfile -t objects < <(cd "$work/build" && find CMakeFiles -name "*.o" | sort)
fi
"$build_py" -m pip wheel --quiet --no-build-isolation --no-deps --wheel-dir "$work/dist" \
    -Ccmake.define.TASKSPACE_NATIVE_ARCH=OFF -Cbuild-dir="$work/build" "$checkout"
reused=0
for o in "${objects[@]}"; do  # a recompiled object has a new time stamp
    [ "$(stat -c %y "$seed/$o")" = "$(stat -c %y "$work/build/$o")" ] && reused=$((reused + 1))
done
echo "wheel-smoke: wheel built in $(($(date +%s) - t0)) s; $reused of ${#objects[@]} object files" \
    "taken from $seed (same compile commands)"
wheel=$(ls "$work"/dist/taskspace-*.whl)
"$build_py" - "$wheel" <<'EOF'
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
kernels = [n for n in names if n.startswith("taskspace/_native/_") and n.endswith(".so")]
assert len(kernels) == 3 and "taskspace/_native/_build_info.json" in names, names
assert not [n for n in names if n.endswith((".cpp", "build.py"))], "C++ sources in the wheel"
assert "taskspace/examples/demo_main.py" in names, "examples/ missing from the wheel"
assert not [n for n in names if "__pycache__" in n], "bytecode caches in the wheel"
EOF
"$build_py" -m pip freeze --all \
    | grep -iE '^(pin|libpinocchio|coal|libcoal|eigenpy|cmeel-boost|numpy)==' >"$work/constraints.txt"

echo "wheel-smoke: installing $(basename "$wheel") into a fresh virtual environment"
"$python" -m venv "$work/venv"
# uv (installed into the build venv by make) when there: the same resolution as pip, faster
if [ -x "$build_venv/bin/uv" ]; then
    install=("$build_venv/bin/uv" pip install --quiet --python "$work/venv/bin/python")
else
    "$work/venv/bin/python" -m pip install --quiet --upgrade pip
    install=("$work/venv/bin/python" -m pip install --quiet)
fi
# First the core dependencies only (no extras): every module but the viewer stack imports,
# the algorithms run, and taskspace.viz says which extra to install.
"${install[@]}" -c "$work/constraints.txt" "$wheel"
(cd "$work" && "$work/venv/bin/python" - <<'EOF'
import importlib, pkgutil
import taskspace
from taskspace import MissingDependencyError
skipped = ("taskspace.viz", "taskspace.cli", "taskspace.__main__", "taskspace.examples")
names = [m.name for m in pkgutil.walk_packages(taskspace.__path__, "taskspace.")
         if not m.name.startswith(skipped)]
for name in names:
    importlib.import_module(name)
from taskspace.features import Position
from taskspace.ik import solve_ik
from taskspace.model import Robot
from taskspace.tasks import Task
robot = Robot.load("panda")
goal = robot.frame_placement(robot.q_default, "panda_hand_tcp").translation + [0.0, 0.1, 0.0]
assert solve_ik(robot, [Task(Position(robot, "panda_hand_tcp"), goal)]).success
try:
    import taskspace.viz  # noqa: F401
except MissingDependencyError as error:
    assert "taskspace[viz]" in str(error), error
else:
    raise AssertionError("taskspace.viz imported without the viz extra")
print(f"wheel-smoke: core install: {len(names)} modules import, IK solves, viz asks for its extra")
EOF
)
"${install[@]}" -c "$work/constraints.txt" "$wheel[test]"

mkdir "$work/run"
cp -r tests README.md "$work/run/"
cp pyproject.toml "$work/run/"  # pytest's settings (markers, warning filters) only
cd "$work/run"
"$work/venv/bin/python" - <<'EOF'
import taskspace, pathlib, sys
where = pathlib.Path(taskspace.__file__).resolve()
assert pathlib.Path(sys.prefix).resolve() in where.parents, f"taskspace imported from {where}"
print(f"wheel-smoke: taskspace {taskspace.__version__} from {where.parent}")
EOF
"$work/venv/bin/taskspace" info | tee "$work/info.txt"
if grep -q "not in use" "$work/info.txt"; then
    echo "wheel-smoke: a compiled kernel does not load from the wheel" >&2
    exit 1
fi
# The examples come with the wheel: `taskspace demo` runs them from the installed copy.
# (into a file first: `| grep -q` closed the pipe at the first line and the listing failed
# with "Broken pipe" whenever it was still writing, a race that failed a smoke run)
"$work/venv/bin/taskspace" demo list >"$work/demos.txt"
grep -q "^ *main" "$work/demos.txt" || { echo "wheel-smoke: no demos" >&2; exit 1; }
MPLBACKEND=Agg "$work/venv/bin/taskspace" demo bug_paths --no-viewer --png bug_paths.png
test -s bug_paths.png || { echo "wheel-smoke: demo wrote no picture" >&2; exit 1; }
TASKSPACE_REQUIRE_NATIVE=1 OPENBLAS_NUM_THREADS=1 "$work/venv/bin/python" -m pytest -q \
    -p no:cacheprovider "$@"
echo "wheel-smoke: passed in $(($(date +%s) - t0)) s"
