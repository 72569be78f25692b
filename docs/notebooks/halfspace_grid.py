#!/usr/bin/python3
"""The diffusion grid of core/lighting/diffusion.cpp and march's readout, in one dimension, on the
sunlit half-space of halfspace_mc.py (albedo 1, g = 0.8, sigma_t = 1), for cells of h mean free
paths: the sun's first scattering averaged over each cell, conductances 1 / (2 r) between cells
(r = 1.5 h sigma_t'), Marshak's boundary 1 / (min(r, 3) + 2), the empty neighbour holding the
face value 2 phi_0 / (min(r, 3) + 2) at its centre; march reads phi and the P1 current of the
linear interpolant (kern::p1Radiance) and integrates sigma_s (phi + 3 g F . wo) / 4 pi along the
view. Prints the radiance of orders >= 2 the viewer sees, to compare with halfspace_mc.py.
The 1D grid has no lateral current, so it does not depend on the azimuth.

usage: halfspace_grid.py mu0 muv                          (needs numpy; not a build dependency)
"""
import sys
import numpy as np

from halfspace_common import CAP, grid_matrix, p1_readout

g = 0.8
mu0, muv = float(sys.argv[1]), float(sys.argv[2])
str_ = 1.0 - g  # sigma_t' at albedo 1


def solve(h, depth=400.0):
    n = int(depth / h) + 1
    b = h / mu0
    q = np.exp(-np.arange(n) * b) * (-np.expm1(-b)) / b * h  # first scattering per cell
    A, r, _ = grid_matrix(n, h, str_, 0.0)
    phi = np.linalg.solve(A, q)
    return phi, 2 * phi[0] / (min(r, CAP) + 2)


def readout(h, phi, face):
    return p1_readout(h, phi, face, str_, g, muv)


for h in [51.2, 12.8, 6.4, 3.2, 1.6, 0.8, 0.4, 0.2]:
    phi, face = solve(h)
    print(f"cell {h:5.1f} mean free paths: L orders>=2 {readout(h, phi, face):.4f}")
