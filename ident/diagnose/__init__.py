"""Diagnosis of a release run: what the linear simulation gets wrong, the physical cause,
the extended model and the measured gain (issue 4). Pure numerics: arrays in, results out.

Modules: `window` (release, hand's influence), `modal` (variable projection, spectra),
`models`
(baseline and extensions), `starts` (start values, bounds), `fitting` (output-error fits),
`lattice` (quantization), `evidence` (residual analysis), `select` (tests against noise),
`explain` (words), `still` (outputs that never move, dropped before fitting), `stretch` (the
columns and samples diagnosed: checks, the release's window, free and held carts), `run` (`diagnose`).
"""

from __future__ import annotations

from ident.diagnose.run import Diagnosis, diagnose

__all__ = ["Diagnosis", "diagnose"]
