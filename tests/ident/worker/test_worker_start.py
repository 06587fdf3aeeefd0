"""The worker is declared alive only once its fit process can take a job (issue 14).

The fit process is a spawned interpreter that imports numpy, scipy, zenoh and the fitter
(seconds, more on a loaded machine). Other workers and the daq's runs count a worker in as
soon as its liveliness token appears; a token declared before the fit process is ready made
the first run wait for that start-up. Here the fitter's loading in the fit process is held
at a gate the test opens (`testkit.fake_fitters`), so "before ready" is a state, not a race.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from schemas import keys
from testkit.waiting import wait_until
from testkit.worker_harness import (
    STARTUP_S,
    FakeDaq,
    FitCollector,
    Router,
    alive_workers,
    client_args,
    start_worker,
    stop,
)

#: two start-up waits (the fit process loading, then the token) and a fit
pytestmark = pytest.mark.timeout(2 * STARTUP_S + 60)


def test_the_worker_is_alive_only_once_its_fit_process_is_ready(router: Router,
                                                                 tmp_path: Path) -> None:
    endpoint, session = router
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    gate = tmp_path / "start.gate"
    env = {"FAKE_FIT_LOG": str(tmp_path / "fits.log"), "FAKE_FIT_START_GATE": str(gate)}
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    worker = start_worker("ws", client_args(endpoint), runs_dir, tmp_path, "testkit.fake_fitters:instant_fit", env)
    try:
        wait_until(lambda: Path(f"{gate}.loading").exists(), STARTUP_S, "the fit process loading its fitter", worker)
        # the session is open and the fit process is loading: not alive yet
        assert "ws" not in alive_workers(session)
        run = daq.announce("r1")   # announced meanwhile: fitted once the worker is up
        gate.touch()
        wait_until(lambda: "ws" in alive_workers(session), STARTUP_S, "the worker alive once its fit process is ready",
                   worker)
        finals = collector.wait_finals([run], timeout_s=60)
    finally:
        code = stop(worker)
        collector.close()
    assert code == 0
    assert [r.status for r in finals[run]] == ["ok"]


def test_a_fit_process_that_cannot_load_its_fitter_ends_the_worker_never_alive(
        router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    seen: list[str] = []   # every liveliness change of the worker's token, as the router sees it
    tokens = session.liveliness().declare_subscriber(keys.ident_alive("wf"), lambda s: seen.append(str(s.kind)))
    env = {"FAKE_FIT_LOG": str(tmp_path / "fits.log"), "FAKE_FIT_START_FAIL": "1"}
    worker = start_worker("wf", client_args(endpoint), tmp_path / "runs", tmp_path, "testkit.fake_fitters:instant_fit",
                          env)
    try:
        code = worker.wait(timeout=STARTUP_S)   # it ends once its fit process failed to start
    finally:
        stop(worker)
        tokens.undeclare()
    assert code == 2
    assert "the fit process ended at start-up" in (tmp_path / "wf.log").read_text()
    assert seen == []   # never declared alive, so never handed a run
