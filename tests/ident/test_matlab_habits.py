"""The API as a MATLAB-trained student uses it: `compare(data, model)`, python-control systems
as models, `ident.d2c`, short summaries, and errors that say what to pass instead.

The reference responses are written here from the physics (closed-form step responses), not
taken from `ident`.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

import ident
from ident.errors import IdentValueError
from testkit.ident_synth import CART1, PULL_M, cart1_run, step


def _analytic_step(t: np.ndarray, t0: float, wn: float, zeta: float, amplitude: float) -> np.ndarray:
    """A·[1 - e^{-ζ wn τ}(cos wd τ + ζ/√(1-ζ²) sin wd τ)], τ = t - t0 ≥ 0 (under-damped, unit DC gain)."""
    tau = np.clip(t - t0, 0.0, None)
    wd = wn * np.sqrt(1.0 - zeta ** 2)
    y = amplitude * (1.0 - np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta / np.sqrt(1 - zeta ** 2)
                                                        * np.sin(wd * tau)))
    return np.where(t >= t0, y, 0.0)


def _lab_case(rng: np.random.Generator) -> tuple[ident.IdData, float, float]:
    """A cart (wn 2–30 rad/s, ζ 0.005–0.3) sampled at 50–1000 Hz, released on a sample."""
    wn, zeta = rng.uniform(2.0, 30.0), rng.uniform(0.005, 0.3)
    fs = rng.uniform(50.0, 1000.0)
    t = np.arange(0.0, 6.0, 1.0 / fs)
    k0 = int(rng.integers(5, t.size // 4))
    u = np.where(np.arange(t.size) >= k0, PULL_M, 0.0)
    y = _analytic_step(t, t[k0], wn, zeta, PULL_M)
    return ident.IdData(t, u, y), wn, zeta


@pytest.mark.parametrize("seed", range(6))
def test_a_hand_derived_tf_compares_with_data_in_matlab_order(seed: int) -> None:
    data, wn, zeta = _lab_case(np.random.default_rng(seed))
    g = control.tf([wn ** 2], [1.0, 2 * zeta * wn, wn ** 2])
    ts = float(data.t[1] - data.t[0])
    for model in (g, control.ss(g), control.sample_system(g, ts, method="zoh"),
                  control.ss(control.sample_system(g, ts, method="zoh"))):
        fit = ident.compare(data, model)
        assert fit == ident.compare(model, data)
        assert fit[0] > 99.99, (model, fit)
        y_hat = ident.simulate(data, model)
        assert y_hat.shape == (data.n_samples, 1)
        assert np.max(np.abs(y_hat[:, 0] - data.y[:, 0])) < 1e-6 * PULL_M


def test_a_list_of_siso_tfs_is_one_model_per_output() -> None:
    rng = np.random.default_rng(7)
    data1, wn1, z1 = _lab_case(rng)
    t, u = data1.t, data1.u
    wn2, z2 = 2.5 * wn1, 0.5 * z1
    y2 = _analytic_step(t, float(t[np.flatnonzero(u)[0]]), wn2, z2, -0.4 * PULL_M)
    data = ident.IdData(t, u, np.column_stack([data1.y[:, 0], y2]))
    models = [control.tf([wn1 ** 2], [1, 2 * z1 * wn1, wn1 ** 2]),
              control.tf([-0.4 * wn2 ** 2], [1, 2 * z2 * wn2, wn2 ** 2])]
    fits = ident.compare(data, models)
    assert len(fits) == 2 and min(fits) > 99.99
    with pytest.raises(IdentValueError, match=r"select_outputs\(\[0\]\)"):
        ident.compare(data, models[0])


def test_fitted_model_in_either_order_and_resid() -> None:
    run = cart1_run(100.0, seed=3)
    data = ident.IdData(run.t, step(run.t, 0.9), run.y)
    model = ident.pem(data, 2)
    assert ident.compare(data, model) == ident.compare(model, data) == pytest.approx(list(model.fit_percent))
    forward, backward = ident.resid(model, data), ident.resid(data, model)
    assert np.array_equal(forward[0].autocorrelation, backward[0].autocorrelation)
    assert np.array_equal(ident.simulate(data, model), model.simulate(data.u, data.t))
    # the model's own transfer functions, as python-control objects, reproduce its simulation
    # up to the fractional input delay it carries and a TF does not
    assert ident.compare(data, model.tf)[0] > model.fit_percent[0] - 5.0


def test_discrete_model_at_another_sample_time_is_refused_with_the_fix() -> None:
    data, wn, zeta = _lab_case(np.random.default_rng(11))
    ts = float(data.t[1] - data.t[0])
    g = control.sample_system(control.tf([wn ** 2], [1, 2 * zeta * wn, wn ** 2]), 2.0 * ts)
    with pytest.raises(IdentValueError, match=r"d2c"):
        ident.compare(data, g)


def test_compare_without_data_says_what_it_needs() -> None:
    g = control.tf([1.0], [1.0, 1.0])
    with pytest.raises(IdentValueError, match="IdData"):
        ident.compare(g, g)


def _random_continuous(rng: np.random.Generator, n_modes: int) -> control.TransferFunction:
    """Σ of lightly damped modes in the lab's ranges (wn 1–40 rad/s, ζ 0.005–0.5)."""
    total = control.tf([0.0], [1.0])
    for _ in range(n_modes):
        wn, zeta = rng.uniform(1.0, 40.0), rng.uniform(0.005, 0.5)
        total = total + control.tf([rng.uniform(-2, 2) * wn ** 2, rng.uniform(-2, 2) * wn ** 2 / 10],
                                   [1.0, 2 * zeta * wn, wn ** 2])
    return control.minreal(total, verbose=False)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("method", ["zoh", "tustin"])
def test_d2c_inverts_python_controls_sampling(seed: int, method: str) -> None:
    rng = np.random.default_rng(100 + seed)
    g = _random_continuous(rng, 1 + seed % 2)
    ts = rng.uniform(0.001, 0.02)
    back = ident.d2c(control.sample_system(g, ts, method=method), method=method)
    assert isinstance(back, control.TransferFunction) and back.isctime(strict=True)
    w = np.logspace(-1, np.log10(0.5 * np.pi / ts), 40)   # below Nyquist
    original = np.squeeze(g(1j * w))
    recovered = np.squeeze(back(1j * w))
    assert np.max(np.abs(recovered - original) / np.maximum(np.abs(original), 1e-6)) < 1e-6
    ss_back = ident.d2c(control.ss(control.sample_system(g, ts, method=method)), method=method)
    assert isinstance(ss_back, control.StateSpace)
    assert np.allclose(np.sort_complex(ss_back.poles()), np.sort_complex(g.poles()), rtol=1e-6)


def test_d2c_refuses_what_has_no_continuous_original() -> None:
    g = control.tf([1.0], [1.0, 0.5, 4.0])
    with pytest.raises(IdentValueError, match="dt"):
        ident.d2c(g)                                        # already continuous
    with pytest.raises(IdentValueError, match="dt"):
        ident.d2c(control.tf([1.0], [1.0, -0.5], True))     # no sample time
    with pytest.raises(IdentValueError, match="negative real axis"):
        ident.d2c(control.tf([1.0], [1.0, 0.5], 0.01))      # pole at z = -0.5
    with pytest.raises(IdentValueError, match="method"):
        ident.d2c(control.sample_system(g, 0.01), method="foh")  # type: ignore[arg-type]


def test_matlab_names_stay_functions_after_their_modules_load() -> None:
    import ident.prediction_error
    import ident.simple
    import ident.zoh

    run = cart1_run(50.0, seed=61)
    ident.prediction_error.pem(ident.IdData(run.t, step(run.t, 0.9), run.y), 2)
    assert callable(ident.pem) and callable(ident.compare) and ident.zoh.d2c_zoh is ident.d2c_zoh
    assert callable(ident.simulate) and ident.simulate.__module__ == "ident.comparison"
    assert callable(ident.d2c) and ident.d2c.__module__ == "ident.lti"


def test_summaries_are_a_few_lines_not_arrays() -> None:
    run = cart1_run(200.0, seed=5)
    data = ident.IdData(run.t, step(run.t, CART1["t_r"]), run.y, name="cart1.csv")
    model = ident.pem(data, 2)
    for obj in (data, model, ident.resid(data, model)[0], ident.fit_simple(data, "rk4")):
        text = repr(obj)
        assert len(text.splitlines()) <= 14 and len(text) < 1500, text
        assert "array(" not in text and "[[" not in text
        page = obj._repr_html_()
        assert page.startswith("<table>") and page.count("<tr>") == len(text.splitlines()) - 1
    wn_true = float(run.wn[0])
    assert f"wn = {model.modes[0].wn:.4g}" in repr(model) and abs(model.modes[0].wn - wn_true) < 0.01 * wn_true
    assert f"{model.fit_percent[0]:.1f} %" in repr(model)
    assert "samples : 1600," in repr(data) and "moving" in repr(data)


def test_a_held_column_is_named_with_the_call_that_selects_the_moving_ones() -> None:
    run = cart1_run(100.0, seed=9)
    rng = np.random.default_rng(9)
    held = 1e-4 * rng.standard_normal(run.t.size)          # a pinned cart: encoder noise only
    data = ident.IdData(run.t, step(run.t, 0.9), np.column_stack([held, run.y[:, 0]]))
    assert "data.select_outputs([1])" in repr(data)
    with pytest.raises(IdentValueError, match=r"select_outputs\(\[1\]\)"):
        ident.pem(data, 2)
    with pytest.raises(IdentValueError, match=r"output=1\) or data.select_outputs\(\[1\]\)"):
        ident.fit_simple(data, "rk4")
    model = ident.pem(data.select_outputs([1]), 2)
    assert model.fit_percent[0] > 99.0
    with pytest.raises(IdentValueError, match=r"data.select_outputs\(\[1\]\)"):
        ident.compare(data, model)   # the one-output model belongs to the moving column
    assert ident.fit_simple(data, "rk4", output=1).fit_percent[0] > 99.0


def test_transposed_arrays_and_milliseconds_are_caught_with_the_fix() -> None:
    run = cart1_run(100.0, seed=4)
    u = step(run.t, 0.9)
    two = np.column_stack([run.y[:, 0], -run.y[:, 0]])
    with pytest.raises(IdentValueError, match=r"pass y\.T"):
        ident.IdData(run.t, u, two.T)
    with pytest.raises(IdentValueError, match=r"pass u\.T"):
        ident.IdData(run.t, u[None, :], two)
    with pytest.raises(IdentValueError, match=r"milliseconds\? pass t / 1000"):
        ident.IdData(run.t * 1000.0, u, two)
    assert ident.IdData(run.t[:, None], u, two).n_samples == run.t.size   # a column of times is fine


def test_a_recorded_pulse_input_is_not_summarised_as_a_step() -> None:
    run = cart1_run(100.0, seed=12)
    pulse = np.where((run.t >= 1.0) & (run.t < 4.0), 0.6, 0.0)   # a motor voltage pulse
    assert "input u : recorded, 0 … 0.6, first change at 1 s" in repr(ident.IdData(run.t, pulse, run.y))
    assert "input u : step of 0.15 at 0.9 s" in repr(ident.IdData(run.t, step(run.t, 0.9), run.y))


def test_a_diagnosis_prints_its_verdict_not_its_traces() -> None:
    from ident.diagnose import diagnose

    run = cart1_run(100.0, seed=31, duration=6.0)
    result = diagnose(run.t, run.y, carts=1, source="cart1.csv")
    text = repr(result)
    assert text.startswith(f"Diagnosis 'cart1.csv': cause {result.report.cause}")
    assert f"{result.report.baseline.fit_percent:.3f} %" in text
    assert len(text.splitlines()) <= 10 and "array(" not in text
    assert result._repr_html_().count("<tr>") == len(text.splitlines()) - 1
