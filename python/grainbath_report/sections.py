"""The ordered list of report sections.

Each entry is a function `section(run, ctx) -> Section | None`: it inspects `run` (solver
attribute, which groups exist) and returns None when its data is absent, so a report only
shows what the run wrote.  To add a section, write the function in the module of its solver
and insert it here.
"""
from . import common, dsmc, edmd, fields

SECTIONS = [
    common.overview,
    # homogeneous DSMC
    dsmc.temperature,
    dsmc.velocity,
    dsmc.steady_temperature,
    dsmc.sonine_a2,
    dsmc.distribution,
    dsmc.rough,
    dsmc.energy,
    dsmc.pressure,
    # spatially resolved runs (DSMC with cells, hydrodynamic solvers)
    fields.density_mode,
    fields.profiles,
    fields.shear,
    fields.maps,
    # event-driven MD
    edmd.equation_of_state,
    edmd.temperature,
    edmd.pair_correlation,
    edmd.velocity_correlations,
    edmd.velocity_distribution,
    edmd.normal_speed,
    edmd.snapshot,
    # everything
    common.appendix,
]
