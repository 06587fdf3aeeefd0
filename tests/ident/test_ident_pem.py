"""Acceptance of `ident.pem`: known parameters back from seeded noisy runs, release unknown."""

from __future__ import annotations

import numpy as np
import pytest

from ident.comparison import compare, fit_percent
from ident.data import IdData
from ident.errors import IdentValueError
from ident.prediction_error import pem
from ident.releases import with_found_release
from testkit.ident_synth import PULL_M, Run, cart1_run, cart2_run, step


def _check(run: Run, model_modes: tuple, release: float | None, fits: list[float]) -> None:
    wn = np.array([m.wn for m in model_modes])
    zeta = np.array([m.zeta for m in model_modes])
    assert np.all(np.abs(wn / run.wn - 1) < 1e-3), (wn, run.wn)
    assert np.all(np.abs(zeta / run.zeta - 1) < 0.02), (zeta, run.zeta)
    assert release is not None and abs(release - run.release_time_s) < 1e-3
    floor = fit_percent(run.y, run.y_clean)  # the noise floor of this run
    assert min(fits) >= 99.5
    assert np.all(np.array(fits) >= np.array(floor) - 0.01), (fits, floor)


@pytest.mark.parametrize("fs", [50.0, 200.0])
def test_one_cart_order_2_with_a_step_input_0_12_s_early(fs: float) -> None:
    run = cart1_run(fs)
    data = IdData(run.t, step(run.t, run.release_time_s - 0.12), run.y)
    model = pem(data, 2)
    _check(run, model.modes, model.release_time_s, compare(model, data))
    assert model.dc_gain[0] == pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("fs", [50.0, 200.0])
def test_two_carts_order_4_both_outputs_release_estimated(fs: float) -> None:
    run = cart2_run(fs)
    data = with_found_release(run.t, run.y)  # the release is estimated from y alone
    model = pem(data, 4)
    _check(run, model.modes, model.release_time_s, compare(model, data))
    # case 3: cart 1 settles at the pull, cart 2 back at its rest
    assert model.dc_gain == pytest.approx([1.0, 0.0], abs=3e-3)


@pytest.mark.parametrize("output", [0, 1])
def test_two_carts_one_output_at_200_hz(output: int) -> None:
    run = cart2_run(200.0, seed=5)
    data = IdData(run.t, step(run.t, run.release_time_s + 0.05), run.y[:, [output]])
    model = pem(data, 4)
    single = Run(run.t, run.y[:, [output]], run.y_clean[:, [output]], run.release_time_s, run.wn, run.zeta)
    _check(single, model.modes, model.release_time_s, compare(model, data))


def test_anchor_input_cart_2_has_relative_degree_4_when_asked() -> None:
    run = cart2_run(200.0, seed=7, structure="anchor")
    data = IdData(run.t, step(run.t, run.release_time_s), run.y)
    model = pem(data, 4, relative_degree=(2, 4))
    _check(run, model.modes, model.release_time_s, compare(model, data))
    (num1, den), (num2, _) = model.tf_coefficients()
    assert len(den) == 5 and len(num1) == 3 and len(num2) == 1
    true_dc = [0.48035736, 0.21193268]
    assert model.dc_gain == pytest.approx(true_dc, rel=5e-3)


def test_dc_gain_constraint_is_met_exactly() -> None:
    run = cart1_run(50.0, seed=3)
    model = pem(IdData(run.t, step(run.t, 1.0), run.y), 2, dc_gain=1.0)
    assert model.dc_gain[0] == pytest.approx(1.0, abs=1e-12)


def test_order_selection_finds_two_modes_for_two_carts() -> None:
    run = cart2_run(50.0, seed=11)
    model = pem(IdData(run.t, step(run.t, 0.5), run.y), None)
    assert model.order == 4


def test_simulate_matches_for_another_step_input_on_the_zoh_path() -> None:
    run = cart1_run(200.0, seed=4)
    data = IdData(run.t, step(run.t, 0.7), run.y)
    model = pem(data, 2)
    # a two-step input takes the zero-order-hold path: the same first step gives the same output
    u2 = step(run.t, 0.7) + np.where(run.t >= 7.9, 0.01, 0.0)
    closed_form = model.simulate(data.u)
    zoh = model.simulate(u2)
    before = run.t < 7.9
    assert np.max(np.abs(zoh[before] - closed_form[before])) < 1e-9


def test_discrete_innovation_form_has_the_continuous_poles() -> None:
    run = cart1_run(50.0, seed=6)
    model = pem(IdData(run.t, step(run.t, 0.5), run.y), 2)
    ad, _bd, _c, _d, k = model.discrete()
    z = np.sort_complex(np.linalg.eigvals(ad))
    expected = np.sort_complex(np.exp(model.poles * 0.02))
    assert np.allclose(z, expected, atol=1e-12)
    assert not np.any(k)


def test_no_motion_is_an_error_naming_it() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0, 4, 0.02)
    data = IdData(t, step(t, 1.0), 1e-4 * rng.standard_normal(t.size))
    with pytest.raises(IdentValueError, match="no motion"):
        pem(data, 2)


def test_constant_input_and_odd_order_are_errors() -> None:
    run = cart1_run(50.0)
    with pytest.raises(IdentValueError, match="constant input"):
        pem(IdData(run.t, np.zeros_like(run.t), run.y), 2)
    with pytest.raises(IdentValueError, match="even order"):
        pem(IdData(run.t, step(run.t, 1.0), run.y), 3)


def test_transfer_function_is_a_control_object_with_the_identified_dc_gain() -> None:
    control = pytest.importorskip("control")
    run = cart1_run(50.0, seed=8)
    model = pem(IdData(run.t, step(run.t, 1.0), run.y), 2)
    (tf,) = model.tf
    assert isinstance(tf, control.TransferFunction)
    assert float(np.real(tf.dcgain())) == pytest.approx(model.dc_gain[0], rel=1e-9)
    assert PULL_M == 0.15


def test_non_uniform_time_stamps_are_fitted_where_they_are() -> None:
    run = cart1_run(200.0, seed=9)
    rng = np.random.default_rng(9)
    keep = rng.random(run.t.size) > 0.2  # a fifth of the samples lost at random
    data = IdData(run.t[keep], step(run.t[keep], 0.7), run.y[keep])
    assert not data.is_uniform()
    model = pem(data, 2)
    thinned = Run(run.t[keep], run.y[keep], run.y_clean[keep], run.release_time_s, run.wn, run.zeta)
    _check(thinned, model.modes, model.release_time_s, compare(model, data))


def test_a_pinned_cart_output_is_named_not_fitted() -> None:
    run = cart1_run(50.0, seed=10)
    y = np.column_stack([run.y[:, 0], np.zeros(run.t.size)])  # cart 2 pinned: a constant reading
    with pytest.raises(IdentValueError, match=r"no motion in output\(s\) \[1\]"):
        pem(IdData(run.t, step(run.t, 0.5), y), 4)
