"""An SRDF posture whose root joint has 7 values, on a robot loaded with another base.

Pinocchio printed "Could not read joint config (root_joint ...)" (from C++, on file descriptor
2) for talos, solo12, go1, icub and bolt loaded with ``base="planar"``, and dropped the base
pose. Reference: the same robot loaded with its free flyer, whose SRDF posture Pinocchio reads
itself; the planar root gets the position and the yaw of the free flyer's quaternion (through
a rotation matrix here, not the formula of the library).
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
import tempfile
import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Robot

ROBOTS = ["talos", "solo12", "go1", "icub", "bolt"]


def _load_capturing_output(name: str, base: str | None) -> tuple[Robot, str]:
    """Load the robot; return it and what was written on file descriptors 1 and 2 meanwhile."""
    libc = ctypes.CDLL(None)
    with tempfile.TemporaryFile() as out:
        sys.stdout.flush()
        sys.stderr.flush()
        libc.fflush(None)
        saved = [os.dup(1), os.dup(2)]
        os.dup2(out.fileno(), 1)
        os.dup2(out.fileno(), 2)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                robot = Robot.load(name, base=base, geometry=False)
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            libc.fflush(None)
            for fd, copy in zip((1, 2), saved):
                os.dup2(copy, fd)
                os.close(copy)
        out.seek(0)
        return robot, out.read().decode(errors="replace")


@pytest.mark.parametrize("name", ROBOTS)
def test_srdf_root_posture_on_planar_and_fixed_bases(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        q_ff = Robot.load(name, geometry=False).q_default
    for base in ("planar", "fixed"):
        robot, printed = _load_capturing_output(name, base)
        assert printed == "", printed
        q = robot.q_default
        if base == "fixed":
            np.testing.assert_array_equal(q, q_ff[7:])
        else:
            np.testing.assert_array_equal(q[4:], q_ff[7:])
            R = pin.Quaternion(np.asarray(q_ff[3:7])).toRotationMatrix()
            yaw = math.atan2(R[1, 0], R[0, 0])
            expected = [q_ff[0], q_ff[1], math.cos(yaw), math.sin(yaw)]
            np.testing.assert_allclose(q[:4], expected, atol=1e-12)
