"""`ident fit PATH`: identify one run file and print the models (text or JSON).

Loads an MCAP run or a text export (`ident.io.load`), then fits PEM (order 2 per cart) and/or
the simple physical model by RK4 or Euler, and prints transfer functions, wn, zeta, fit %
and the release time. Exit status 0 on success, 2 on unusable input or a failed fit.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

import numpy as np

from ident.commands.run_file_options import add_run_file_options

METHODS = ("pem", "rk4", "euler", "all")


def add_parser(subparsers: Any) -> None:
    parser = subparsers.add_parser("fit", help="fit a run file: PEM and/or the physical model",
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_file_options(parser, "1: one cart (order 2), 2: both carts (order 4); default: the moving columns")
    parser.add_argument("--method", choices=METHODS, default="all")
    parser.add_argument("--input", dest="input_col", default=None,
                        help="input column (e.g. 'Control Effort' for a motor input); default: the release step")
    parser.add_argument("--rate", dest="rate_hz", type=float, default=None,
                        help="sample rate (Hz) of an export without a time column")
    parser.add_argument("--release", type=float, default=None, help="release time (s) if known")
    parser.add_argument("--step-m", type=float, default=0.15, help="pull distance (m), default 0.15")
    parser.add_argument("--order", type=int, default=None, help="PEM order (default: 2 per cart)")
    parser.add_argument("--noise-model", choices=("oe", "innovation"), default="oe",
                        help="PEM noise model: output error (white noise) or innovation form with K")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ident.errors import IdentError

    try:
        report = fit_file(args)
    except IdentError as exc:
        print(f"ident fit: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 0


def fit_file(args: argparse.Namespace) -> dict[str, Any]:
    """Load and fit as the arguments say; a JSON-ready report."""
    from ident.io import load
    from ident.release import motion_amplitude, moving_outputs

    data = load(args.path, args.time_col, args.pos_cols, args.scale, args.release, args.step_m,
                args.input_col, args.rate_hz)
    moving = moving_outputs(data.y)
    carts = args.carts or max(1, min(len(moving), 2))
    if carts == 1 and data.n_outputs > 1:
        column = (data.pulled_cart - 1 if data.pulled_cart in (1, 2) and data.pulled_cart - 1 in moving
                  else int(np.argmax(motion_amplitude(data.y))))
        data = data.select_outputs([column])
    elif carts == 2 and data.n_outputs < 2:
        from ident.errors import IdentValueError

        raise IdentValueError("--carts 2", "two position columns", f"{data.n_outputs}")
    report: dict[str, Any] = {"file": str(args.path), "n_samples": data.n_samples,
                              "sample_time_s": data.sample_time(), "n_outputs": data.n_outputs,
                              "release_time_s_given": data.release_time_s, "notes": list(data.notes),
                              "fits": []}
    methods = ["pem", "rk4", "euler"] if args.method == "all" else [args.method]
    for method in methods:
        if method == "pem":
            report["fits"].append(_pem_report(data, args.order or 2 * carts, args.noise_model))
        elif data.n_outputs == 1 and args.input_col is None:
            report["fits"].append(_simple_report(data, method))
    return report


def _pem_report(data: Any, order: int, noise_model: str = "oe") -> dict[str, Any]:
    from ident.pem import pem

    model = pem(data, order, noise_model=noise_model)  # type: ignore[arg-type]
    label = f"pem order {order}" + (" (innovation form)" if noise_model == "innovation" else "")
    return {"method": label, "release_time_s": model.release_time_s,
            "modes": [{"wn": m.wn, "wn_std": m.wn_std, "zeta": m.zeta, "zeta_std": m.zeta_std}
                      for m in model.modes],
            "outputs": [{"num": num.tolist(), "den": den.tolist(), "fit_percent": fit, "dc_gain": float(dc)}
                        for (num, den), fit, dc in zip(model.tf_coefficients(), model.fit_percent,
                                                       model.dc_gain, strict=True)],
            "converged": model.success}


def _simple_report(data: Any, method: str) -> dict[str, Any]:
    from ident.simple import fit_simple

    fit = fit_simple(data, method)  # type: ignore[arg-type]
    wn2 = fit.wn ** 2
    return {"method": f"simple {method}", "release_time_s": fit.release_time_s,
            "modes": [{"wn": fit.wn, "wn_std": fit.std_errors["wn"], "zeta": fit.zeta,
                       "zeta_std": fit.std_errors["zeta"]}],
            "outputs": [{"num": [fit.gain * wn2], "den": [1.0, 2 * fit.zeta * fit.wn, wn2],
                         "fit_percent": fit.fit_percent[0], "dc_gain": fit.gain}],
            "converged": fit.success}


def polynomial(coefficients: list[float]) -> str:
    """'1 s^2 + 0.76 s + 53.6' from coefficients, highest power first."""
    degree = len(coefficients) - 1
    terms = []
    for i, c in enumerate(coefficients):
        power = degree - i
        if c == 0.0 and len(coefficients) > 1:
            continue
        var = "" if power == 0 else (" s" if power == 1 else f" s^{power}")
        terms.append(f"{c:.6g}{var}")
    return " + ".join(terms).replace("+ -", "- ") or "0"


def format_report(report: dict[str, Any]) -> str:
    lines = [f"{report['file']}: {report['n_samples']} samples, Ts = {report['sample_time_s'] * 1e3:.3f} ms, "
             f"{report['n_outputs']} output(s)"]
    lines += [f"  note: {n}" for n in report["notes"]]
    for fit in report["fits"]:
        release = fit["release_time_s"]
        lines.append(f"[{fit['method']}] "
                     + ("input as recorded" if release is None else f"release time {release:.4f} s")
                     + ("" if fit["converged"] else "  (NOT CONVERGED)"))
        for i, m in enumerate(fit["modes"], 1):
            lines.append(f"  mode {i}: wn = {m['wn']:.4f} ± {m['wn_std']:.2g} rad/s, "
                         f"zeta = {m['zeta']:.5f} ± {m['zeta_std']:.2g}")
        for j, out in enumerate(fit["outputs"], 1):
            lines.append(f"  y{j}: G(s) = ({polynomial(out['num'])}) / ({polynomial(out['den'])})")
            lines.append(f"      fit {out['fit_percent']:.2f} %, DC gain {out['dc_gain']:.4g}")
    return "\n".join(lines)
