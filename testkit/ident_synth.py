"""Synthetic runs for the identification tests, generated independently of `ident`.

The ODEs are written out here (not taken from `ident.physics`) and integrated with scipy's
DOP853 at rtol 1e-10 from the release instant; noise is seeded. The code under test gets
only t, a step input whose time is wrong or estimated, and y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

FloatArray = NDArray[np.float64]

NOISE_M = 1e-4
PULL_M = 0.15
#: the reference cases of shared/reference/sysid_peers.md
CART1 = {"m": 0.727, "k": 39.0, "c": 0.553, "t_r": 0.891}
CART2 = {"m1": 0.833, "m2": 1.098, "k1": 31.2, "k2": 60.4, "k3": 76.5, "c1": 0.150, "c2": 0.290,
         "t_r": 0.596}


@dataclass(frozen=True)
class Run:
    t: FloatArray
    y: FloatArray
    y_clean: FloatArray
    release_time_s: float
    wn: FloatArray
    zeta: FloatArray


def _modes(a: FloatArray) -> tuple[FloatArray, FloatArray]:
    poles = np.linalg.eigvals(a)
    upper = sorted([p for p in poles if p.imag > 0], key=abs)
    wn = np.array([abs(p) for p in upper])
    return wn, np.array([-p.real / abs(p) for p in upper])


def _integrate(a: FloatArray, b: FloatArray, c: FloatArray, t: FloatArray, t_r: float,
               seed: int, noise: float) -> Run:
    y = np.zeros((t.size, c.shape[0]))
    after = t >= t_r
    sol = solve_ivp(lambda _, x: a @ x + b * PULL_M, (t_r, float(t[-1])), np.zeros(a.shape[0]),
                    t_eval=t[after], method="DOP853", rtol=1e-10, atol=1e-14)
    y[after] = (c @ sol.y).T
    rng = np.random.default_rng(seed)
    wn, zeta = _modes(a)
    return Run(t, y + noise * rng.standard_normal(y.shape), y, t_r, wn, zeta)


def cart1_run(fs: float, seed: int = 1, duration: float = 8.0, noise: float = NOISE_M) -> Run:
    """m x'' + c x' + k (x - r) = 0, r = 0.15 H(t - t_r)."""
    m, k, c = CART1["m"], CART1["k"], CART1["c"]
    a = np.array([[0.0, 1.0], [-k / m, -c / m]])
    b = np.array([0.0, k / m])
    t = np.arange(0.0, duration, 1.0 / fs, dtype=np.float64)
    return _integrate(a, b, np.array([[1.0, 0.0]]), t, CART1["t_r"], seed, noise)


def cart2_run(fs: float, seed: int = 2, structure: str = "release", duration: float = 8.0,
              noise: float = NOISE_M) -> Run:
    """M x'' + C x' + K x = f r: release (f = K (1, 0)ᵀ, case 3) or anchor (f = (k1, 0))."""
    p = CART2
    mass = np.diag([p["m1"], p["m2"]])
    stiff = np.array([[p["k1"] + p["k2"], -p["k2"]], [-p["k2"], p["k2"] + p["k3"]]])
    damp = np.diag([p["c1"], p["c2"]])
    f = stiff @ np.array([1.0, 0.0]) if structure == "release" else np.array([p["k1"], 0.0])
    m_inv = np.linalg.inv(mass)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-m_inv @ stiff, -m_inv @ damp]])
    b = np.concatenate([np.zeros(2), m_inv @ f])
    t = np.arange(0.0, duration, 1.0 / fs, dtype=np.float64)
    return _integrate(a, b, np.hstack([np.eye(2), np.zeros((2, 2))]), t, p["t_r"], seed, noise)


def step(t: FloatArray, at: float) -> FloatArray:
    return np.where(t >= at, PULL_M, 0.0)
