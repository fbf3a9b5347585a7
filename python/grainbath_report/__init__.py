"""grainbath_report: turn a grainbath run's results.h5 + summary.json into plots and a report.

Layout:
  cli.py       argument handling, locating the output directory, running the sections
  data.py      RunData: read-only access to results.h5, summary.json and the resolved parameters
  document.py  Section / Figure / Table and the Markdown and self-contained HTML writers
  plotting.py  matplotlib style shared by every plot (simulation vs theory conventions)
  dsmc.py      sections for the homogeneous DSMC solver
  edmd.py      sections for the event-driven MD solver
  fields.py    sections for spatially resolved output (/fields, density modes)
  sections.py  the ordered registry of sections

Adding a section: write `def my_section(run, ctx) -> Section | None` in the module of its
solver (return None when its data is absent) and list it in sections.SECTIONS.
"""

__all__ = ["cli", "data", "document", "plotting", "sections"]
