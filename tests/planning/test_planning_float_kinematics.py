"""The sphere filter's single-precision kinematics (sphere_batch.hpp, SphereFilter::load_q).

The filter computes the joint placements of 4 configurations in float directly from q (the
kernel's double placements only when a lane reaches the exact test). References, independent
of the filter's code: Pinocchio's ``forwardKinematics`` in double, the bound stated in the
header of sphere_batch.hpp (u = 2^-24, joint at depth d of the chain): rotation within 21 d u
(Frobenius), translation within (35 d + 8) u S, sines and cosines within 2 u; and the kernel's
double-precision sphere test with the filter off (the trusted "spheres only" lanes give its
answers exactly).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from _mbm import ROOT, SKIP_REASON
from _sphere_reference import first_sphere_contacts, last_step_pairs

from taskspace._native import planning_kernel
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

pytestmark = [
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
    pytest.mark.skipif(planning_kernel() is None, reason="compiled planning kernel not built"),
]

U = 2.0**-24
SPHERES_ONLY = 2
OFF, TRUSTED = 0, 2


@pytest.fixture(scope="module")
def robot() -> Any:
    return motionbenchmaker_panda()


def _levels() -> list[int]:
    """The SIMD levels of this processor (the filter's builds: 1 SSE2, 2 AVX2 with FMA, 3
    AVX-512), each tested against the bound."""
    module = planning_kernel()
    return list(range(1, module.CollisionKernel.max_simd + 1)) if module is not None else [1]


LEVELS = _levels()


def _kernel(robot: Any, scenario: str, index: int, level: int = 0) -> tuple[Any, Any]:
    """The problem's request and a new sphere kernel, at SIMD level ``level`` (0: initial)."""
    req = motionbenchmaker_problems(ROOT, scenario, [index])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    kernel = space.checker.sphere_kernel()
    if level:
        kernel.set_simd(level)
        assert kernel.simd == level
    assert kernel.sphere_filter()
    return req, kernel


def _depths(model: Any) -> list[int]:
    depth = [0] * model.njoints
    for j in range(1, model.njoints):
        depth[j] = depth[model.parents[j]] + 1
    return depth


def _configurations(model: Any, rng: Any) -> np.ndarray:
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    random = rng.uniform(lo, hi, (400, model.nq))
    corners = np.where(rng.integers(0, 2, (64, model.nq)).astype(bool), lo, hi)
    # beyond the limits (the kinematics do not clip): large angles, the double reduction
    # (|q| < 1e5) and libm's sine beyond it
    far = rng.uniform(-1.0, 1.0, (48, model.nq)) * np.repeat([1e2, 9.9e4, 1e7], 16)[:, None]
    return np.vstack([random, corners, lo, hi, np.zeros(model.nq), far])


@pytest.mark.parametrize("level", LEVELS)
def test_float_placements_against_pinocchio(robot: Any, level: int) -> None:
    """Every joint placement of load_q against Pinocchio's forwardKinematics (double) within the
    stated bound, on random configurations, the limits' corners and far beyond the limits; the
    eps of the filter is the stated (140 n + 342) u S with S at least the chain's reach plus the
    spheres' extent (a bound halved or a sign flipped in the chain fails)."""
    _, kernel = _kernel(robot, "box", 3, level)
    model = robot.model
    data = model.createData()
    scale, n = kernel.sphere_filter_bound()
    depth = _depths(model)
    assert n == max(depth)
    joints = range(1, model.njoints)
    reach = sum(np.linalg.norm(model.jointPlacements[j].translation) for j in joints)
    assert scale >= reach + 0.1  # the links and their spheres beyond the last joint (> 10 cm)
    assert kernel.sphere_filter_eps() == pytest.approx((140.0 * n + 342.0) * U * scale, rel=1e-12)
    qs = _configurations(model, np.random.default_rng(11))
    placements = kernel.sphere_filter_placements(qs)
    assert placements.shape == (len(qs), 12 * model.njoints)
    worst_r = np.zeros(model.njoints)
    worst_t = np.zeros(model.njoints)
    for q, row in zip(qs, placements, strict=True):
        pin.forwardKinematics(model, data, q)
        for j in range(model.njoints):
            m = data.oMi[j]
            rot = row[12 * j : 12 * j + 9].reshape(3, 3)
            worst_r[j] = max(worst_r[j], np.linalg.norm(rot - m.rotation))
            t = row[12 * j + 9 : 12 * j + 12]
            worst_t[j] = max(worst_t[j], np.linalg.norm(t - m.translation))
    d = np.array(depth, dtype=float)
    assert np.all(worst_r <= 21.0 * d * U), worst_r / U
    assert np.all(worst_t <= (35.0 * d + 8.0) * U * scale), worst_t / U
    assert worst_r[-1] > 0.5 * U  # float, not double rounded


@pytest.mark.parametrize("level", LEVELS)
def test_float_sines_and_cosines(robot: Any, level: int) -> None:
    """The first joint (a revolute joint about z placed without rotation: its rotation is
    exactly (c, -s; s, c)) on a dense grid and at multiples of pi/2: the float sine and cosine
    within 2 u of the double ones."""
    _, kernel = _kernel(robot, "box", 3, level)
    model = robot.model
    assert model.joints[1].shortname() == "JointModelRZ"
    assert np.array_equal(model.jointPlacements[1].rotation, np.eye(3))
    x = np.concatenate(
        [
            np.linspace(-10.0, 10.0, 40001),
            np.arange(-64, 65) * (np.pi / 2),
            np.linspace(9.9e4, 1e5 - 1.0, 257),
            [1e5, -3e5, 1e9],
        ]
    )
    qs = np.zeros((len(x), model.nq))
    qs[:, 0] = x
    p = kernel.sphere_filter_placements(qs)
    c, s = p[:, 12 + 0], p[:, 12 + 3]
    assert np.array_equal(p[:, 12 + 1], -s)
    assert np.abs(c - np.cos(x)).max() <= 2.0 * U
    assert np.abs(s - np.sin(x)).max() <= 2.0 * U
    assert np.all(p[:, 12 + 8] == 1.0)


@pytest.mark.parametrize("scenario", ["box", "cage"])
def test_trusted_lanes_give_the_double_answers(robot: Any, scenario: str) -> None:
    """Edges whose only point is a configuration on the free side of a sphere contact (the last
    representable step before it: the float spheres overlap within eps there) or on its
    colliding side: the trusted "spheres only" answer is the double test's (free, then
    colliding), not "colliding" for the free one (a lane is trusted only where the spheres
    overlap by more than eps)."""
    _, kernel = _kernel(robot, scenario, 1 if scenario == "cage" else 3)
    model = robot.model
    rng = np.random.default_rng(7)
    qs = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit, (120, model.nq))
    kernel.set_sphere_filter(OFF)
    flags = kernel.collisions_with(qs, SPHERES_ONLY).astype(bool)
    kernel.set_sphere_filter(TRUSTED)
    contacts = first_sphere_contacts(kernel, qs, rng, 24)
    kernel.set_sphere_filter(OFF)
    ends = last_step_pairs(kernel, qs[~flags][:24], contacts, 24)
    kernel.set_sphere_filter(TRUSTED)
    free, hit = ends[0::2], ends[1::2]
    flagged = kernel.sphere_filter_flags(free).astype(bool)
    assert flagged.all()  # the filter cannot clear them: the double test decides
    for mode in (OFF, TRUSTED):
        kernel.set_sphere_filter(mode)
        # an edge q -> q with 2 segments: its one interior point is q itself
        assert [kernel.first_invalid_on_edge(q, q, 2, SPHERES_ONLY) for q in free] == [-1] * 24
        assert [kernel.first_invalid_on_edge(q, q, 2, SPHERES_ONLY) for q in hit] == [1] * 24
    kernel.set_sphere_filter(TRUSTED)
