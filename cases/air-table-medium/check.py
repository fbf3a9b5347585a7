# Medium collision rate under the air table against the exact rate of the checkpointed
# velocities (docs/edmd.md "Air table in a medium"). Usage, from the repository root:
#   for s in 1 2 3 4 5 6 7 8 9; do build/grainbath run cases/air-table-medium --set run.seed=$s --out OUT/s$s -q; done
#   /usr/bin/python3 cases/air-table-medium/check.py OUT
# Each run keeps its last two checkpoints (the velocities sampled); the expectation per grain
# is K <|v - w|> over the 2D Maxwellian medium (Rice mean), averaged over grains and
# checkpoints; the ratio's error is the spread over the seeds.
import glob, json, sys
import h5py, numpy as np
from scipy.special import i0e, i1e

K = 1.0; TB = 0.2; alpha = 0.5  # case.toml
mB = alpha / (1 - alpha); s = np.sqrt(TB / mB)

def rate(v):  # K E|v - w|, w ~ N(0, s^2 I_2): s sqrt(pi/2) L_{1/2}(-|v|^2 / 2 s^2), scaled Bessels
    x = -(v * v).sum(1) / (2 * s * s)
    return K * s * np.sqrt(np.pi / 2) * ((1 - x) * i0e(-x / 2) - x * i1e(-x / 2))

ratios = []
for d in sorted(glob.glob(sys.argv[1] + '/*.checkpoints')):
    measured = json.load(open(d[:-len('.checkpoints')] + '/summary.json'))['medium']['background_collision_rate']
    pred = np.mean([rate(h5py.File(f, 'r')['/engine/velocities'][:].reshape(-1, 3)[:, :2]).mean()
                    for f in glob.glob(d + '/*.h5')])
    ratios.append(measured / pred)
r = np.array(ratios)
print(f'runs {len(r)}: measured / exact = {r.mean():.4f} +- {r.std(ddof=1) / np.sqrt(len(r)):.4f}')
