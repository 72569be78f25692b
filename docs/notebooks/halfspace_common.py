"""What the half-space notebooks share (docs/accuracy.md): Henyey-Greenstein evaluation and
sampling, the one-dimensional diffusion grid of core/lighting/diffusion.cpp and march's P1
readout integrated along a view. Medium z > 0 in optical-depth units (sigma_t = 1)."""
import numpy as np

CAP = 3.0  # kDiffusionMaxBoundaryResistance


def hg(c, g):
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * c) ** 1.5)


def sample_hg(rng, d, g):
    """Directions scattered from unit directions d (rows) by HG g."""
    n = len(d)
    u = rng.random(n)
    c = (1 + g * g - ((1 - g * g) / (1 - g + 2 * g * u)) ** 2) / (2 * g)
    s = np.sqrt(np.maximum(0, 1 - c * c))
    ph = 2 * np.pi * rng.random(n)
    t = np.where(np.abs(d[:, 0:1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    b1 = np.cross(d, t)
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    b2 = np.cross(d, b1)
    return c[:, None] * d + (s * np.cos(ph))[:, None] * b1 + (s * np.sin(ph))[:, None] * b2


def grid_matrix(n, h, str_, sigma_a):
    """The grid's system on n cells of h mean free paths: absorption sigma_a h per cell,
    conductances 1 / (2 r) between cells (r = 1.5 h sigma_t'), Marshak's boundary
    1 / (min(r, CAP) + 2) at the surface. Returns the matrix, r and the boundary conductance."""
    r = 1.5 * h * str_
    G, Gb = 1.0 / (2 * r), 1.0 / (min(r, CAP) + 2.0)
    A = np.zeros((n, n))
    for i in range(n):
        A[i, i] += sigma_a * h + (Gb if i == 0 else 0.0)
        if i > 0:
            A[i, i] += G
            A[i, i - 1] -= G
        if i < n - 1:
            A[i, i] += G
            A[i, i + 1] -= G
    return A, r, Gb


def p1_readout(h, phi, face, str_, g, muv, albedo=1.0):
    """march's readout sigma_s (phi + 3 g F . wo) / 4 pi of the linear interpolant (the empty
    neighbour holding the face value at its centre), integrated along a view leaving at cosine
    muv: the radiance the viewer sees."""
    dz = 0.001
    z = np.arange(0, 40, dz) + dz / 2
    xs = np.concatenate([[-0.5 * h], (np.arange(len(phi)) + 0.5) * h])
    ys = np.concatenate([[face], phi])
    ph = np.interp(z, xs, ys)
    idx = np.searchsorted(xs, z) - 1
    F = np.clip(-(ys[idx + 1] - ys[idx]) / h / (3 * str_), -ph, ph)
    S = albedo * np.maximum((ph + 3 * g * F * (-muv)) / (4 * np.pi), 0)
    return (S * np.exp(-z / muv) * dz / muv).sum()
