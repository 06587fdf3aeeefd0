"""cartlab `ident`: identification of spring-cart runs.

Pure numerical code (arrays in, result objects out) plus thin adapters for files and
Zenoh. The public API is re-exported here lazily, so `import ident` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: public name -> defining module; filled in as the engine grows.
_EXPORTS: dict[str, str] = {
    "IdData": "ident.data",
    "check_arrays": "ident.data",
    "make_uniform": "ident.data",
    "step_input": "ident.data",
    "from_release": "ident.data",
    "estimate_release_time": "ident.release",
    "noise_std": "ident.release",
    "moving_outputs": "ident.release",
    "SingleCart": "ident.physics",
    "TwoCartChain": "ident.physics",
    "StateSpace": "ident.physics",
    "Mode": "ident.physics",
    "pem": "ident.pem",
    "Model": "ident.model",
    "ModeEstimate": "ident.model",
    "compare": "ident.compare",
    "simulate": "ident.compare",
    "d2c": "ident.lti",
    "fit_percent": "ident.compare",
    "resid": "ident.compare",
    "ResidualTest": "ident.compare",
    "fit_simple": "ident.simple",
    "SimpleFit": "ident.simple",
    "rk4": "ident.physics",
    "euler": "ident.physics",
    "euler_coulomb": "ident.physics",
    "linear_step_response": "ident.physics",
    "d2c_zoh": "ident.d2c",
    "c2d_zoh": "ident.d2c",
    "moesp": "ident.subspace",
    "load": "ident.io",
    "load_text": "ident.io",
    "load_mcap": "ident.io",
}


# `ident.d2c` names both a submodule (the matrix functions) and the MATLAB-style function. The
# import system binds a submodule to the package attribute when the submodule is first loaded,
# so load the submodule first and bind the function after it: the attribute stays the function.
importlib.import_module("ident.d2c")
from ident.lti import d2c as d2c  # noqa: E402 - the function, bound after the submodule (see above)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'ident' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
