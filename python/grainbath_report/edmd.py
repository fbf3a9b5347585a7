"""Sections for the event-driven MD solver."""


def _none(run, ctx):
    return None


equation_of_state = temperature = pair_correlation = velocity_correlations = velocity_distribution = _none
normal_speed = snapshot = _none
