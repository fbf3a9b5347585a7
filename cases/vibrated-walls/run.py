#!/usr/bin/env python3
"""Runs of cases/vibrated-walls (all from case.toml with --set overrides), outputs in
cases/vibrated-walls/output/<name>/. Then `plot.py` makes the tables and the figure.

  GRAINBATH=build/grainbath /usr/bin/python3 cases/vibrated-walls/run.py [--force] [--seeds=2,3,...] [names...]

--seeds=S1,S2,... also runs each named run (all by default) with these seeds (`--set run.seed=S`)
into output-seeds/<name>/s<S>/; plot.py then adds the mean and standard error of T/T_bal over
seed 1 and these to balance.csv. The blocked error of one run's mean T understates the scatter
between runs in the near-elastic, weakly dissipating runs (slow energy modes; docs/edmd.md
"Errors of the window means").

Series:
  main         case.toml as is: 1600 disks, nu = 0.1, L_x = L_y = 112 sigma, e = 0.9, v_dr = 1
  e<e>         the main geometry at e = 0.99 ... 0.7 (profiles, EOS, Fourier fit, balance)
  dilute-e<e>  400 disks, nu = 0.05, L_x = 40 sigma (aspect 1:4), elastic walls; v_dr chosen so
               that the energy balance gives T = 1, start at T = 1 (the balance's limit)
  dense-nu<nu> 1600 disks, e = 0.99, nu = 0.2 and 0.3, same way (v_dr for T_balance = 1)
  two-walls    dilute geometry, e = 0.99, v_low = 1, v_high = 0.5, alpha_high = 0.9 (eq. B.4)
"""
import json
import os
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
exe = os.environ.get("GRAINBATH", os.path.join(os.getcwd(), "build", "grainbath"))

DILUTE = ["edmd.particles=400", "edmd.packing_fraction=0.05", "edmd.aspect=[1.0,4.0]", "profiles.slabs=20",
          "edmd.equilibrate=300", "edmd.collisions=4000"]


def theory(sets):
    cmd = [exe, "theory", here] + [a for s in sets for a in ("--set", s)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    d = json.loads(out)
    # the JSON nests "edmd": {...}
    return d["edmd"] if "edmd" in d else d


def scaled(sets, two_walls=None):
    """v_dr such that the Enskog-consistent balance gives T = 1 (T scales as v_dr^2)."""
    sets = sets + ["edmd.temperature=1.0"]  # start at the balance temperature
    probe = sets + (two_walls or ["walls.driving_speed_low=1.0", "walls.driving_speed_high=1.0"])
    T1 = theory(probe)["wall_balance_temperature"]
    s = 1.0 / T1 ** 0.5
    if two_walls:
        out = []
        for kv in two_walls:
            k, v = kv.split("=")
            out.append(f"{k}={float(v) * s:.12g}" if "driving_speed" in k else kv)
        return sets + out
    return sets + [f"walls.driving_speed_low={s:.12g}", f"walls.driving_speed_high={s:.12g}"]


def runs():
    r = {"main": []}
    for e in ["0.99", "0.95", "0.8", "0.7"]:
        # start near the steady state (half the balance temperature: clustering cools the gas)
        T = theory([f"restitution.e={e}"])["wall_balance_temperature"]
        r["e" + e] = [f"restitution.e={e}", f"edmd.temperature={0.5 * T:.6g}"]
    for e in ["0.998", "0.995", "0.99", "0.98", "0.95", "0.9", "0.8"]:
        r["dilute-e" + e] = scaled(DILUTE + [f"restitution.e={e}"])
    for nu in ["0.2", "0.3"]:
        r["dense-nu" + nu] = scaled([f"edmd.packing_fraction={nu}", "restitution.e=0.99", "edmd.equilibrate=300"])
    r["two-walls"] = scaled(DILUTE + ["restitution.e=0.99"],
                            ["walls.driving_speed_low=1.0", "walls.driving_speed_high=0.5", "walls.restitution_high=0.9"])
    return r


def main():
    force = "--force" in sys.argv
    seeds = [int(x) for a in sys.argv[1:] if a.startswith("--seeds=") for x in a[len("--seeds="):].split(",") if x]
    only = [a for a in sys.argv[1:] if not a.startswith("--")]
    for name, sets in runs().items():
        if only and name not in only:
            continue
        jobs = [(os.path.join(here, "output", name), [])]
        jobs += [(os.path.join(here, "output-seeds", name, f"s{k}"), [f"run.seed={k}"]) for k in seeds]
        for out, extra in jobs:
            if os.path.exists(os.path.join(out, "summary.json")) and not force:
                print(f"{out}: exists")
                continue
            cmd = ["nice", exe, "run", here, "--out", out, "-q"] + [a for s in sets + extra for a in ("--set", s)]
            print(" ".join(cmd[1:]), flush=True)
            subprocess.run(cmd, check=True)


if __name__ == "__main__":
    main()
