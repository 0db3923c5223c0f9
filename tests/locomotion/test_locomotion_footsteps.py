"""Footstep plans, the ZMP reference, support polygons over time and swing trajectories
(references: circle geometry, the phase timing, finite differences of the samples)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.locomotion.footsteps import (
    Footstep,
    FootstepPlan,
    PhaseKind,
    StepTiming,
    arc_walk,
    straight_walk,
    turn_in_place,
)
from taskspace.locomotion.swing_trajectory import SwingTrajectory
from taskspace.locomotion.zmp_reference import (
    SoleSize,
    support_polygon_at,
    support_polygons,
    zmp_reference,
)


def test_straight_walk_geometry_and_timing():
    timing = StepTiming(single_support=0.6, double_support=0.2)
    plan = straight_walk(10, step_length=0.25, step_width=0.18, timing=timing)
    assert len(plan.steps) == 10
    assert [s.side for s in plan.steps[:3]] == ["right", "left", "right"]
    assert [s.x for s in plan.steps] == pytest.approx([0.25 * i for i in range(1, 10)] + [2.25])
    assert all(abs(s.y) == pytest.approx(0.09) for s in plan.steps)
    left, right = plan.final_feet()
    assert left.position == pytest.approx([2.25, 0.09]) and right.position == pytest.approx(
        [2.25, -0.09]
    )
    phases = plan.phases()
    assert phases[-1].end == pytest.approx(plan.duration)
    assert plan.duration == pytest.approx(1.6 + 10 * 0.8 + 1.6)
    singles = [p for p in phases if p.kind is PhaseKind.SINGLE_SUPPORT]
    assert len(singles) == 10
    assert all(p.end - p.start == pytest.approx(0.6) for p in singles)
    for a, b in itertools.pairwise(phases):  # contiguous in time
        assert a.end == pytest.approx(b.start)


@pytest.mark.parametrize("angle", [0.8, -0.8])
def test_arc_walk_feet_on_offset_circles(angle):
    R, w = 1.5, 0.2
    plan = arc_walk(8, radius=R, angle=angle, step_width=w)
    center = np.array([0.0, math.copysign(R, angle)])
    inner = "left" if angle > 0 else "right"
    for s in (*plan.initial, *plan.steps):
        expected = R - w / 2 if s.side == inner else R + w / 2
        assert np.linalg.norm(s.position - center) == pytest.approx(expected, abs=1e-12)
    assert plan.steps[-1].yaw == pytest.approx(angle)
    assert plan.steps[0].side != inner  # the outer foot steps first


def test_turn_in_place():
    plan = turn_in_place(math.pi / 2, 4, step_width=0.2)
    for s in plan.steps:
        assert np.linalg.norm(s.position) == pytest.approx(0.1)
    left, right = plan.final_feet()
    assert left.yaw == right.yaw == pytest.approx(math.pi / 2)
    assert left.position == pytest.approx([-0.1, 0.0], abs=1e-12)
    assert plan.steps[0].side == "left"


@pytest.mark.parametrize(
    "plan",
    [straight_walk(6), arc_walk(6, radius=1.0, angle=0.9), turn_in_place(1.2, 5)],
    ids=["straight", "arc", "turn"],
)
def test_zmp_reference_continuous_and_inside_support(plan):
    dt = 0.01
    t = np.arange(0.0, plan.duration + dt, dt)
    ref = zmp_reference(plan, t)
    jumps = np.linalg.norm(np.diff(ref, axis=0), axis=1)
    assert jumps.max() < 0.35 * dt / plan.timing.double_support + 1e-9
    sole = SoleSize(length=0.2, width=0.1)
    polys = support_polygons(plan, t, sole)
    assert min(p.margin(r) for p, r in zip(polys, ref, strict=True)) >= -1e-12
    # single support: the polygon is one sole and the reference is its center
    for ph in plan.phases():
        if ph.kind is PhaseKind.SINGLE_SUPPORT:
            tm = 0.5 * (ph.start + ph.end)
            poly = support_polygon_at(plan, tm, sole)
            assert poly.area == pytest.approx(0.02)
            assert zmp_reference(plan, [tm])[0] == pytest.approx(ph.stance[0].position)


def test_plan_validation():
    feet = (Footstep("left", 0, 0.1), Footstep("right", 0, -0.1))
    with pytest.raises(InvalidInputError, match="alternate"):
        FootstepPlan(feet, (Footstep("left", 0.2, 0.1), Footstep("left", 0.4, 0.1)))
    with pytest.raises(InvalidInputError, match=r"\(left footstep, right footstep\)"):
        FootstepPlan(feet[::-1], ())
    with pytest.raises(UnknownNameError, match="left, right"):
        Footstep("middle", 0, 0)
    with pytest.raises(InvalidInputError, match="weight_shift"):
        StepTiming(initial_double_support=0.2, weight_shift=0.4)


def test_swing_trajectory_ends_clearance_and_derivatives():
    lift, land = Footstep("left", 0.0, 0.1, 3.0), Footstep("left", 0.3, 0.12, -3.0)
    T, h = 0.7, 0.06
    swing = SwingTrajectory(lift, land, T, clearance=h, lift_height=0.0, land_height=0.02)
    t = np.linspace(0.0, T, 701)
    s = swing.sample(t)
    assert s.position[0] == pytest.approx([0.0, 0.1, 0.0], abs=1e-12)
    assert s.position[-1] == pytest.approx([0.3, 0.12, 0.02], abs=1e-12)
    assert np.abs(s.velocity[[0, -1]]).max() < 1e-12
    assert np.abs(s.acceleration[[0, -1]]).max() < 1e-9
    assert s.position[350, 2] == pytest.approx(0.02 + h)  # apex at mid-swing
    assert s.position[1:-1, 2].min() > 0.0  # never below the ground
    # yaw takes the short way round (3.0 -> -3.0 through pi)
    assert s.yaw[-1] == pytest.approx(2 * math.pi - 3.0)
    assert np.all(np.diff(s.yaw) >= 0)
    # velocities and accelerations are the derivatives of the samples
    fd = np.gradient(s.position, t, axis=0)
    assert np.abs(fd[5:-5] - s.velocity[5:-5]).max() < 1e-4
    fd2 = np.gradient(s.velocity, t, axis=0)
    assert np.abs(fd2[5:-5] - s.acceleration[5:-5]).max() < 1e-2


@pytest.mark.parametrize(("z0", "z1"), [(0.0, 0.0), (0.2, 0.0), (0.0, 0.2), (0.5, 0.0), (0.1, 0.4)])
def test_swing_height_between_ends_and_apex_as_documented(z0: float, z1: float) -> None:
    """The height never dips below the lower end; the apex (clearance above the higher end) is
    the highest point for equal heights, and is exceeded by at most 12 % of the height
    difference otherwise (the module docstring's figures)."""
    a, b = Footstep("left", 0.0, 0.0), Footstep("left", 0.3, 0.0)
    swing = SwingTrajectory(a, b, 0.8, clearance=0.05, lift_height=z0, land_height=z1)
    z = swing.sample(np.linspace(0.0, 0.8, 8001)).position[:, 2]
    apex = max(z0, z1) + 0.05
    assert z.min() >= min(z0, z1) - 1e-12
    assert z[4000] == pytest.approx(apex, abs=1e-12)  # through the apex at mid-swing
    assert z.max() <= apex + 0.12 * abs(z1 - z0) + 1e-12


def test_swing_needs_same_side():
    with pytest.raises(InvalidInputError, match="one foot"):
        SwingTrajectory(Footstep("left", 0, 0), Footstep("right", 0, 0), 0.5)
