#!/usr/bin/python3
"""A uniform sky over a half-space, exact and as the diffusion grid has it, for docs/accuracy.md
("The sky's grid on the photons' voxel").

Medium z > 0 in optical-depth units (sigma_t = 1), albedo a, Henyey-Greenstein g = 0.8, under a
sky of radiance 1 from every direction above. Exact: photons enter with cosine-weighted
directions (the sky's irradiance pi) and are traced to the end; each collision adds its
next-event estimate toward a viewer leaving at cosine muv: the radiance of every order the
viewer sees (what march takes from the grid when photons carry the sun). Grid: the diffusion
grid of core/lighting/diffusion.cpp in one dimension (absorption sigma_a h per cell,
conductances 1 / (2 r) with r = 1.5 h sigma_t', Marshak's boundary 1 / (min(r, 3) + 2) toward a
sky fluence 4 pi, the empty neighbour holding the face value 4 pi + 2 (phi_0 - 4 pi) / (min(r, 3)
+ 2) at its centre) and march's P1 readout sigma_s (phi + 3 g F . wo) / 4 pi integrated along the
view, for cells of h mean free paths.

usage: halfspace_sky.py albedo muv [photons]      (needs numpy; not a build dependency)
"""
import sys
import numpy as np

from halfspace_common import CAP, grid_matrix, hg, p1_readout, sample_hg

rng = np.random.default_rng(2)
g = 0.8
a, muv = float(sys.argv[1]), float(sys.argv[2])
N = int(sys.argv[3]) if len(sys.argv) > 3 else 200000


def exact():
    mu = np.sqrt(rng.random(N))
    ph = 2 * np.pi * rng.random(N)
    d = np.stack([np.sqrt(1 - mu * mu) * np.cos(ph), np.sqrt(1 - mu * mu) * np.sin(ph), mu], 1)
    z = -np.log(rng.random(N)) * mu
    wo = np.array([np.sqrt(1 - muv * muv), 0, -muv])
    w = np.ones(N)
    alive = np.ones(N, bool)
    L = 0.0
    for _ in range(5000):
        if not alive.any():
            break
        idx = np.nonzero(alive)[0]
        zi, di, wi = z[idx], d[idx], w[idx]
        L += (wi * a * hg(di @ wo, g) * np.exp(-zi / muv) / muv).sum()
        dn = sample_hg(rng, di, g)
        zn = zi + dn[:, 2] * (-np.log(rng.random(len(idx))))
        z[idx], d[idx], w[idx] = zn, dn, wi * a
        alive[idx[(zn < 0) | (zn > 300)]] = False
    return L * np.pi / N


def grid(h, depth=400.0):
    str_ = 1 - a * g
    n = int(depth / h) + 1
    A, r, Gb = grid_matrix(n, h, str_, 1 - a)
    q = np.zeros(n)
    q[0] = Gb * 4 * np.pi  # the sky's fluence through the surface
    phi = np.linalg.solve(A, q)
    face = 4 * np.pi + 2 * (phi[0] - 4 * np.pi) / (min(r, CAP) + 2)
    return p1_readout(h, phi, face, str_, g, muv, a)


L = exact()
print(f"albedo {a}, view cosine {muv}: exact {L:.4f} (sky radiance 1)")
for h in [51.2, 12.8, 3.2, 1.6, 0.8, 0.4, 0.2, 0.05]:
    Lg = grid(h)
    print(f"  grid, cell {h:5.2f} mean free paths: {Lg:.4f} ({Lg / L:.2f} of exact)")
