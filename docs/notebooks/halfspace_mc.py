#!/usr/bin/python3
"""Exact transport in a sunlit half-space, for docs/accuracy.md ("The grid at a lit surface").

Medium z > 0 in optical-depth units (sigma_t = 1), albedo a, Henyey-Greenstein g = 0.8, a sun of
unit irradiance entering at cosine mu0, the viewer leaving at cosine muv with azimuth phiv
relative to the sun's. Photons are traced to the end (analogue walks) and every collision adds
its next-event estimate toward the viewer: the radiance the viewer sees, split into single
scattering and the orders >= 2 (what march's multiple scattering has to supply). Also prints,
per depth, the in-scattered radiance of orders >= 2 toward the viewer (S) and the fluence and
normal current of the once-scattered light, for comparison with a P1 readout.

usage: halfspace_mc.py albedo phiv_degrees mu0 muv     (needs numpy; not a build dependency)
"""
import sys
import numpy as np

from halfspace_common import hg as hg_g, sample_hg as sample_hg_g

rng = np.random.default_rng(1)
g = 0.8
a = float(sys.argv[1]) if len(sys.argv) > 1 else 1.0
phiv = np.radians(float(sys.argv[2]) if len(sys.argv) > 2 else 180.0)
mu0 = float(sys.argv[3]) if len(sys.argv) > 3 else 0.5
muv = float(sys.argv[4]) if len(sys.argv) > 4 else 0.8
N = 200000




def hg(c):
    return hg_g(c, g)


def sample_hg(d):
    return sample_hg_g(rng, d, g)


sun = np.array([np.sqrt(1 - mu0 * mu0), 0, mu0])  # propagation into the medium
wo = np.array([np.sqrt(1 - muv * muv) * np.cos(phiv), np.sqrt(1 - muv * muv) * np.sin(phiv), -muv])
nb, dz = 200, 0.1
S = np.zeros(nb)
phi = np.zeros(nb)
Fz = np.zeros(nb)
L1 = L2 = 0.0
z = -np.log(rng.random(N)) * mu0
d = np.tile(sun, (N, 1))
w = np.ones(N)
alive = np.ones(N, bool)
order = 0
while alive.any() and order < 3000:
    order += 1
    idx = np.nonzero(alive)[0]
    zi, di, wi = z[idx], d[idx], w[idx]
    cth = di @ wo
    contrib = wi * a * hg(cth) * np.exp(-zi / muv) / muv
    if order == 1:
        L1 += contrib.sum()
    else:
        L2 += contrib.sum()
        b = np.minimum((zi / dz).astype(int), nb - 1)
        np.add.at(S, b, wi * hg(cth))
        np.add.at(phi, b, wi)
        np.add.at(Fz, b, wi * di[:, 2])
    wi = wi * a
    dn = sample_hg(di)
    zn = zi + dn[:, 2] * (-np.log(rng.random(len(idx))))
    z[idx], d[idx], w[idx] = zn, dn, wi
    alive[idx[(zn < 0) | (zn > 300)]] = False
norm = mu0 / N  # the sun's flux per unit area over the photon count
S *= norm / dz
phi *= norm / dz
Fz *= norm / dz
print(f"a={a} g={g} mu0={mu0} muv={muv} phiv={np.degrees(phiv):.0f}: "
      f"L single {L1 * norm:.5f}  L orders>=2 {L2 * norm:.5f}")
for i in [0, 1, 2, 3, 5, 10, 20, 40, 80, 150]:
    print(f" tau {i * dz + dz / 2:5.2f}: S {S[i]:.4f}  phi/4pi {phi[i] / 4 / np.pi:.4f}  "
          f"Fz {Fz[i]:.4f}  P1 of the exact moments {(phi[i] + 3 * g * Fz[i] * wo[2]) / 4 / np.pi:.4f}")
