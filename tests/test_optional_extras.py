"""The extras of ``pip install "taskspace[...]"``: without them, one clear error.

The wheel smoke test (``.ci/wheel_smoke.sh``) installs the wheel without extras and checks that
every other module imports and IK runs; here the missing packages are simulated by an import
blocker in a subprocess (the test environment has every extra).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from taskspace import MissingDependencyError
from taskspace._validation import EXTRAS, missing_modules, require_extra

BLOCK = """
import sys
class Blocker:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {blocked!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}")
        return None
sys.meta_path.insert(0, Blocker())
import importlib.util
real = importlib.util.find_spec
importlib.util.find_spec = lambda n, *a: None if n.split(".")[0] in {blocked!r} else real(n, *a)
"""


def run_blocked(blocked: set[str], code: str) -> subprocess.CompletedProcess[str]:
    program = BLOCK.format(blocked=blocked) + textwrap.dedent(code)
    return subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, timeout=120
    )


def test_every_extra_is_installed_here():
    for extra in EXTRAS:
        assert missing_modules(extra) == (), extra


def test_unknown_extra_lists_the_valid_ones():
    with pytest.raises(KeyError, match="extras are"):
        require_extra("gui", "x")


def test_error_names_the_packages_and_the_install_command():
    error = MissingDependencyError("taskspace.viz", "viz", ["meshcat", "PIL"])
    assert isinstance(error, ImportError)
    assert str(error) == (
        'taskspace.viz needs meshcat, PIL (not installed): pip install "taskspace[viz]" '
        '(or "taskspace[all]")'
    )


@pytest.mark.slow  # two interpreters importing taskspace (a few seconds)
def test_viz_without_meshcat_asks_for_the_viz_extra_and_the_rest_works():
    proc = run_blocked(
        {"meshcat", "matplotlib"},
        """
        from taskspace import MissingDependencyError
        from taskspace.model import Robot
        robot = Robot.load("ur5")
        try:
            from taskspace.viz import Viewer
        except MissingDependencyError as error:
            print("ERROR", error)
        """,
    )
    assert proc.returncode == 0, proc.stderr
    expected = "ERROR taskspace.viz needs meshcat, matplotlib (not installed): pip install"
    assert f'{expected} "taskspace[viz]"' in proc.stdout


@pytest.mark.slow
def test_rendering_an_env_without_matplotlib_asks_for_the_viz_extra():
    proc = run_blocked(
        {"matplotlib"},
        """
        from taskspace import MissingDependencyError
        from taskspace.learning.envs.pendulum import PendulumEnv
        PendulumEnv()  # no rendering: fine
        try:
            PendulumEnv(render_mode="rgb_array")
        except MissingDependencyError as error:
            print("ERROR", error.extra, error.modules)
        """,
    )
    assert proc.returncode == 0, proc.stderr
    assert "ERROR viz ('matplotlib',)" in proc.stdout
