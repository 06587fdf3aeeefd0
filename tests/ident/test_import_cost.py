"""`import ident` and `ident --help` load no heavy numerics: scipy's submodules, numba and
nbformat are imported where they are used (issue 11: `import ident` took 4.4 s under load).
Checked in a fresh interpreter by what `sys.modules` holds, not by a timing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("scipy.linalg", "scipy.optimize", "scipy.signal", "scipy.special", "scipy.stats", "numba",
         "nbformat", "matplotlib", "control", "zenoh")


def _loaded_after(statement: str) -> list[str]:
    code = f"import json, sys\n{statement}\nprint(json.dumps(sorted(sys.modules)))"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=120, check=True).stdout
    modules = set(json.loads(out))
    return [name for name in HEAVY if name in modules]


def test_import_ident_loads_no_heavy_module() -> None:
    assert _loaded_after("import ident") == []


def test_the_cli_parser_loads_no_heavy_module() -> None:
    assert _loaded_after("from ident.cli import build_parser; build_parser().format_help()") == []


def test_a_fit_still_loads_what_it_uses() -> None:
    # the deferral is real: fitting imports scipy.optimize when it runs
    loaded = _loaded_after("import numpy as np, ident\n"
                           "t = np.arange(400) / 100.0\n"
                           "y = np.where(t > 1, 1 - np.exp(-0.3 * (t - 1)) * np.cos(8 * (t - 1)), 0)\n"
                           "ident.fit_simple(ident.from_release(t, y[:, None], 1.0))")
    assert "scipy.optimize" in loaded
