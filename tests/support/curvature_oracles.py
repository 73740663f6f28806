"""Closed-form oracles for the curvature tests: derivatives and curvatures of surfaces of
revolution written out by hand, independent of gshade's patches and formulas.

p(theta, phi) = (rho(phi) cos theta, rho(phi) sin theta, z(phi)) for
torus     rho = R + r cos phi, z = r sin phi:  K = cos phi / (r (R + r cos phi)),
          k = 1/r around the tube and cos phi / (R + r cos phi) along the parallel;
sphere    the torus with R = 0:                K = 1/r^2, k1 = k2 = 1/r;
cylinder  rho = r, z = phi:                    K = 0, k = 1/r around it and 0 along it;
all for the outward normal bent away from (curvatures negative; do Carmo §3-3, Ex. 4).
The derivatives are taken in the sheared parameters (s, t) = (theta - SHEAR phi, phi), so that
F and M are not 0: d/ds = d/dtheta, d/dt = SHEAR d/dtheta + d/dphi.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np

ORDER = 3
SHEAR = 0.6


@dataclass
class Oracle:
    """Derivatives d (shape (4, 4, n, 3), in s and t) of a surface of revolution at n points
    and its curvatures w.r.t. N = p_s x p_t = p_theta x p_phi (sign = <N, outward> / |N|)."""

    d: np.ndarray
    p_theta: np.ndarray
    p_phi: np.ndarray
    sign: np.ndarray
    k_around: np.ndarray  # the normal curvature along p_theta (the parallel)
    k_along: np.ndarray  # along p_phi (the meridian)
    dK_dphi: np.ndarray
    dH_dphi: np.ndarray

    @property
    def K(self):
        return self.k_around * self.k_along

    @property
    def H(self):
        return (self.k_around + self.k_along) / 2

    @property
    def half_gap(self):
        return np.abs(self.k_around - self.k_along) / 2


def _revolution(rho: list, z: list, theta: np.ndarray) -> np.ndarray:
    """d^(a+b) p / ds^a dt^b from the profile's derivatives rho[b], z[b] (b <= ORDER)."""
    n = 2 * ORDER + 1
    polar = np.zeros((n, ORDER + 1, len(theta), 3))  # d^(a+b) p / dtheta^a dphi^b
    for a in range(n):
        for b in range(ORDER + 1):
            polar[a, b, :, 0] = rho[b] * np.cos(theta + a * np.pi / 2)
            polar[a, b, :, 1] = rho[b] * np.sin(theta + a * np.pi / 2)
            polar[a, b, :, 2] = z[b] if a == 0 else 0.0
    d = np.zeros((ORDER + 1, ORDER + 1, len(theta), 3))
    for a in range(ORDER + 1):
        for b in range(ORDER + 1):
            for k in range(b + 1):  # (SHEAR d/dtheta + d/dphi)^b
                d[a, b] += comb(b, k) * SHEAR**k * polar[a + k, b - k]
    return d


def surface(name: str, n: int = 200, seed: int = 3) -> Oracle:
    """The oracle at n random points (the sphere away from its poles)."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0, 2 * np.pi, n)
    phi = rng.uniform(-1.4, 1.4, n) if name == "sphere" else rng.uniform(-np.pi, np.pi, n)
    c, s = np.cos(phi), np.sin(phi)
    if name == "cylinder":
        r = 0.75
        rho = [np.full(n, r), *(np.zeros(n) for _ in range(ORDER))]
        z = [phi, np.ones(n), *(np.zeros(n) for _ in range(ORDER - 1))]
        d = _revolution(rho, z, theta)
        outward = np.stack([np.cos(theta), np.sin(theta), 0 * theta], -1)
        k_around, k_along = np.full(n, -1 / r), np.zeros(n)
        dK, dH = np.zeros(n), np.zeros(n)
    else:
        R, r = (0.0, 1.3) if name == "sphere" else (2.5, 0.8)
        rho = [r * np.cos(phi + b * np.pi / 2) for b in range(ORDER + 1)]
        rho[0] = R + rho[0]
        z = [r * np.sin(phi + b * np.pi / 2) for b in range(ORDER + 1)]
        d = _revolution(rho, z, theta)
        outward = np.stack([c * np.cos(theta), c * np.sin(theta), s], -1)
        k_around, k_along = -c / (R + r * c), np.full(n, -1 / r)
        dK = -R * s / (r * (R + r * c) ** 2)
        dH = R * s / (2 * (R + r * c) ** 2)
    p_theta, p_phi = d[1, 0], d[0, 1] - SHEAR * d[1, 0]
    N = np.cross(d[1, 0], d[0, 1])
    sign = np.sign(np.sum(N * outward, -1))
    assert np.all(sign == sign[0])  # one orientation everywhere
    return Oracle(d, p_theta, p_phi, sign, sign * k_around, sign * k_along, dK, sign * dH)
