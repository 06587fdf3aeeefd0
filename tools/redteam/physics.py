"""Red-team physics: one or two carts on springs, written from the lab's physics only.

Independent of `ident`, `daq` and `testkit` (it imports none of them): an event-driven
integration with `scipy.integrate.solve_ivp` (DOP853, tight tolerances), so dry friction's
stops and break-aways are located as events instead of being stepped over.

Chain (positions `x_i` in metres from each cart's own rest, velocities `v_i`):

    m1 a1 = -k1 (x1 + e1 x1³) - k2 (x1 - x2) - c1 v1 - q1 v1|v1| m1 - F1 + H1
    m2 a2 = -k3 (x2 + e3 x2³) - k2 (x2 - x1) - c2 v2 - q2 v2|v2| m2 - F2 + H2

`e` (1/m²) makes the wall spring cubic (hardening e > 0, softening e < 0), `q` (1/m) is
quadratic drag per unit mass, `F_i` dry friction: kinetic `fk_i` (N) opposing the sliding
velocity, static `fs_i ≥ fk_i` holding a stopped cart while the other forces stay below it.
`H_i` is a hand: either a position constraint (the cart follows a hand path `p(t)`, its
equation is not integrated) or a soft spring-damper to a wandering hand position `h(t)`,
`H = -kh (x - h(t)) - ch (v - h'(t))` (a loosely held cart). A motor's force `G u` may be
added to a cart (`Cart.force`, constant within a `run`: a pulse is three runs). One cart is the chain with
`m2` absent (`k2` is then a spring to the wall).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

Path = Callable[[float], tuple[float, float]]  # t -> (position m, velocity m/s)


@dataclass
class Cart:
    """One cart: mass (kg), damping to ground (N s/m), friction (N), drag (1/m)."""

    m: float
    c: float = 0.0
    fk: float = 0.0
    fs: float = 0.0
    q: float = 0.0
    # soft hand (a loosely held cart): stiffness N/m, damping N s/m, hand position path
    kh: float = 0.0
    ch: float = 0.0
    h: Path | None = None
    # an applied force (a motor through its rack), N: constant within a run, set between runs
    force: float = 0.0


@dataclass
class Chain:
    """wall -k1- cart1 [-k2- cart2 -k3- wall]; one cart when `carts` has one entry."""

    carts: list[Cart]
    k1: float
    k2: float = 0.0
    k3: float = 0.0
    e1: float = 0.0
    e3: float = 0.0
    # hand position constraints: cart index -> path, set and cleared between segments
    held: dict[int, Path] = field(default_factory=dict)

    def forces(self, t: float, x: Sequence[float], v: Sequence[float]) -> list[float]:
        """Every force but dry friction on each cart (N), one per cart (scalar arithmetic: this
        runs at every stage of the integrator)."""
        n = len(self.carts)
        x0 = x[0]
        f = [-self.k1 * (x0 + self.e1 * x0 ** 3)]
        if n == 1:
            f[0] -= self.k2 * x0
        else:
            x1 = x[1]
            f[0] -= self.k2 * (x0 - x1)
            f.append(-self.k3 * (x1 + self.e3 * x1 ** 3) - self.k2 * (x1 - x0))
        for i, cart in enumerate(self.carts):
            vi = v[i]
            f[i] -= cart.c * vi + cart.q * cart.m * vi * abs(vi)
            if cart.h is not None:
                hp, hv = cart.h(t)
                f[i] -= cart.kh * (x[i] - hp) + cart.ch * (vi - hv)
            f[i] += cart.force
        return f


class Simulator:
    """Advance a chain through segments; modes per cart: 'slide' (sign s), 'stick', 'hand'."""

    def __init__(self, chain: Chain, x0: np.ndarray, v0: np.ndarray, t0: float) -> None:
        self.chain = chain
        self.x = np.array(x0, dtype=np.float64)
        self.v = np.array(v0, dtype=np.float64)
        self.t = float(t0)
        self.mode: list[str] = ["slide"] * len(chain.carts)
        self.sign = np.zeros(len(chain.carts))
        self._classify()

    def _classify(self) -> None:
        """Pick each free cart's mode from its state (stopped carts stick or break away)."""
        f = self.chain.forces(self.t, self.x, self.v)
        for i, cart in enumerate(self.chain.carts):
            if i in self.chain.held:
                self.mode[i] = "hand"
                continue
            if cart.fk <= 0.0:
                self.mode[i], self.sign[i] = "slide", 0.0
            elif abs(self.v[i]) > 1e-12:
                self.mode[i], self.sign[i] = "slide", np.sign(self.v[i])
            elif abs(f[i]) < cart.fs * (1 - 1e-7):  # at a break-away event |f| = fs: slide
                self.mode[i], self.v[i] = "stick", 0.0
            else:
                self.mode[i], self.sign[i] = "slide", np.sign(f[i])

    def _unpack(self, t: float, s: Sequence[float]) -> tuple[list[float], list[float]]:
        x, v = [float(a) for a in self.x], [float(a) for a in self.v]
        for j, i in enumerate(self._free):
            x[i], v[i] = float(s[2 * j]), float(s[2 * j + 1])
        for i, p in self.chain.held.items():
            x[i], v[i] = p(t)
        return x, v

    def run(self, t_end: float, t_out: np.ndarray) -> np.ndarray:
        """Integrate to `t_end`; return positions at `t_out` (those within the span), (len, n)."""
        out = np.full((len(t_out), len(self.chain.carts)), np.nan)
        for _ in range(100000):  # bounded: each pass ends at an event or at t_end
            if self.t >= t_end - 1e-12:
                break
            self._classify()
            self._segment(t_end, t_out, out)
        return out

    def _segment(self, t_end: float, t_out: np.ndarray, out: np.ndarray) -> None:
        self._free = [i for i in range(len(self.chain.carts)) if self.mode[i] != "hand"]
        s0 = np.ravel([[self.x[i], self.v[i]] for i in self._free]) if self._free else np.zeros(0)

        carts = self.chain.carts
        # per free cart: sliding, and its kinetic friction with the sliding sign (N)
        sliding = [self.mode[i] == "slide" for i in self._free]
        kinetic = [carts[i].fk * self.sign[i] for i in self._free]

        def rhs(t: float, s: np.ndarray) -> np.ndarray:
            x, v = self._unpack(t, s.tolist())
            f = self.chain.forces(t, x, v)
            d = [0.0] * (2 * len(self._free))
            for j, i in enumerate(self._free):
                if sliding[j]:
                    d[2 * j], d[2 * j + 1] = v[i], (f[i] - kinetic[j]) / carts[i].m
            return np.array(d)

        events = []
        for j, i in enumerate(self._free):
            cart = self.chain.carts[i]
            if self.mode[i] == "slide" and cart.fk > 0:
                ev = _event(lambda t, s, j=j: s[2 * j + 1], -self.sign[i])
            elif self.mode[i] == "stick":
                ev = _event(lambda t, s, i=i, cart=cart: abs(self._force(t, s, i)) - cart.fs, 1.0)
            else:
                continue
            events.append(ev)
        if not self._free:
            sol_t, state = t_end, s0
            self._emit_held(t_out, out, self.t, t_end)
        else:
            sol = solve_ivp(rhs, (self.t, t_end), s0, method="DOP853", rtol=1e-10, atol=1e-12,
                            events=events or None, dense_output=True, max_step=0.01)
            # at the span's end take t_end itself (sol.t[-1] may fall an ulp short, and an input
            # switched on at t_end would then be seen as an event at once, again and again)
            sol_t = float(t_end) if sol.status == 0 else float(sol.t[-1])
            state = sol.y[:, -1]
            sel = np.flatnonzero((t_out >= self.t) & (t_out <= sol_t))
            if sel.size:
                states = sol.sol(t_out[sel])            # (2 free, len(sel)), one call
                for j, i in enumerate(self._free):
                    out[sel, i] = states[2 * j]
                for i, p in self.chain.held.items():
                    out[sel, i] = [p(float(tk))[0] for tk in t_out[sel]]
        x, v = self._unpack(sol_t, state)
        for i in self._free:
            if self.mode[i] == "slide" and self.chain.carts[i].fk > 0 and abs(v[i]) < 1e-9:
                v[i] = 0.0  # stopped at a velocity event: _classify decides stick or reverse
        self.x, self.v, self.t = np.array(x), np.array(v), sol_t

    def _force(self, t: float, s: np.ndarray, i: int) -> float:
        x, v = self._unpack(t, s)
        return float(self.chain.forces(t, x, v)[i])

    def _emit_held(self, t_out: np.ndarray, out: np.ndarray, t0: float, t1: float) -> None:
        for k in np.flatnonzero((t_out >= t0) & (t_out <= t1)):
            x, _ = self._unpack(float(t_out[k]), np.zeros(0))
            out[k] = x


def _event(fun: Callable[[float, np.ndarray], float], direction: float) -> Callable[..., float]:
    fun.terminal = True  # type: ignore[attr-defined]
    fun.direction = direction  # type: ignore[attr-defined]
    return fun


def quintic(t0: float, t1: float, a: tuple[float, float, float], b: tuple[float, float, float]) -> Path:
    """A hand path from (x, v, acc) `a` at t0 to `b` at t1 (quintic), constant outside."""
    d = t1 - t0
    m = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0],
                  [1, d, d**2, d**3, d**4, d**5], [0, 1, 2 * d, 3 * d**2, 4 * d**3, 5 * d**4],
                  [0, 0, 2, 6 * d, 12 * d**2, 20 * d**3]], dtype=np.float64)
    coef = np.linalg.solve(m, np.array([*a, *b], dtype=np.float64))
    dcoef = coef[1:] * np.arange(1, 6)

    def path(t: float) -> tuple[float, float]:
        if t >= t1:
            return b[0] + b[1] * (t - t1), b[1]
        tau = max(t - t0, 0.0)
        return float(np.polyval(coef[::-1], tau)), float(np.polyval(dcoef[::-1], tau))

    return path


def wander(rng: np.random.Generator, peak_to_peak: float, f_lo: float = 0.05, f_hi: float = 0.6) -> Path:
    """A smooth hand wander: three sinusoids scaled to roughly the given peak-to-peak (m)."""
    f = rng.uniform(f_lo, f_hi, 3)
    ph = rng.uniform(0, 2 * np.pi, 3)
    amp = rng.uniform(0.3, 1.0, 3)
    amp *= peak_to_peak / (2 * amp.sum())

    def path(t: float) -> tuple[float, float]:
        w = 2 * np.pi * f
        return float(np.sum(amp * np.sin(w * t + ph))), float(np.sum(amp * w * np.cos(w * t + ph)))

    return path
