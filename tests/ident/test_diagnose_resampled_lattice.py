"""A record whose samples were interpolated onto a uniform grid (`ident.make_uniform`: an uneven
clock) has no lattice left in its positions: `diagnose(..., readings=...)` looks for the encoder's
lattice in the readings as they were read.

The record is drawn from the physics, independently of the code: a damped cart ringing at 2.5 Hz
sampled every 1.128 ms with a clock stamped to whole milliseconds (the ECP-210's), read through
an encoder of 17.86 µm, then interpolated onto the evened clock's uniform grid."""

from __future__ import annotations

import numpy as np
import pytest

from ident.data import IdData, make_uniform
from ident.diagnose import diagnose
from ident.errors import IdentDimensionError

COUNT_M = 1.0 / 56000.0


def _record() -> tuple[IdData, np.ndarray]:
    period = 1.128e-3
    t_true = period * np.arange(7000)
    wn, zeta = 2 * np.pi * 2.5, 0.02
    wd = wn * np.sqrt(1 - zeta ** 2)
    x = 0.04 * np.exp(-zeta * wn * t_true) * np.cos(wd * t_true)
    x[t_true < 0.5] = 0.04                                   # held, then let go at 0.5 s
    release = t_true >= 0.5
    tau = t_true[release] - 0.5
    x[release] = 0.04 * np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))
    noisy = x + np.random.default_rng(5).normal(0.0, 4e-6, x.size)
    readings = np.round(noisy / COUNT_M) * COUNT_M
    stamps = np.floor(t_true * 1e3) * 1e-3                   # whole ms on 1.128 ms samples
    raw = IdData(stamps, np.zeros(stamps.size), readings[:, None])
    return raw, readings[:, None]


def test_the_encoder_lattice_is_read_off_the_readings_of_a_resampled_record() -> None:
    raw, readings = _record()
    data = make_uniform(raw)
    assert "linear interpolation" in data.notes[-1]        # the positions were resampled
    report = diagnose(data.t, data.y, carts=1, readings=readings).report
    assert report.evidence.lattice_quantum_m == pytest.approx(COUNT_M, rel=1e-9)
    # the interpolated positions sit between the levels: no staircase of them is claimed, and
    # the quantization candidate says why
    assert all(e.effect != "quantization" for e in report.effects)
    candidate = next(c for c in report.candidates if c.effect == "quantization")
    assert not candidate.significant and "17.86 um lattice" in candidate.note and "resampled" in candidate.note


def test_without_its_readings_a_resampled_record_shows_no_encoder_count() -> None:
    raw, _ = _record()
    data = make_uniform(raw)
    report = diagnose(data.t, data.y, carts=1).report
    # interpolated a fraction of a step off the readings, the positions lie on no 17.86 um lattice
    q = report.evidence.lattice_quantum_m
    assert q is None or abs(q - COUNT_M) > 0.05 * COUNT_M


def test_readings_of_other_columns_than_the_positions_are_refused_naming_the_shape() -> None:
    raw, readings = _record()
    data = make_uniform(raw)
    with pytest.raises(IdentDimensionError, match=r"readings.*\(M, 1\).*shape \(7000, 2\)"):
        diagnose(data.t, data.y, carts=1, readings=np.hstack([readings, readings]))
