"""Shared settings of the short G1 walks in the walking tests."""

from __future__ import annotations

from taskspace.locomotion.footsteps import StepTiming

# phases short enough for a 2-3 step walk to simulate in a few seconds
SHORT_TIMING = StepTiming(
    single_support=0.5,
    double_support=0.2,
    initial_double_support=0.6,
    final_double_support=0.8,
    weight_shift=0.3,
)
G1_FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
