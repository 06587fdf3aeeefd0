"""Support for the tests and the tools: ports, one bounded wait, process harnesses, data writers.

Nothing here is used by `daq`, `ident` or `schemas`; tests and `tools/*.py` import the
submodules directly (`from testkit.waiting import wait_until`), never each other by path.

- `ports`: free loopback TCP ports and Zenoh endpoints.
- `waiting`: `wait_until`, the one bounded wait on a condition or an event.
- `repo`: the checkout's root (the working directory of child processes).
- process harnesses: `daq_process` (`daq` as a subprocess), `worker_harness` (`ident worker`
  processes, a stand-in daq, a fit collector), `fake_fitters` (fitters the worker tests
  plug in), `benchkit` (a whole bench as a service), `faultkit` (kill -9 trials),
  `web_harness` and `web_support` (the bench page in a process or a thread, headless
  Chromium), `browser_page` (the page in Chromium and its DOM read-outs), `zenoh_router`
  (a Zenoh router from Python, also `tools/zenoh_router.py`), `secure_bus` (the lab's secure
  router and its clients, for the access tests).
- the faults of issue 14 (`tools/bench_faults.py --issue14`): `fault_rows` (all rows),
  `fault_table` (the `Row` and its table), `fault_rows_files`, `fault_rows_worker`,
  `fault_rows_resources` (the rows by concept), `full_disk` (a disk that fills up, behind
  the daq's file opener), `peak_memory` (the peak memory of one call in a fresh child, or
  of another process, from the kernel's high-water mark).
- generators: `effects` (runs with a hidden effect, written from the physics, for the
  diagnosis tests and `tools/bench_diagnose.py`).
- data writers and readers: `mcap_runs` (daq-style MCAP runs), `ident_synth` (synthetic
  runs for identification), `synth_runs` (bench traces for the release detector),
  `lab_runs` (the three lab cases recorded by `daq run`), `sim_support` (reading and
  decoding a finite port), `serialfaults` (serial fault injection and its truth),
  `daq_records` (run metadata and sample batches).
- judges: `release_judge` (an independent release instant in a real record),
  `release_tally` (the release detector scored against a simulated hand).
"""
