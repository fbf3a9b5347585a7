#!/usr/bin/python3
"""Table and plot of the diffusion-limit scan (run.sh): DSMC decay rate of the density mode
against the paper's D k^2 (Bisi-Spiga eq. 36), the kinetic (Sonine-Galerkin) value and the
closures' finite-eps linear rates.

    /usr/bin/python3 cases/diffusion-limit/table.py [--out DIR]

Reads the runs DIR/eps-* (default output/ beside this script, where run.sh puts them; git
ignores it), writes DIR/table.md and DIR/diffusion_limit.png and compares the table with the
shipped reference/table.md (scripts/compare_tables.py). `--out cases/diffusion-limit/reference` reads
and replaces the shipped ones."""
import argparse
import json
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

here = Path(__file__).resolve().parent
ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--out", default=here / "output", type=Path, help="the runs eps-*; the table and figure go there")
out = ap.parse_args().out.resolve()
rows = []
for d in sorted(p for p in out.glob("eps-*") if (p / "summary.json").exists()):
    # a re-run keeps the run before as eps-<value>.previous (grainbath never deletes output): skip those
    try:
        eps = float(d.name.split("-", 1)[1])
    except ValueError:
        continue
    s = json.load(open(d / "summary.json"))
    h = s["theory"]["hydro"]
    rows.append((eps, s["mode"]["decay_rate"], s["mode"]["decay_rate_stderr"], h["decay_rate"],
                 h["decay_rate_kinetic"], h.get("decay_rate_maxwellian_closure"), h.get("decay_rate_grad_closure")))
if not rows:
    raise SystemExit(f"table.py: no finished runs {out}/eps-* (run.sh makes them)")
rows.sort()
lines = ["| eps | DSMC rate | paper D k^2 | kinetic | Maxwellian closure | Grad closure | DSMC/paper - 1 | kinetic/paper - 1 |",
         "|---|---|---|---|---|---|---|---|"]
for eps, r, e, p, k, m, g in rows:
    lines.append(f"| {eps:g} | {r:.5f} ± {e:.5f} | {p:.5f} | {k:.5f} | {m:.5f} | {g:.5f} | "
                 f"{r / p - 1:+.3f} ± {e / p:.3f} | {k / p - 1:+.3f} |")
(out / "table.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))
fig, ax = plt.subplots(figsize=(6.4, 4.2))
eps = [r[0] for r in rows]
ax.errorbar(eps, [r[1] / r[3] - 1 for r in rows], yerr=[r[2] / r[3] for r in rows], fmt="o", color="k",
            capsize=3, label="DSMC")
ax.plot(eps, [r[4] / r[3] - 1 for r in rows], "-", label="kinetic (Sonine-Galerkin) D")
ax.plot(eps, [r[5] / r[3] - 1 for r in rows], "--", label="local-Maxwellian closure, finite eps")
ax.plot(eps, [r[6] / r[3] - 1 for r in rows], ":", label="Grad closure, finite eps")
ax.axhline(0, color="grey", lw=0.8)
ax.set_xscale("log")
ax.set_xlabel("Knudsen parameter eps")
ax.set_ylabel("decay rate / (paper D k^2) - 1")
ax.set_title("density mode, k = pi: approach to the drift-diffusion limit")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(out / "diffusion_limit.png", dpi=110)
print(f"wrote {out / 'table.md'} and diffusion_limit.png beside it")
if out != (here / "reference").resolve():
    subprocess.run([sys.executable, str(here.parent.parent / "scripts" / "compare_tables.py"),
                    str(here / "reference" / "table.md"), str(out / "table.md")], check=True)
