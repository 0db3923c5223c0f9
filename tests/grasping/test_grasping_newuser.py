"""New-user inputs to the grasping API: right answers or taskspace errors, never silently wrong."""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.grasping import (
    AntipodalOptions,
    GraspContact,
    balance_forces,
    box_mesh,
    closure_hull,
    closure_lp,
    cylinder_mesh,
    epsilon_l1,
    epsilon_linf,
    force_closure,
    grasp_matrix,
    grasp_quality,
    minimal_closure_subset,
    primitive_wrenches,
    sphere_mesh,
    task_wrench_scale,
)

# The cross-polytope conv{+-e_i} in R^6: in closure; L1 epsilon 1/sqrt(6) (distance of the
# facet sum(x) = 1 from the origin); the LP margin (least convex coefficient) 1/12.
CROSS = np.vstack([np.eye(6), -np.eye(6)])
C1 = GraspContact([0.05, 0, 0], [-1, 0, 0])
C2 = GraspContact([-0.05, 0, 0], [1, 0, 0])


@pytest.mark.parametrize("scale", [1e300, 1e-300, 1e-12, 1e12])
def test_closure_does_not_depend_on_the_scale_of_the_wrenches(scale: float) -> None:
    lp = closure_lp(CROSS * scale)
    assert lp.closure and lp.rank == 6
    assert lp.margin == pytest.approx(1 / 12)
    hull = closure_hull(CROSS * scale)
    assert hull.closure and hull.rank == 6
    assert hull.margin == pytest.approx(scale / math.sqrt(6))


def test_closure_of_one_dimensional_wrenches() -> None:
    assert closure_hull(np.array([[2.0], [-1.0]])).margin == pytest.approx(1.0)
    assert not closure_hull(np.array([[2.0], [1.0]])).closure


def test_float32_and_numpy_scalars_are_accepted() -> None:
    c = GraspContact(np.float32([0, 0, 1]), np.float32([0, 0, -1]), mu=np.float32(0.5))
    assert c.mu == 0.5 and isinstance(c.mu, float)
    assert closure_hull(CROSS.astype(np.float32)).closure
    assert AntipodalOptions(samples=np.int64(10), edges=np.int64(6)).samples == 10


BAD_CALLS = {
    "mu bool": lambda: GraspContact([0, 0, 0], [0, 0, 1], mu=True),
    "frame not str": lambda: GraspContact([0, 0, 0], [0, 0, 1], frame=3),
    "center shape": lambda: grasp_matrix([C1, C2], center=[1, 2]),
    "center nan": lambda: grasp_matrix([C1, C2], center=[np.nan, 0, 0]),
    "pw center nan": lambda: primitive_wrenches([C1, C2], center=[np.nan, 0, 0]),
    "pw torque_scale text": lambda: primitive_wrenches([C1, C2], torque_scale="a"),
    "pw not contacts": lambda: primitive_wrenches([1, 2]),  # type: ignore[list-item]
    "pw edges huge": lambda: primitive_wrenches([C1, C2], edges=10**12),
    "pw mu_scale nan": lambda: primitive_wrenches([C1, C2], mu_scale=math.nan),
    "pw mu_scale negative": lambda: primitive_wrenches([C1, C2], mu_scale=-1.0),
    "lp text": lambda: closure_lp("abc"),  # type: ignore[arg-type]
    "lp no columns": lambda: closure_lp(np.zeros((3, 0))),
    "hull no columns": lambda: closure_hull(np.zeros((3, 0))),
    "lp tolerance nan": lambda: closure_lp(CROSS, tolerance=math.nan),
    "quality no contacts": lambda: grasp_quality([]),
    "quality center shape": lambda: grasp_quality([C1, C2], center=[1, 2]),
    "epsilon 1-D": lambda: epsilon_l1(np.zeros(6)),
    "epsilon nan": lambda: epsilon_l1(np.full((12, 6), np.nan)),
    "epsilon_linf owner": lambda: epsilon_linf(CROSS, [0]),
    "task wrench shape": lambda: task_wrench_scale(CROSS, np.ones(5)),
    "task wrench nan": lambda: task_wrench_scale(CROSS, np.full(6, np.nan)),
    "subset no contacts": lambda: minimal_closure_subset([]),
    "balance regularization < 0": lambda: balance_forces(
        [C1, C2], [0, 0, -1, 0, 0, 0], regularization=-1.0
    ),
    "balance regularization nan": lambda: balance_forces(
        [C1, C2], [0, 0, -1, 0, 0, 0], regularization=math.nan
    ),
    "balance J nan": lambda: balance_forces(
        [C1, C2], [0, 0, -1, 0, 0, 0], hand_jacobian=np.full((6, 2), np.nan), torque_limits=[1, 1]
    ),
    "balance tau nan": lambda: balance_forces(
        [C1, C2], [0, 0, -1, 0, 0, 0], hand_jacobian=np.ones((6, 2)), torque_limits=[np.nan, 1]
    ),
    "balance tau without J": lambda: balance_forces(
        [C1, C2], [0, 0, -1, 0, 0, 0], torque_limits=[1.0]
    ),
    "box negative": lambda: box_mesh([-0.1, 0.1, 0.1]),
    "sphere zero": lambda: sphere_mesh(0.0),
    "sphere subdivisions huge": lambda: sphere_mesh(0.1, subdivisions=20),
    "cylinder negative": lambda: cylinder_mesh(-0.1, 0.2),
    "cylinder segments": lambda: cylinder_mesh(0.1, 0.2, segments=2),
    "sample n negative": lambda: box_mesh([0.1, 0.1, 0.1]).sample_surface(
        -1, np.random.default_rng(0)
    ),
    "options edges": lambda: AntipodalOptions(edges=2),
    "options samples bool": lambda: AntipodalOptions(samples=True),
}


@pytest.mark.parametrize("name", sorted(BAD_CALLS))
def test_bad_input_is_a_taskspace_error(name: str) -> None:
    with pytest.raises(TaskspaceError) as info:
        BAD_CALLS[name]()
    assert isinstance(info.value, InvalidInputError)


def test_two_soft_fingers_close_and_two_point_fingers_do_not() -> None:
    # Two antipodal point contacts cannot resist a moment about the line joining them.
    r = force_closure([C1, C2])
    assert not r.closure
    W, _ = primitive_wrenches([C1, C2])
    assert np.all(W @ r.certificate >= -1e-9)
    assert abs(r.certificate[3]) == pytest.approx(1.0)  # the moment about x
