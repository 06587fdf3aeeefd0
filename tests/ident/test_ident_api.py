"""The public API as documented: `ident.<name>` works before and after submodules load."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import ident
from testkit.ident_synth import cart1_run, step


def test_every_exported_name_resolves() -> None:
    for name, module in ident._EXPORTS.items():
        assert getattr(importlib.import_module(module), name) is not None
        assert getattr(ident, name) is not None


def test_pem_and_compare_stay_callable_after_their_modules_are_imported() -> None:
    importlib.import_module("ident.pem")
    importlib.import_module("ident.compare")
    run = cart1_run(50.0, seed=61)
    data = ident.IdData(run.t, step(run.t, 0.5), run.y)
    model = ident.pem(data, 2)
    fits = ident.compare(model, data)
    assert fits == pytest.approx(list(model.fit_percent)) and fits[0] > 99.5
    assert ident.pem.CANDIDATE_ORDERS == (2, 4, 6)  # still the module, too
    assert isinstance(ident.resid(model, data)[0].white, bool)
    assert np.isfinite(ident.fit_simple(data, "rk4").wn)


def test_unknown_names_raise_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = ident.nope
