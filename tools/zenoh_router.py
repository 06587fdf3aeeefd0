"""Start a Zenoh router from Python (no `zenohd` needed): the lab's hub for several benches.

    python tools/zenoh_router.py                                  # plain router on tcp/127.0.0.1:7447
    python tools/zenoh_router.py --listen tcp/127.0.0.1:7500
    python tools/zenoh_router.py --config tools/zenoh/router-secure.json5 \
        --credentials /etc/cartlab/zenoh-credentials.txt --listen tcp/10.0.0.5:7447

The router itself (configs, options, `open_router`) is `testkit.zenoh_router`, shared with
the tests.
"""

from __future__ import annotations

import sys

from testkit.zenoh_router import main

if __name__ == "__main__":
    sys.exit(main())
