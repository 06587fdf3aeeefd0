"""Score a diagnosis report against a generated case's truth (no `ident` import: duck-typed).

The report is read as `ident diagnose` writes it (`schemas.diagnosis.DiagnosisReport`):
`cause` (the headline), `effects` (the effects the forward selection accepted, each with
`effect`, `parameters`, `material`; older reports: the `significant` candidates instead),
`candidates`, `corrected_linear` (the linear part's `zeta`, ...), `release_time_s`.

Parameter errors are relative, |estimate - truth| / |truth|; a friction that is zero on one
of two carts is scored against the larger one (a cart without friction should come out
near 0, not within 5 % of 0; cart 2's friction through cart 1's encoder, a length f2 / k2,
against cart 1's f1 / k2). A parameter the report does not give counts as infinitely wrong.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from testkit.effects.case import Case

PARAMETER_TOL = 0.05
#: effect whose parameter block holds a parameter of the truth
OWNER = {"coulomb_accel_m_s2": "coulomb_friction", "coulomb_accel_m_s2_cart2": "coulomb_friction",
         "coulomb_cart2_per_coupling_m": "coulomb_friction",
         "drag_per_m": "quadratic_drag", "cubic_per_m2_s2": "cubic_stiffness",
         "cubic_rel_per_m2": "cubic_stiffness", "quantum_m": "quantization", "mode_hz": "coupled_mode",
         "held_cart_gain_per_s2": "held_cart_motion"}


@dataclass(frozen=True)
class Verdict:
    """How one diagnosis did. `headline_right` is None for a pair (either effect may lead);
    `immaterial_listed`: every immaterial effect of the truth is among the accepted ones."""

    family: str
    cause: str
    found: tuple[str, ...]
    material: tuple[str, ...]
    headline_right: bool | None
    all_found: bool
    immaterial_listed: bool
    errors: dict[str, float]
    false_positive: bool
    tolerance: float = PARAMETER_TOL

    @property
    def parameters_ok(self) -> bool:
        return all(e <= self.tolerance for e in self.errors.values())

    @property
    def right(self) -> bool:
        """Headline (or, for a pair, both effects) right and every parameter within tolerance."""
        named = self.headline_right if self.headline_right is not None else self.all_found
        return bool(named) and self.immaterial_listed and self.parameters_ok and not self.false_positive


def accepted(report: Any) -> list[Any]:
    """The accepted effects: `report.effects`, or the significant candidates of an older report."""
    effects = getattr(report, "effects", None)
    if effects is not None:
        return list(effects)
    return [c for c in report.candidates if c.significant]


def _estimate(report: Any, name: str) -> float | None:
    if name == "zeta":
        return report.corrected_linear.get("zeta")
    owner = OWNER.get(name)
    for fit in accepted(report):
        if fit.effect == owner and name in fit.parameters:
            return float(fit.parameters[name])
    return None


def _std(report: Any, name: str) -> float | None:
    owner = OWNER.get(name)
    for fit in accepted(report):
        if fit.effect == owner and name in getattr(fit, "parameter_std", {}):
            return float(fit.parameter_std[name])
    return None


def parameter_sigmas(case: Case, report: Any) -> dict[str, float]:
    """Per parameter of the truth, |estimate - truth| in the report's own 1-sigma uncertainty
    (`parameter_std`); inf where the report gives no estimate or no uncertainty."""
    out = {}
    for name, value in case.truth.parameters.items():
        got, std = _estimate(report, name), _std(report, name)
        out[name] = float("inf") if got is None or not std else abs(got - value) / std
    return out


def parameter_errors(case: Case, report: Any) -> dict[str, float]:
    truth = case.truth.parameters
    frictions = [abs(v) for k, v in {**case.truth.details, **truth}.items() if k.startswith("coulomb_accel")]
    errors = {}
    for name, value in truth.items():
        got = _estimate(report, name)
        scale = abs(value) if value != 0.0 else max(frictions, default=1.0)
        if name == "coulomb_cart2_per_coupling_m" and value == 0.0:   # a length: against cart 1's
            scale = case.truth.details["coulomb_cart1_per_coupling_m"]
        errors[name] = float("inf") if got is None else abs(got - value) / scale
    return errors


def noise_floor_percent(case: Case, start_s: float) -> float:
    """The fit % (MATLAB compare) the noise-free truth reaches on the observed readings from
    `start_s` on: no model can do better than the noise leaves."""
    window = case.observed.t >= start_s
    y, clean = case.observed.y[window], case.truth.clean[window]
    return float(100.0 * (1.0 - np.linalg.norm(y - clean) / np.linalg.norm(y - y.mean(axis=0))))


def judge(case: Case, report: Any, tolerance: float = PARAMETER_TOL) -> Verdict:
    truth = case.truth
    fits = accepted(report)
    found = tuple(f.effect for f in fits)
    material = tuple(f.effect for f in fits if getattr(f, "material", True))
    errors = parameter_errors(case, report)
    all_found = set(truth.effects) <= set(found)
    false_positive = truth.family == "none" and (report.cause != "none" or bool(material))
    headline = None if truth.headline is None else report.cause == truth.headline
    listed = set(truth.immaterial) <= set(found)
    return Verdict(truth.family, str(report.cause), found, material, headline, all_found, listed, errors,
                   false_positive, tolerance)
