#!/usr/bin/python3
"""How far any mix of march's own light terms can come on the thick rows of the validation matrix,
for docs/accuracy.md ("The thick rows: what march's terms can and cannot carry", stop 68).

For each case of a suite CSV, the reference (the mean of its two cached halves) is fitted over
the cloud's pixels and R, G, B by a non-negative least-squares mix of march images of the same
case rendered with other settings (each a suite cache folder whose CASE.march.exr holds one), with
weights chosen per case: an oracle no renderer can have, since it reads the reference. The error
of each fit is the suite's (RMSE over the mean, the reference's noise taken out in quadrature).
If no mix reaches 10%, no single-scene calibration of those terms can, and a model fitted once
across the matrix cannot either.

usage: thick_oracle.py SUITE.csv REFDIR BASEDIR NAME=DIR [NAME=DIR ...]
  SUITE.csv   the suite's CSV of the cases (its case and reference_noise columns)
  REFDIR      the folder of the cached references (CASE.a.exr, CASE.b.exr)
  BASEDIR     the folder whose CASE.march.exr is march as it renders by default
  NAME=DIR    a term: the folder whose CASE.march.exr is march rendered with that term's settings
Every subset of the terms is fitted, each by a least squares that tries every subset of its
columns: meant for a handful of terms (the work grows as 2^n).
(needs numpy and oiiotool; not a build dependency)
"""
import csv
import itertools
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests",
                                "bench"))
from image_compare import exr  # noqa: E402


def nnls(X, y):
    """Non-negative least squares by trying every subset of the (few) columns."""
    best, best_r = np.zeros(X.shape[1]), np.inf
    for k in range(1, X.shape[1] + 1):
        for cols in itertools.combinations(range(X.shape[1]), k):
            w, *_ = np.linalg.lstsq(X[:, cols], y, rcond=None)
            if (w < 0).any():
                continue
            full = np.zeros(X.shape[1])
            full[list(cols)] = w
            r = float(((X @ full - y) ** 2).sum())
            if r < best_r:
                best, best_r = full, r
    return best


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    suite_csv, refdir, basedir = sys.argv[1:4]
    terms = dict(a.split("=", 1) for a in sys.argv[4:])
    fits = {"default": [], "default, scaled": []}
    names = list(terms)
    for k in range(1, len(names) + 1):
        for combo in itertools.combinations(names, k):
            fits[" + ".join(combo)] = []
    for row in csv.DictReader(open(suite_csv)):
        case, noise = row["case"], float(row["reference_noise"])
        key = case.replace("/", ".")
        R = 0.5 * (exr(f"{refdir}/{key}.a.exr", 4) + exr(f"{refdir}/{key}.b.exr", 4))
        m = R[:, :, 3] > 0.01
        y = R[m][:, :3].ravel()
        mean = y.mean()

        def err(pred):
            e = np.sqrt(((pred - y) ** 2).mean()) / mean
            return np.sqrt(max(0.0, e * e - noise * noise))

        base = exr(f"{basedir}/{key}.march.exr")[m][:, :3].ravel()
        F = {n: exr(f"{d}/{key}.march.exr")[m][:, :3].ravel() for n, d in terms.items()}
        fits["default"].append(err(base))
        fits["default, scaled"].append(err(base * (y @ base) / (base @ base)))
        line = f"{case:52s} default {fits['default'][-1]:6.1%}"
        for name in list(fits)[2:]:
            X = np.stack([F[n] for n in name.split(" + ")], 1)
            fits[name].append(err(X @ nnls(X, y)))
        line += f"  best mix {fits[list(fits)[-1]][-1]:6.1%}"
        print(line)
    print()
    print("| march, weights per case | within 10% | median |")
    print("|---|---|---|")
    for name, v in fits.items():
        print(f"| {name} | {sum(e <= 0.1 for e in v)} of {len(v)} | {np.median(v):.1%} |")


if __name__ == "__main__":
    main()
