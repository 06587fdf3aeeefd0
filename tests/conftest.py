"""Suite-wide fixtures and guards (owned by the lead; shared helpers live in the `testkit` package).

- `free_port`: an ephemeral TCP port on 127.0.0.1 for a Zenoh listener or a web server.
- `realdata_dir`: `../shared/realdata` beside the checkout, or a clean skip when absent.
- A guard that fails the run when almost nothing was collected, so an empty or
  mis-collected suite can never pass.
- Hypothesis draws the same examples on every run (`derandomize`): the suite is deterministic.
  `HYPOTHESIS_PROFILE=explore` draws new ones (and keeps failures in `.hypothesis/`), for
  hunting; a failure found that way is kept as an `@example`.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

from testkit.ports import free_port as pick_free_port

settings.register_profile("deterministic", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))

REPO_ROOT = Path(__file__).resolve().parents[1]
REALDATA = REPO_ROOT.parent / "shared" / "realdata"
MIN_TESTS = 50


@pytest.fixture
def free_port() -> int:
    return pick_free_port()


@pytest.fixture(scope="session")
def realdata_dir() -> Path:
    if not REALDATA.is_dir():
        pytest.skip(f"real measured runs not present at ../shared/realdata (looked in {REALDATA.name}/ "
                    "beside the checkout): nothing to validate against")
    return REALDATA


def pytest_collection_finish(session: pytest.Session) -> None:
    # Only guard full runs (no explicit file or -k selection).
    args = [a for a in session.config.args if not a.startswith("-")]
    full_run = all(Path(a).resolve() == (REPO_ROOT / "tests").resolve() for a in args) or not args
    selected = bool(session.config.getoption("keyword") or session.config.getoption("markexpr"))
    if full_run and not selected and len(session.items) < MIN_TESTS:
        raise pytest.UsageError(f"collected {len(session.items)} tests, expected at least {MIN_TESTS}: "
                                "the suite is not being found")
