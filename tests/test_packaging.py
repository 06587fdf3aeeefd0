"""Packaging: every imported package declared, ranges not pins, a constraints file, a licence.

The declared dependencies (pyproject.toml) are ranges so that cartlab installs beside a
student's own numpy or scipy; `constraints.txt` pins the set `make` and CI install and test.
"""

from __future__ import annotations

import ast
import importlib.metadata
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
OURS = {"daq", "ident", "schemas", "testkit", "tests", "tools"}
#: Shipped packages (must declare their imports as runtime dependencies).
RUNTIME_DIRS = ("daq", "ident", "schemas")
#: Development-only code (may also use the `test` extra); testkit is installed with the
#: project but only tests and tools import it.
DEV_DIRS = ("tests", "tools", "testkit")


def _pyproject() -> dict[str, object]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def _requirements(group: str | None) -> list[Requirement]:
    project = _pyproject()["project"]
    assert isinstance(project, dict)
    lines = project["dependencies"] if group is None else project["optional-dependencies"][group]
    return [Requirement(line) for line in lines]


def _names(requirements: list[Requirement]) -> set[str]:
    return {canonicalize_name(r.name) for r in requirements}


def _imported_modules(directories: tuple[str, ...]) -> dict[str, str]:
    """Top-level names of absolute imports in every .py file under `directories` -> one file."""
    found: dict[str, str] = {}
    for directory in directories:
        for path in sorted((ROOT / directory).rglob("*.py")):
            tree = ast.parse(path.read_text(), filename=str(path))
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    found.setdefault(name.split(".")[0], str(path.relative_to(ROOT)))
    return found


def _third_party(modules: dict[str, str]) -> dict[str, str]:
    local = {p.stem for d in DEV_DIRS for p in (ROOT / d).rglob("*.py")}   # tests' sibling helpers
    return {m: f for m, f in modules.items()
            if m not in sys.stdlib_module_names and m not in OURS and m not in local and m != "__future__"}


def _undeclared(directories: tuple[str, ...], declared: set[str]) -> list[str]:
    distributions = importlib.metadata.packages_distributions()
    problems = []
    for module, where in sorted(_third_party(_imported_modules(directories)).items()):
        owners = {canonicalize_name(d) for d in distributions.get(module, [])}
        if not owners:
            problems.append(f"{module} (imported in {where}) is not installed")
        elif not owners & declared:
            problems.append(f"{module} (imported in {where}) comes from {sorted(owners)}, not declared")
    return problems


def test_every_package_the_shipped_code_imports_is_a_declared_dependency() -> None:
    problems = _undeclared(RUNTIME_DIRS, _names(_requirements(None)))
    assert not problems, "declare these in [project] dependencies: " + "; ".join(problems)


def test_every_package_tests_and_tools_import_is_declared() -> None:
    declared = _names(_requirements(None)) | _names(_requirements("test"))
    problems = _undeclared(DEV_DIRS, declared)
    assert not problems, "declare these in the `test` extra: " + "; ".join(problems)


def test_import_scan_sees_third_party_imports() -> None:
    # the scan itself must find what we know is imported, or the two tests above prove nothing
    runtime = _third_party(_imported_modules(RUNTIME_DIRS))
    assert {"numpy", "scipy", "zenoh", "mcap", "pydantic", "serial", "zstandard"} <= set(runtime)


@pytest.mark.parametrize("group", [None, "test"])
def test_dependencies_are_ranges_up_to_the_next_major(group: str | None) -> None:
    for req in _requirements(group):
        specs = {s.operator: Version(s.version) for s in req.specifier}
        assert set(specs) == {">=", "<"}, f"{req}: expected a range '>=LOW,<HIGH', got {req.specifier}"
        lower, upper = specs[">="], specs["<"]
        assert lower < upper <= Version(f"{lower.major + 1}"), (
            f"{req}: expected the upper bound at most the next major version, got {upper}")


def _constraints() -> dict[str, Version]:
    pins = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        line = line.split("#")[0].strip()
        if line:
            name, _, version = line.partition("==")
            assert version, f"constraints.txt: expected NAME==VERSION, got {line!r}"
            pins[canonicalize_name(name)] = Version(version)
    return pins


def test_constraints_pin_every_declared_dependency_inside_its_range() -> None:
    pins = _constraints()
    for req in _requirements(None) + _requirements("test"):
        name = canonicalize_name(req.name)
        assert name in pins, f"{req.name} is declared but not pinned in constraints.txt ('make constraints')"
        assert req.specifier.contains(pins[name]), f"constraints.txt pins {name}=={pins[name]} outside {req}"


def test_licence_is_bsd_3_clause() -> None:
    assert _pyproject()["project"]["license"] == "BSD-3-Clause"  # type: ignore[index]
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License")
    assert "Neither the name of the copyright holder" in text


def test_pip_check_is_clean() -> None:
    proc = subprocess.run([sys.executable, "-m", "pip", "check"], capture_output=True, text=True, timeout=120,
                          check=False)
    if "No module named pip" in proc.stderr:
        pytest.skip("pip is not installed in this environment")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def _closure(requirements: list[Requirement]) -> dict[str, str]:
    """Every distribution the requirements pull in (installed metadata, markers evaluated),
    mapped to the requirement that first pulled it."""
    from packaging.markers import default_environment

    seen: dict[str, str] = {}
    todo = [(r, r.name) for r in requirements]
    while todo:
        req, via = todo.pop()
        name = canonicalize_name(req.name)
        if name in seen:
            continue
        seen[name] = via
        try:
            dist = importlib.metadata.distribution(req.name)
        except importlib.metadata.PackageNotFoundError:
            continue
        for line in dist.requires or []:
            child = Requirement(line)
            env = {**default_environment(), "extra": ""}
            if child.marker is None or child.marker.evaluate(env):
                todo.append((child, via))
    return seen


def test_constraints_pin_the_whole_tree_not_only_what_is_declared() -> None:
    pins = _constraints()
    missing = {name: via for name, via in _closure(_requirements(None) + _requirements("test")).items()
               if name not in pins}
    assert not missing, ("not pinned in constraints.txt (install, then 'make constraints'): "
                         + ", ".join(f"{n} (via {v})" for n, v in sorted(missing.items())))
