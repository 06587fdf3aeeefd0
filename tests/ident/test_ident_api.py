"""The public API as documented: `ident.<name>` works before and after submodules load."""

from __future__ import annotations

import importlib
import os
import pkgutil
import subprocess
import sys
from types import ModuleType

import numpy as np
import pytest

import ident
from testkit.ident_synth import cart1_run, step


def test_every_exported_name_is_defined_and_public() -> None:
    assert len(ident.__all__) == len(set(ident.__all__)) > 30
    for name in ident.__all__:
        assert getattr(ident, name) is not None
    public = {n for n, v in vars(ident).items() if not n.startswith("_") and not isinstance(v, ModuleType)}
    assert public <= set(ident.__all__), public - set(ident.__all__)


def test_no_public_function_shares_its_name_with_a_module() -> None:
    modules = {m.name for m in pkgutil.iter_modules(ident.__path__)}
    assert not modules & set(ident.__all__), modules & set(ident.__all__)


def test_pem_and_compare_stay_callable_after_their_modules_are_imported() -> None:
    importlib.import_module("ident.prediction_error")
    importlib.import_module("ident.comparison")
    run = cart1_run(50.0, seed=61)
    data = ident.IdData(run.t, step(run.t, 0.5), run.y)
    model = ident.pem(data, 2)
    fits = ident.compare(model, data)
    assert fits == pytest.approx(list(model.fit_percent)) and fits[0] > 99.5
    assert callable(ident.pem) and ident.prediction_error.CANDIDATE_ORDERS == (2, 4, 6)
    assert isinstance(ident.resid(model, data)[0].white, bool)
    assert np.isfinite(ident.fit_simple(data, "rk4").wn)


def test_unknown_names_raise_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = ident.nope


_BLAS_THREADS = """
import ctypes, glob, os, sys
import ident.cli
import numpy
libs = glob.glob(os.path.join(os.path.dirname(numpy.__file__), os.pardir, "numpy.libs", "*openblas*"))
getters = [getattr(ctypes.CDLL(lib), name, None) for lib in libs
           for name in ("scipy_openblas_get_num_threads64_", "openblas_get_num_threads64_",
                        "openblas_get_num_threads")]
found = [g for g in getters if g is not None]
print(found[0]() if found else "unknown")
"""


def test_the_command_line_runs_blas_on_one_thread() -> None:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", _BLAS_THREADS], env=env, capture_output=True, text=True,
                         check=True, timeout=120).stdout.strip()
    if out == "unknown":
        pytest.skip("numpy's bundled OpenBLAS not found: cannot ask it for its thread count")
    assert out == "1"
