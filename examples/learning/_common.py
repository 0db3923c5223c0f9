"""Shared helpers of the examples here (arguments, figures), from taskspace.viz.plots."""

from taskspace.viz.plots import fast_mode as fast
from taskspace.viz.plots import parse_example_args as parse
from taskspace.viz.plots import save_figures as finish

__all__ = ["fast", "finish", "parse"]
