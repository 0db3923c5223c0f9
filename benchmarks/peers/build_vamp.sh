#!/usr/bin/env bash
# Builds vamp-planner 0.6.4 into .venv-peers/vamp without network access to GitHub/GitLab.
# Needs: the sdist (pip download --no-deps --no-binary :all: vamp-planner==0.6.4), and bare/mirror git
# repositories of its header dependencies in $MIRRORS/<owner>+<name>/repo (or any git dir containing
# the pinned commits): cpm-cmake+CPM.cmake KavrakiLab+nigh orlp+pdqsort lemire+SIMDxorshift
# wjakob+nanobind Tessil+robin-map. The build is -march=native (VAMP's design): not portable.
set -euo pipefail
cd "$(dirname "$0")/../.."
SDIST=${1:?usage: build_vamp.sh SDIST MIRRORS}; MIRRORS=${2:?}
WORK=$(mktemp -d /tmp/vamp-build.XXXX); D=$WORK/deps; PY=${PYTHON:-python3}
mkdir -p $D/{nigh,pdqsort,SIMDxorshift,nanobind/ext/robin_map,cpm}
x() { git -C "$MIRRORS/$1/repo" archive "$2" "${@:4}" | tar -x -C "$3"; }
x KavrakiLab+nigh     97130999440647c204e0265d05a997dbd8da4e70 $D/nigh src LICENSE
x orlp+pdqsort        b1ef26a55cdb60d236a5cb199c4234c704f46726 $D/pdqsort
x lemire+SIMDxorshift 857c1a01df53cf1ee1ae8db3238f0ef42ef8e490 $D/SIMDxorshift
x wjakob+nanobind     9a25aed8a7edfe60ef9ad1c911e57667bc4916c4 $D/nanobind
x Tessil+robin-map    4ec1bf19c6a96125ea22062f38c2cf5b958e448e $D/nanobind/ext/robin_map
git -C "$MIRRORS/cpm-cmake+CPM.cmake/repo" show v0.40.1:cmake/CPM.cmake \
  | sed 's/1.0.0-development-version/0.40.1/' > $D/cpm/CPM.cmake
echo "117cbf2711572f113bab262933eb5187b08cfc06dce0714a1ee94f2183ddc3ec  $D/cpm/CPM.cmake" | sha256sum -c -
tar xzf "$SDIST" -C $WORK; SRC=$(ls -d $WORK/vamp_planner-*)
printf 'set(CPM_USE_LOCAL_PACKAGES ON)\ninclude(%s)\n' "$D/cpm/CPM.cmake" > $SRC/cmake/FetchInitCPM.cmake
[ -x .venv-peers/vamp/bin/python ] || "$PY" -m venv .venv-peers/vamp
V=$PWD/.venv-peers/vamp
$V/bin/pip install --quiet scikit-build-core "nanobind>=2.0.0" typing_extensions numpy cmeel-eigen
EIGEN=$($V/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["platlib"])')/cmeel.prefix/share/eigen3/cmake
CMAKE_BUILD_PARALLEL_LEVEL=${JOBS:-2} $V/bin/pip install --no-build-isolation --no-deps "$SRC" \
  -C cmake.define.Eigen3_DIR="$EIGEN" \
  -C cmake.define.CPM_nigh_SOURCE=$D/nigh -C cmake.define.CPM_pdqsort_SOURCE=$D/pdqsort \
  -C cmake.define.CPM_SIMDxorshift_SOURCE=$D/SIMDxorshift -C cmake.define.CPM_nanobind_SOURCE=$D/nanobind \
  -C cmake.define.FETCHCONTENT_FULLY_DISCONNECTED=ON
$V/bin/python -c "import vamp; vamp.panda"
rm -rf "$WORK"
echo "vamp built; now run benchmarks/peers/install.sh (its last block adds the peer script's dependencies)"
