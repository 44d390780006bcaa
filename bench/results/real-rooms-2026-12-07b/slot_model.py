#!/usr/bin/env python3
"""A model of the light behind the lounge's bookcase (docs/performance.md, "A gap's rays drawn
uniformly"): why a texel in a narrow gap is gathered with uniform rays, not cosine-weighted ones.

A point on the bookcase's back (x = 0, facing +x) looks at the wall 2.5 cm away across a slot
open at its sides (|z| = 0.6 m) and its top (y = 2 m), closed by the floor. A ray that leaves the
slot sees the lit room (radiance 1); one that meets the wall inside it sees the slot's own light,
0.3 at the slot's mouth falling off with e-fold 3.5 cm into it (the profile measured there); one
that meets the floor inside it sees 0.01. Per estimator: the mean (relative to the cosine
estimator's) and the standard deviation of one ray's estimate over that mean.

    python3 slot_model.py
"""
import numpy as np

GAP, FALL = 0.025, 0.035
rng = np.random.default_rng(1)


def radiance(p, d):
    t = GAP / d[:, 0]
    hit = p + t[:, None] * d
    out = (np.abs(hit[:, 2]) > 0.6) | (hit[:, 1] > 2.0)
    depth = np.maximum(np.minimum(0.6 - np.abs(hit[:, 2]), 2.0 - hit[:, 1]), 0.0)
    inside = np.where(hit[:, 1] < 0.0, 0.01, 0.3 * np.exp(-depth / FALL))
    return np.where(out, 1.0, inside)


def estimate(p, n, kind):
    u1, u2 = rng.random(n), rng.random(n)
    if kind == "cosine":
        c, w = np.sqrt(1.0 - u1), np.ones(n)
    else:  # uniform over the hemisphere, weight 2 cos
        c = 1.0 - u1
        w = 2.0 * c
    s = np.sqrt(1.0 - c * c)
    phi = 2.0 * np.pi * u2
    d = np.stack([c, s * np.cos(phi), s * np.sin(phi)], 1)
    return radiance(p, d) * w


for y, z in [(0.40, -0.08), (1.46, -0.28), (1.41, 0.57), (0.72, -0.53), (0.81, 0.51)]:
    p = np.array([0.0, y, z])
    cos, uni = estimate(p, 400_000, "cosine"), estimate(p, 400_000, "uniform")
    m = cos.mean()
    print(f"y {y:.2f} z {z:+.2f}: cosine sd/mean {cos.std() / m:5.1f}, uniform mean "
          f"{uni.mean() / m:.3f} sd/mean {uni.std() / m:5.1f}, variance ratio "
          f"{cos.var() / uni.var():5.1f}")
