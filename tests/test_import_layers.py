"""The ident layering contracts catch what they are for: on a temporary copy of `ident`,
a clean copy passes `lint-imports`; an upward import hidden in a function, a cycle between
two modules of a subpackage, and a new module missing from the layers each fail it."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"unexpected config value {value!r}")


def _ident_contracts() -> list[dict[str, object]]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    inside = [c for c in config["contracts"]
              if c.get("containers") == ["ident"] or c.get("ancestors") == ["ident"]]
    assert {c["type"] for c in inside} == {"layers", "acyclic_siblings"}, inside
    return inside


def _copy(tmp_path: Path) -> Path:
    """`ident` and its contracts alone in `tmp_path` (nothing else of ours is a root package)."""
    shutil.copytree(ROOT / "ident", tmp_path / "ident",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    lines = ["[tool.importlinter]", 'root_packages = ["ident"]', "include_external_packages = false"]
    for contract in _ident_contracts():
        lines += ["", "[[tool.importlinter.contracts]]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in contract.items()]
    (tmp_path / "pyproject.toml").write_text("\n".join(lines) + "\n")
    return tmp_path


def _lint(where: Path) -> subprocess.CompletedProcess[str]:
    exe = Path(sys.executable).with_name("lint-imports")
    found = str(exe) if exe.exists() else shutil.which("lint-imports")
    if found is None:
        pytest.fail("lint-imports is not installed: run `make test`, which installs the test extras")
    env = {**os.environ, "PYTHONPATH": str(where)}   # the copy, not the installed ident
    return subprocess.run([found, "--no-cache"], cwd=where, env=env, capture_output=True, text=True,
                          timeout=180)


def _append(path: Path, text: str) -> None:
    path.write_text(path.read_text() + "\n" + text)


def _upward_import_in_a_function(root: Path) -> str:
    # ident.errors is the bottom layer; ident.model imports it, so this closes a cycle
    _append(root / "ident" / "errors.py", "def _late() -> None:\n    from ident import model\n")
    return "ident is layered"


def _cycle_inside_a_subpackage(root: Path) -> str:
    # ident.diagnose.run imports ident.diagnose.models; the reverse import closes a cycle
    _append(root / "ident" / "diagnose" / "models.py", "from ident.diagnose import run as _run\n")
    return "no import cycles between sibling modules"


def _module_missing_from_the_layers(root: Path) -> str:
    (root / "ident" / "newcomer.py").write_text('"""A module nobody placed in a layer."""\n')
    return "ident is layered"


@pytest.mark.timeout(600)
def test_a_clean_copy_passes_and_each_injected_fault_breaks_its_contract(tmp_path: Path) -> None:
    clean = _lint(_copy(tmp_path / "clean"))
    assert clean.returncode == 0, clean.stdout[-4000:] + clean.stderr[-2000:]
    faults: list[Callable[[Path], str]] = [_upward_import_in_a_function, _cycle_inside_a_subpackage,
                                           _module_missing_from_the_layers]
    for inject in faults:
        root = _copy(tmp_path / inject.__name__)
        contract = inject(root)
        proc = _lint(root)
        assert proc.returncode != 0, f"{inject.__name__}: lint-imports passed\n{proc.stdout[-3000:]}"
        broken = [line for line in proc.stdout.splitlines() if line.endswith("BROKEN")]
        assert any(line.startswith(contract) for line in broken), (inject.__name__, broken)
