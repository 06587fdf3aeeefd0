"""Seeded runs with a hidden physical effect, generated independently of `ident`.

A chain of masses (`anchor –k1– m1 –k2– m2 ... – wall`, viscous dampers to ground) is held
with cart 1 pulled by `step` and released at `t_r` (positions read 0 while held; the carts
settle at (step, 0, ...)). The ODEs are written out here and integrated by scipy's DOP853
at rtol 1e-10; dry friction uses an event-driven hybrid integrator (slip in each direction,
stick while |spring + damper force| ≤ f, exact stick and break-away events). Nothing here
imports `ident`: the code under test only ever sees the CSV (or t, y arrays).

Effects (magnitudes drawn inside physically plausible ranges, stated per effect):
- coulomb_friction: f_i = r·wn²·step/4 per cart, r ∈ [0.02, 0.15] (peaks lose 2–15 % of the
  step per cycle);
- quadratic_drag: c_q = r·3/(4 step), r ∈ [0.03, 0.15] (first half-cycle loses 3–15 %);
- cubic_stiffness: κ = r·8 wn²/(3 step²), r ∈ [0.005, 0.04] (frequency shift at the step);
- quantization: the encoder reports q·round((x + jitter)/q), q ∈ [1e-5, 3e-4] m, mechanical
  jitter below a tenth of a count;
- coupled_mode: an extra light mass (5–30 % of a cart) on a stiff spring behind the last
  observed cart, its mode 1.6–4× the main frequency, redrawn until that mode shows in the
  observed carts with ≥ 5× the noise and decays no faster than 2/s;
- none: the linear chain.
Other draws: sampling 50–1000 Hz (log-uniform), 4–10 s after a release at 0.2–1.5 s, step
0.05–0.2 m, noise 2e-5–2e-4 m (log-uniform; quantized runs carry only the quantization),
one cart wn 5–20 rad/s and zeta 0.005–0.05, two carts masses 0.5–1.5 kg, springs 20–120 N/m.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

FloatArray = NDArray[np.float64]

EFFECTS = ("coulomb_friction", "quadratic_drag", "cubic_stiffness", "quantization", "coupled_mode", "none")
RTOL, ATOL = 1e-10, 1e-13


@dataclass(frozen=True)
class HiddenCase:
    seed: int
    effect: str
    carts: int
    t: FloatArray
    y: FloatArray                       # (N, carts) m, as measured
    truth: dict[str, float] = field(default_factory=dict)
    rate_hz: float = 0.0
    noise_m: float = 0.0
    release_s: float = 0.0


@dataclass(frozen=True)
class Chain:
    kt: FloatArray      # (n, n) mass-normalised stiffness
    ct: FloatArray      # (n, n) mass-normalised damping

    def main_wn(self, observed: int) -> float:
        lam = np.linalg.eigvals(self._a())
        return float(np.min(np.abs(lam)))

    def _a(self) -> FloatArray:
        n = self.kt.shape[0]
        return np.block([[np.zeros((n, n)), np.eye(n)], [-self.kt, -self.ct]])


def _chain(masses: FloatArray, springs: FloatArray, dampers: FloatArray) -> Chain:
    """springs k_1..k_{n+1} (anchor-m1, m1-m2, ..., mn-wall), dampers c_i to ground."""
    n = masses.size
    k = np.zeros((n, n))
    for i in range(n):
        k[i, i] = springs[i] + springs[i + 1]
        if i + 1 < n:
            k[i, i + 1] = k[i + 1, i] = -springs[i + 1]
    return Chain(k / masses[:, None], np.diag(dampers / masses))


def _smooth(chain: Chain, z0: FloatArray, tau: FloatArray, cubic: float, drag: float) -> FloatArray:
    n = chain.kt.shape[0]

    def rhs(_: float, s: FloatArray) -> FloatArray:
        x, v = s[:n], s[n:]
        a = -chain.kt @ x - chain.ct @ v - cubic * x ** 3 - drag * v * np.abs(v)
        return np.concatenate([v, a])

    sol = solve_ivp(rhs, (0.0, float(tau[-1])), z0, t_eval=tau, rtol=RTOL, atol=ATOL, method="DOP853")
    return np.asarray(sol.y[:n].T)


def _coulomb(chain: Chain, z0: FloatArray, tau: FloatArray, f: FloatArray) -> FloatArray:
    """Hybrid slip/stick integration; f (n,) friction accelerations (m/s²)."""
    n = chain.kt.shape[0]
    out = np.empty((tau.size, n))
    state = z0.astype(float).copy()
    t0 = 0.0
    mode = np.zeros(n)              # +1/-1 slipping in that direction, 0 stuck

    def spring(s: FloatArray) -> FloatArray:
        return np.asarray(-chain.kt @ s[:n] - chain.ct @ s[n:])

    def classify(s: FloatArray, i: int) -> float:
        a = spring(s)[i]
        return 0.0 if abs(a) <= f[i] else float(np.sign(a))

    for i in range(n):
        mode[i] = classify(state, i) if state[n + i] == 0 else np.sign(state[n + i])
    for _ in range(20000):
        m = mode.copy()

        def rhs(_: float, s: FloatArray, m: FloatArray = m) -> FloatArray:
            a = spring(s) - f * m
            v = s[n:].copy()
            a[m == 0] = 0.0
            v[m == 0] = 0.0
            return np.concatenate([v, a])

        events, owners = [], []
        for i in range(n):
            if m[i] != 0:
                # fires just past the velocity zero (scipy may report a zero at the start point)
                def stops(_t: float, s: FloatArray, i: int = i, m: FloatArray = m) -> float:
                    return float(s[n + i] * m[i] + 1e-12)
                stops.terminal, stops.direction = True, -1    # type: ignore[attr-defined]
                events.append(stops)
                owners.append((i, 0.0))
            elif f[i] > 0:
                for sgn in (1.0, -1.0):
                    def breaks_away(_t: float, s: FloatArray, i: int = i, sgn: float = sgn) -> float:
                        return float(sgn * spring(s)[i] - f[i])
                    breaks_away.terminal, breaks_away.direction = True, 1  # type: ignore[attr-defined]
                    events.append(breaks_away)
                    owners.append((i, sgn))
        todo = tau >= t0
        if np.all(m == 0):
            out[todo] = state[:n]
            return out
        sol = solve_ivp(rhs, (t0, float(tau[-1])), state, rtol=RTOL, atol=ATOL, method="DOP853",
                        events=events, dense_output=True)
        t1 = float(sol.t[-1])
        seg = todo & (tau <= t1)
        if np.any(seg):
            out[seg] = sol.sol(tau[seg])[:n].T
        if sol.status == 0:
            return out
        state = sol.y[:, -1].copy()
        fired = [k for k, te in enumerate(sol.t_events) if te.size]
        i, sgn = owners[fired[0]]
        if sgn == 0.0:                  # a slipping cart came to rest: stick or reverse
            state[n + i] = 0.0
            mode[i] = classify(state, i)
        else:                           # a stuck cart breaks away in the direction of the force
            mode[i] = sgn
        t0 = t1
    raise RuntimeError("too many friction events")


def _draw_chain(rng: np.random.Generator, carts: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    if carts == 1:
        wn, zeta = rng.uniform(5.0, 20.0), rng.uniform(0.005, 0.05)
        m = rng.uniform(0.5, 1.5)
        return np.array([m]), np.array([wn * wn * m, 0.0]), np.array([2 * zeta * wn * m])
    masses = rng.uniform(0.5, 1.5, 2)
    springs = rng.uniform(20.0, 120.0, 3)
    zeta = rng.uniform(0.005, 0.04, 2)
    dampers = 2 * zeta * np.sqrt((springs[:2] + springs[1:]) * masses)
    return masses, springs, dampers


def make_case(seed: int, effect: str | None = None, carts: int | None = None,
              flick: bool = False) -> HiddenCase:
    """One run with a hidden effect; effect and carts drawn by the seed unless given.

    `flick`: the hand does not let go from rest but moves cart 1 for 0.1–0.2 s (a smooth
    cubic from the held position) and lets go while it moves (velocity 0.2–0.6 wn·step
    towards rest, position up to ±30 % of the step from the held one).
    """
    rng = np.random.default_rng(seed)
    effect = effect or str(rng.choice(EFFECTS))
    carts = carts or int(rng.integers(1, 3))
    rate = float(np.exp(rng.uniform(np.log(50.0), np.log(1000.0))))
    t_r = rng.uniform(0.2, 1.5)
    length = rng.uniform(4.0, 10.0)
    step = rng.uniform(0.05, 0.2)
    noise = float(np.exp(rng.uniform(np.log(2e-5), np.log(2e-4))))
    masses, springs, dampers = _draw_chain(rng, carts)
    truth: dict[str, float] = {}
    if effect == "coupled_mode":
        masses, springs, dampers, truth = _add_mode(rng, masses, springs, dampers, carts, step, noise)
    chain = _chain(masses, springs, dampers)
    n = masses.size
    wn = chain.main_wn(carts)
    t = np.arange(int((t_r + length) * rate)) / rate
    tau = t[t >= t_r] - t_r
    z0 = np.zeros(2 * n)
    z0[0] = -step
    hand = None
    if flick:
        duration = rng.uniform(0.1, 0.2)
        x_rel, v_rel = rng.uniform(-0.3, 0.3) * step, rng.uniform(0.2, 0.6) * wn * step
        z0[0], z0[n] = x_rel - step, v_rel
        hand = (duration, x_rel, v_rel)
    if effect == "coulomb_friction":
        f = np.zeros(n)
        f[:carts] = rng.uniform(0.02, 0.15, carts) * wn * wn * step / 4
        z = _coulomb(chain, z0, tau, f)
        truth["coulomb_accel_m_s2"] = float(f[0])
        if carts == 2:
            truth["coulomb_accel_m_s2_cart2"] = float(f[1])
    else:
        cubic = rng.uniform(0.005, 0.04) * 8 * wn * wn / (3 * step * step) if effect == "cubic_stiffness" else 0.0
        drag = rng.uniform(0.03, 0.15) * 3 / (4 * step) if effect == "quadratic_drag" else 0.0
        z = _smooth(chain, z0, tau, cubic, drag)
        if cubic:
            truth["cubic_per_m2_s2"] = cubic
        if drag:
            truth["drag_per_m"] = drag
    rest = np.zeros(carts)
    rest[0] = step
    y = np.zeros((t.size, carts))
    y[t >= t_r] = rest + z[:, :carts]
    if hand is not None:
        duration, x_rel, v_rel = hand
        moving = (t >= t_r - duration) & (t < t_r)
        s_ = (t[moving] - (t_r - duration)) / duration
        # cubic Hermite from (0, 0) to (x_rel, v_rel·duration) in normalised time
        y[moving, 0] = (3 * s_ ** 2 - 2 * s_ ** 3) * x_rel + (s_ ** 3 - s_ ** 2) * v_rel * duration
    if effect == "quantization":
        q = float(np.exp(rng.uniform(np.log(1e-5), np.log(3e-4))))
        jitter = rng.uniform(0.0, 0.1) * q
        y = q * np.round((y + rng.normal(0.0, jitter, y.shape)) / q)
        truth["quantum_m"] = q
        noise = 0.0
    else:
        y = y + rng.normal(0.0, noise, y.shape)
    return HiddenCase(seed, effect, carts, t, y, truth, rate, noise, float(t_r))


def _add_mode(rng: np.random.Generator, masses: FloatArray, springs: FloatArray, dampers: FloatArray,
              carts: int, step: float, noise: float) -> tuple[FloatArray, FloatArray, FloatArray, dict[str, float]]:
    """An extra light mass behind cart `carts`, its own mode 1.6-4x the main one, drawn again
    (up to 200 times) until that mode rings in the observed carts with at least 5x the noise
    for at least half a second (otherwise the run has no visible second resonance)."""
    for _ in range(200):
        drawn = _draw_mode(rng, masses, springs, dampers, carts)
        amp, decay = _mode_visibility(drawn[0], drawn[1], drawn[2], carts, step)
        if amp >= 5.0 * noise and decay <= 2.0:
            return drawn
    return drawn


def _mode_visibility(masses: FloatArray, springs: FloatArray, dampers: FloatArray, carts: int,
                     step: float) -> tuple[float, float]:
    """Amplitude (m) in the observed carts and decay rate (1/s) of the highest mode."""
    chain = _chain(masses, springs, dampers)
    lam, vec = np.linalg.eig(chain._a())
    z0 = np.zeros(lam.size)
    z0[0] = -step
    coef = np.linalg.solve(vec, z0.astype(complex))
    top = int(np.argmax(np.abs(lam)))
    amp = float(2 * np.max(np.abs(vec[:carts, top] * coef[top])))
    return amp, float(-lam[top].real)


def _draw_mode(rng: np.random.Generator, masses: FloatArray, springs: FloatArray, dampers: FloatArray,
               carts: int) -> tuple[FloatArray, FloatArray, FloatArray, dict[str, float]]:
    base = _chain(masses, springs, dampers)
    m_e = rng.uniform(0.05, 0.3) * masses[-1]
    w_e = rng.uniform(1.6, 4.0) * float(np.max(np.abs(np.linalg.eigvals(base._a()))))
    k_c = rng.uniform(0.3, 0.7) * w_e * w_e * m_e
    k_w = w_e * w_e * m_e - k_c
    c_e = 2 * rng.uniform(0.003, 0.02) * w_e * m_e
    new_m = np.append(masses, m_e)
    # the far spring of the last cart now ends on the extra mass, which is tied to the wall
    new_k = np.concatenate([springs[:carts], [k_c, k_w]])
    new_c = np.append(dampers, c_e)
    chain = _chain(new_m, new_k, new_c)
    lam = np.linalg.eigvals(chain._a())
    top = float(np.max(np.abs(lam)))
    return new_m, new_k, new_c, {"mode_hz": top / (2 * np.pi)}


def write_csv(case: HiddenCase, path: Path) -> Path:
    """The run as `time_s,pos1_m[,pos2_m]` (what the code under test receives)."""
    header = ["time_s"] + [f"pos{i + 1}_m" for i in range(case.carts)]
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for k in range(case.t.size):
            writer.writerow([repr(float(case.t[k]))] + [repr(float(v)) for v in case.y[k]])
    return path
