"""The layering contracts (import-linter), the type checker and the linter (ruff), run by the suite."""

import io
import re
import shutil
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _tool(name: str) -> str:
    exe = Path(sys.executable).with_name(name)
    found = str(exe) if exe.exists() else shutil.which(name)
    if found is None:
        pytest.fail(f"{name} is not installed: run `make test`, which installs the test extras")
    return found


def test_layers_hold() -> None:
    proc = subprocess.run([_tool("lint-imports"), "--no-cache"], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.timeout(400)
def test_types_check() -> None:
    proc = subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True,
                          text=True, timeout=380)
    assert proc.returncode == 0, proc.stdout[-6000:] + proc.stderr[-2000:]


def test_ruff_is_clean() -> None:
    proc = subprocess.run([_tool("ruff"), "check", "--no-cache", "."], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-6000:] + proc.stderr[-2000:]


_NOQA = re.compile(r"#\s*noqa\b(?P<rest>.*)$")
_JUSTIFIED = re.compile(r":\s*[A-Z]+[0-9]+(\s*,\s*[A-Z]+[0-9]+)*\s*(-|\()\s*\w")


def unjustified_noqa(source: str) -> list[int]:
    """Line numbers of `# noqa` comments without codes and a reason (`# noqa: E402 - why`)."""
    comments = (tok for tok in tokenize.generate_tokens(io.StringIO(source).readline)
                if tok.type == tokenize.COMMENT)
    return [tok.start[0] for tok in comments
            if (m := _NOQA.search(tok.string)) and not _JUSTIFIED.match(m.group("rest"))]


def test_unjustified_noqa_is_recognised() -> None:
    assert unjustified_noqa("import daq  # noqa: F401\nx = 1  # noqa\ns = '# noqa'\n") == [1, 2]
    assert unjustified_noqa("import daq  # noqa: F401 - registers sim://\ny = 2  # noqa: E731 (why)\n") == []


def test_every_noqa_says_why() -> None:
    files = subprocess.run(["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True,
                           check=True, timeout=60).stdout.split()
    bad = [f"{name}:{n}" for name in files if (ROOT / name).is_file()
           for n in unjustified_noqa((ROOT / name).read_text(encoding="utf-8"))]
    assert not bad, f"each `# noqa: CODE` needs a reason after it (`- why`): {bad}"
