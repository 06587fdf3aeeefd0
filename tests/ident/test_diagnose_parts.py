"""Small parts of `ident.diagnose` against exact answers."""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose.lattice import find_lattice, find_noisy_lattice
from ident.diagnose.select import threshold
from ident.errors import IdentValueError
from ident.physics.chain import linear_free_response
from ident.physics.free import NonlinearTerms, simulate_free
from ident.physics.measures import fit_percent
from schemas.diagnosis import DiagnosisReport


def _analytic(wn: float, zeta: float, x0: float, tau: np.ndarray) -> np.ndarray:
    wd = wn * np.sqrt(1 - zeta ** 2)
    return x0 * np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))


def test_linear_free_response_is_the_analytic_one() -> None:
    tau = np.linspace(0.0, 5.0, 501)
    z = linear_free_response(np.array([[7.3, 0.05]]), np.array([[-0.15, 0.0]]), tau, 1)
    assert np.max(np.abs(z[0, :, 0] - _analytic(7.3, 0.05, -0.15, tau))) < 1e-12


def test_zero_nonlinear_terms_reproduce_the_linear_model_through_the_stepping_scheme() -> None:
    terms = NonlinearTerms(cubic_per_m2=np.array([1e-30]))
    z = simulate_free(np.array([[7.3, 0.05]]), np.array([[-0.15, 0.0]]), 0.01, 500, 1, terms)
    assert np.max(np.abs(z[0, :, 0] - _analytic(7.3, 0.05, -0.15, 0.01 * np.arange(500)))) < 1e-10


def test_friction_stops_the_cart_where_the_envelope_law_says() -> None:
    # undamped Coulomb oscillator: each half cycle the peak drops by 2f/wn²; it sticks once
    # the spring can no longer overcome friction (|x| ≤ f/wn²)
    wn, f, x0 = 10.0, 0.5, 0.1
    z = simulate_free(np.array([[wn, 0.0]]), np.array([[-x0, 0.0]]), 0.002, 3000, 1,
                      NonlinearTerms(friction_m_s2=np.array([[f]])))[0, :, 0]
    step = 2 * f / wn ** 2
    half_cycles = int(np.ceil((x0 - f / wn ** 2) / step))
    expected_rest = (-1) ** (half_cycles + 1) * (x0 - half_cycles * step)
    assert z[-1] == pytest.approx(expected_rest, abs=2e-5)
    assert np.all(z[-200:] == z[-1])


def test_lattice_finds_the_encoder_count_and_rejects_continuous_data() -> None:
    rng = np.random.default_rng(3)
    x = 0.1 * np.sin(np.linspace(0, 20, 2000)) + 0.02
    q = 1.0 / 56000
    lattice, coherence = find_lattice(np.round(x / q) * q)
    assert lattice is not None and lattice.quantum_m == pytest.approx(q, rel=1e-9)
    assert coherence > 0.999
    none, _ = find_lattice(x + rng.normal(0, 1e-5, x.size))
    assert none is None


def test_fit_percent_and_noise_bounds() -> None:
    y = np.column_stack([np.sin(np.linspace(0, 10, 100))])
    assert fit_percent(y, y) == [100.0]
    assert fit_percent(y, np.full_like(y, y.mean())) == [pytest.approx(0.0)]
    assert threshold(1, False, 500) == pytest.approx(10.828, abs=1e-3)   # χ²_1(0.999)
    assert threshold(4, True, 500) == pytest.approx(18.467 + 2 * np.log(250), abs=1e-3)


def test_bad_input_is_named() -> None:
    from ident.diagnose import diagnose

    t = np.arange(100) * 0.01
    with pytest.raises(IdentValueError, match="motion"):
        diagnose(t, np.zeros(100))
    with pytest.raises(IdentValueError, match="uniform"):
        diagnose(np.sort(np.random.default_rng(0).uniform(0, 1, 100)), np.sin(t))
    with pytest.raises(IdentValueError, match="finite"):
        diagnose(t, np.full(100, np.nan))


def test_the_record_round_trips_and_has_a_schema() -> None:
    schema = DiagnosisReport.model_json_schema()
    for key in ("release_time_s", "baseline", "candidates", "cause", "extended", "gain_points",
                "validation", "explanation"):
        assert key in schema["properties"]
    assert set(schema["$defs"]["Candidate"]["properties"]["effect"]["enum"]) == {
        "coulomb_friction", "quadratic_drag", "cubic_stiffness", "quantization", "coupled_mode", "presliding",
        "static_friction", "held_cart_motion", "rest_drift", "none"}
    assert "effects" in schema["properties"] and DiagnosisReport.SCHEMA_VERSION == 2


def _decaying_swing(rng: np.random.Generator, n: int = 2000) -> np.ndarray:
    """A cart ringing down (amplitude 2-20 cm, 0.5-2 Hz at 200 Hz) then resting for a fifth."""
    t = np.arange(n) / 200.0
    amp, f, rest = rng.uniform(0.02, 0.2), rng.uniform(0.5, 2.0), rng.uniform(-0.05, 0.05)
    x = rest + amp * np.exp(-0.3 * t) * np.cos(2 * np.pi * f * t)
    x[int(0.8 * n):] = x[int(0.8 * n)]
    return x


def test_a_lattice_read_under_noise_is_found_with_its_quantum() -> None:
    rng = np.random.default_rng(17)
    for _ in range(12):
        x = _decaying_swing(rng)
        q = float(np.exp(rng.uniform(np.log(1e-5), np.log(2e-3))))
        if np.ptp(x) < 10 * q:
            continue
        y = q * np.round(x / q) + rng.normal(0.0, rng.uniform(0.02, 0.3) * q, x.size)
        assert find_lattice(y)[0] is None   # no exact lattice
        lattice = find_noisy_lattice(y)
        assert lattice is not None, f"q = {q:.3g} m not found"
        assert lattice.quantum_m == pytest.approx(q, rel=0.01)


def test_no_lattice_is_read_into_continuous_data_or_a_resting_cart() -> None:
    rng = np.random.default_rng(18)
    for _ in range(12):
        x = _decaying_swing(rng)
        assert find_noisy_lattice(x + rng.normal(0.0, float(np.exp(rng.uniform(np.log(5e-6), np.log(2e-4)))),
                                                 x.size)) is None
