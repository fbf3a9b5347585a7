"""Sections for spatially resolved output (/fields, density-mode amplitudes). Layout: docs/OUTPUT.md."""


def density_mode(run, ctx):
    return None


def profiles(run, ctx):
    return None
