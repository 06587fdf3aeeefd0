"""The Python of each identification in the report, with cartlab's public API.

The equivalent of the handout's MATLAB: load the exported run data (`data/<case>.csv`, the
samples the fits used, and `data/<case>.json`, the release time and pulled cart), the
simple identification by RK4 and by Euler simulation (`ident.fit_simple`), PEM of order 2
and 4 (`ident.pem`), the continuous transfer functions (`Model.tf()`), the simulation and
its plot, the diagnosis. These strings are the report's code blocks and the notebook's code
cells (`ident.report.notebook`); the notebook test runs them and checks their numbers equal
the report's. Renders only: the code is text here, never executed.
"""

from __future__ import annotations

from schemas.fit import LabCase

SETUP = """\
import json

import control
import matplotlib.pyplot as plt
import numpy as np

import ident
from ident.diagnose import diagnose

numbers = {}   # every number the report quotes, recomputed here
runs = {}      # case -> (data, meta)
held = {}      # case -> the other carts' positions (a held cart's motion: the diagnosis' input)
simple_fits = {}  # case -> (rk4, euler)"""


def load(case: LabCase) -> str:
    """Read `data/<case>.csv` (time, input, positions, held carts' positions) into `ident.IdData`."""
    return f"""\
table = np.loadtxt("data/{case}.csv", delimiter=",", skiprows=1, ndmin=2)
meta = json.loads(open("data/{case}.json").read())
n = len(meta["outputs"])
data = ident.IdData(t=table[:, 0], u=table[:, 1], y=table[:, 2:2 + n],
                    release_time_s=meta["release_time_s"], pulled_cart=meta["pulled_cart"])
numbers["{case}"] = {{}}
runs["{case}"] = (data, meta)
held["{case}"] = table[:, 2 + n:]
print(f"{{data.n_samples}} samples at {{1 / data.sample_time():.4g}} Hz, carts {{meta['outputs']}}")"""


def simple(case: LabCase) -> str:
    """Fit wn, zeta, gain and the release of the physical model, simulated by RK4 and Euler."""
    return f"""\
data, meta = runs["{case}"]
rk4 = ident.fit_simple(data, "rk4")      # the physical model simulated by Runge-Kutta 4
euler = ident.fit_simple(data, "euler")  # ... and by explicit Euler
for fit in (rk4, euler):
    G = control.tf([fit.gain * fit.wn**2], [1, 2 * fit.zeta * fit.wn, fit.wn**2])  # X(s)/R(s)
    print(f"{{fit.method}}: wn = {{fit.wn:.6g}} rad/s, zeta = {{fit.zeta:.6g}}, gain = {{fit.gain:.6g}}, "
          f"fit = {{fit.fit_percent[0]:.4f}} %")
    print(G)
    numbers["{case}"][fit.method] = {{"wn": fit.wn, "zeta": fit.zeta, "fit": fit.fit_percent[0]}}
simple_fits["{case}"] = (rk4, euler)"""


def pem(case: LabCase, order: int) -> str:
    """PEM of `order`, its continuous transfer functions, modes and fit %."""
    return f"""\
data, meta = runs["{case}"]
model = ident.pem(data, {order})          # prediction-error model, order {order}
for G in model.tf:                         # continuous-time X_i(s)/R(s) (d2c of the fit)
    print(G)
for mode in model.modes:
    print(f"mode: wn = {{mode.wn:.6g}} rad/s, zeta = {{mode.zeta:.6g}}")
print("fit % per cart:", [round(f, 4) for f in model.fit_percent])
numbers["{case}"]["pem"] = {{"wn": [m.wn for m in model.modes], "zeta": [m.zeta for m in model.modes],
                          "fit": list(model.fit_percent)}}"""


def simulate_and_plot(case: LabCase, simple_too: bool) -> str:
    """Simulate the identified model(s) and plot them against the measured positions."""
    extra = f"""
for fit, style in zip(simple_fits["{case}"], ("--", ":")):
    axes[0].plot(data.t, fit.simulate(data.u)[:, 0], style, linewidth=2, marker="o" if fit.method == "euler" else None,
                 markevery=max(1, data.n_samples // 40), fillstyle="none",
                 label=f"{{fit.method}} simulation")""" if simple_too else ""
    return f"""\
y_hat = model.simulate(data.u)             # free-run simulation from the release step
fig, axes = plt.subplots(data.n_outputs, 1, figsize=(7, 2.6 * data.n_outputs + 0.6), squeeze=False,
                         layout="constrained")
axes = axes[:, 0]
for j, ax in enumerate(axes):
    ax.plot(data.t, data.y[:, j], "-", linewidth=2, label="measured")
    ax.plot(data.t, y_hat[:, j], "-.", linewidth=2, label=f"PEM order {{model.order}} simulation")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"cart {{meta['outputs'][j]}} position (m)"){extra}
for ax in axes:
    ax.legend(loc="best")
plt.show()"""


def diagnosis(case: LabCase, carts: int, forced: bool = False) -> str:
    """What the linear simulation gets wrong: the effects and their held-out gains (`forced`:
    the run's input is a recorded force, the rig's drive, which the model takes too)."""
    drive = ("\n# the run began where the rig's drive switched: the model is driven by it too"
             if forced else "")
    force = ", u=data.u" if forced else ""
    return f"""\
data, meta = runs["{case}"]
# a held cart's measured motion enters as an input (its columns after the fitted carts'){drive}
found = diagnose(data.t, np.column_stack([data.y, held["{case}"]]), carts={carts}{force}).report
print(f"cause: {{found.cause}}, gain {{found.gain_points:+.3f}} fit-% points held out")
for c in found.candidates:
    print(f"  {{c.effect:18s}} gain {{c.gain_points:+.3f}}  significant: {{c.significant}}")
numbers["{case}"]["diagnosis"] = {{"cause": found.cause, "gain": found.gain_points}}"""


NUMBERS = """\
print(json.dumps(numbers))   # the numbers of this notebook, compared with the report's by the tests"""


__all__ = ["NUMBERS", "SETUP", "diagnosis", "load", "pem", "simple", "simulate_and_plot"]
