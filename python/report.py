#!/usr/bin/python3
"""grainbath report: plots and report.md / report.html from a run's output.

Usage:  /usr/bin/python3 python/report.py DIR [--out REPORT_DIR] [--strict]

DIR is a case directory (its output/ is used) or an output directory holding
results.h5 and summary.json.  The report goes to DIR/report/ (PNG files,
report.md, and a self-contained report.html with the PNGs embedded).

Needs numpy, matplotlib and h5py (Debian: python3-matplotlib python3-h5py);
`grainbath report DIR` runs this script with /usr/bin/python3.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from grainbath_report.cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
