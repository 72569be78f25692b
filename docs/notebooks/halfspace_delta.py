#!/usr/bin/python3
"""The diffusion grid's light at a lit surface under the delta-M split, for docs/accuracy.md
("The grid's readout under delta-M, and the half-space's own limit", stop 50).

Medium z > 0 in optical-depth units (sigma_t = 1), albedo a, Henyey-Greenstein g = 0.8, the
forward fraction f = g^2 of render.forward_scattering = "delta". Prints, for the sun (unit
irradiance entering at cosine mu0, viewer at cosine muv, azimuth 180 degrees) and for a uniform
sky of radiance 1 (viewer at cosine 0.8), the radiance of the orders the grid carries:

- the one-dimensional grid of core/lighting/diffusion.cpp (halfspace_common.grid_matrix: cells
  of h mean free paths, Marshak's boundary with its resistance cap) read as march reads it
  ("plain": sigma_s (phi + 3 g F . wo) / 4 pi under sigma_t, the sun's source the beam's loss
  under sigma_t - f sigma_s times its albedo), and read under the split ("delta": sigma_s (1 - f)
  (phi + 3 g* F . wo) / 4 pi under sigma_t - f sigma_s, g* = (g - f) / (1 - f));
- the limit of both as the cell goes to 0, in closed form: phi = C e^{-kappa z} + P e^{-beta z}
  (the sun's source q0 e^{-beta z}, P = q0 / (sigma_a - D beta^2)), C from Marshak's boundary
  phi(0) - 2 D phi'(0) = 4 pi L_sky, each term A e^{-lambda z} read as
  A (1 - 3 g' D lambda muv) / (sigma_t'' + lambda muv).

Compare with the exact transport of halfspace_mc.py (sun) and halfspace_sky.py (sky): for these
geometries 0.298 (a = 1) and 0.033 (a = 0.9) for the sun at mu0 0.926, muv 0.995; 0.964 and
0.171 for the sky at muv 0.8.

usage: halfspace_delta.py               (needs numpy; not a build dependency)
"""
import numpy as np

from halfspace_common import CAP, grid_matrix

g = 0.8
F_DELTA = g * g
CELLS = [51.2, 12.8, 3.2, 0.8, 0.2]


def split(a, delta):
    f = F_DELTA if delta else 0.0
    ts = 1.0 - f * a  # the beams' extinction
    gp = (g - f) / (1.0 - f) if delta else g
    return f, ts, gp


def grid(kind, a, h, delta, mu0, muv, depth=400.0):
    f, ts, gp = split(a, delta)
    sa, str_ = 1.0 - a, 1.0 - a * g
    n = int(depth / h) + 1
    A, r, Gb = grid_matrix(n, h, str_, sa)
    q = np.zeros(n)
    sky = 0.0
    if kind == "sun":
        b = h * ts / mu0  # the beam's loss per cell (the six-face source in 1D) x its albedo
        q = a * (1.0 - f) * np.exp(-np.arange(n) * b) * (-np.expm1(-b)) / b * h
    else:
        sky = 1.0
        q[0] = Gb * 4 * np.pi
    phi = np.linalg.solve(A, q)
    face = 4 * np.pi * sky + 2 * (phi[0] - 4 * np.pi * sky) / (min(r, CAP) + 2)
    dz = 0.001
    z = np.arange(0, 60, dz) + dz / 2
    xs = np.concatenate([[-0.5 * h], (np.arange(n) + 0.5) * h])
    ys = np.concatenate([[face], phi])
    ph = np.interp(z, xs, ys)
    i = np.searchsorted(xs, z) - 1
    F = np.clip(-(ys[i + 1] - ys[i]) / h / (3 * str_), -ph, ph)
    S = a * (1.0 - f) * np.maximum((ph + 3 * gp * F * (-muv)) / (4 * np.pi), 0)
    return (S * np.exp(-z * ts / muv) * dz / muv).sum()


def limit(kind, a, delta, mu0, muv):
    f, ts, gp = split(a, delta)
    sa = 1.0 - a
    D = 1.0 / (3.0 * (1.0 - a * g))
    kap = np.sqrt(sa / D)
    terms = []
    lsky = 1.0 if kind == "sky" else 0.0
    P, beta = 0.0, 0.0
    if kind == "sun":
        beta = ts / mu0
        P = a * (1.0 - f) / (sa - D * beta * beta)
        terms.append((P, beta))
    C = (4 * np.pi * lsky - P * (1 + 2 * D * beta)) / (1 + 2 * D * kap)
    terms.append((C, kap))
    L = sum(A * (1 - 3 * gp * D * lam * muv) / (ts + lam * muv) for A, lam in terms)
    return a * (1.0 - f) / (4 * np.pi) * L


for kind, mu0, muv in [("sun", 0.926, 0.995), ("sky", 1.0, 0.8)]:
    for a in [1.0, 0.9]:
        for delta in [False, True]:
            cells = " ".join(f"{grid(kind, a, h, delta, mu0, muv):.4f}" for h in CELLS)
            print(f"{kind} a={a} {'delta' if delta else 'plain'}: cells {CELLS}: {cells}; "
                  f"limit {limit(kind, a, delta, mu0, muv):.4f}")
