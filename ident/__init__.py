"""cartlab `ident`: identification of spring-cart runs.

Pure numerical code (arrays in, result objects out) plus thin adapters for files and
Zenoh. The public API below is re-exported from the modules that define it; no public
function shares its name with a module (`ident.pem` is the function, defined in
`ident.prediction_error`; `ident.compare` in `ident.comparison`; `ident.d2c` in
`ident.lti`, its matrix form in `ident.zoh`).
"""

import os

# The fits are small dense problems: a multi-threaded BLAS only adds contention (2-5x slower
# measured on a loaded 2-core bench PC). OpenBLAS reads this once, when numpy first loads,
# which the imports below do; so it is set here, before them (a value already set wins).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"

from ident.comparison import ResidualTest, compare, fit_percent, resid, simulate
from ident.data import IdData, check_arrays, from_release, make_uniform, step_input
from ident.io import load, load_mcap, load_text
from ident.lti import d2c
from ident.model import ModeEstimate, Model
from ident.physics import (
    Mode,
    SingleCart,
    StateSpace,
    TwoCartChain,
    euler,
    euler_coulomb,
    linear_step_response,
    rk4,
)
from ident.prediction_error import pem
from ident.release import moving_outputs, noise_std
from ident.releases import Release, find_releases, with_found_release
from ident.simple import SimpleFit, fit_simple
from ident.subspace import moesp
from ident.zoh import c2d_zoh, d2c_zoh

__all__ = [
    "IdData",
    "Mode",
    "ModeEstimate",
    "Model",
    "Release",
    "ResidualTest",
    "SimpleFit",
    "SingleCart",
    "StateSpace",
    "TwoCartChain",
    "__version__",
    "c2d_zoh",
    "check_arrays",
    "compare",
    "d2c",
    "d2c_zoh",
    "euler",
    "euler_coulomb",
    "find_releases",
    "fit_percent",
    "fit_simple",
    "from_release",
    "linear_step_response",
    "load",
    "load_mcap",
    "load_text",
    "make_uniform",
    "moesp",
    "moving_outputs",
    "noise_std",
    "pem",
    "resid",
    "rk4",
    "simulate",
    "step_input",
    "with_found_release",
]
