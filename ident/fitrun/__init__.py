"""Fit a run: load, analyse, `FitReport` — the one use case behind `ident fit`, `ident report`
and the worker. `analysis` (pure: IdData in, `RunAnalysis` out), `records` (`RunAnalysis` ->
`schemas.fit.FitReport`), `usecase` (the two stages, with a release selection). Renders
nothing: figures and documents are `ident.report`'s."""

from ident.fitrun.analysis import (
                                   FitSettings,
                                   RunAnalysis,
                                   SimpleResult,
                                   analyse,
                                   analyse_fits,
                                   detect_case,
                                   with_diagnosis,
)
from ident.fitrun.records import poly_text, tf_text, to_fit_report
from ident.fitrun.usecase import (
                                   ReleaseSelector,
                                   Renderer,
                                   RunFileOptions,
                                   RunFit,
                                   RunIdentity,
                                   complete,
                                   failed_report,
                                   fit_file,
                                   fit_first,
                                   load_run,
                                   report_of,
                                   with_pending,
                                   with_run_drive,
)

__all__ = [
                                   "FitSettings",
                                   "ReleaseSelector",
                                   "Renderer",
                                   "RunAnalysis",
                                   "RunFileOptions",
                                   "RunFit",
                                   "RunIdentity",
                                   "SimpleResult",
                                   "analyse",
                                   "analyse_fits",
                                   "complete",
                                   "detect_case",
                                   "failed_report",
                                   "fit_file",
                                   "fit_first",
                                   "load_run",
                                   "poly_text",
                                   "report_of",
                                   "tf_text",
                                   "to_fit_report",
                                   "with_diagnosis",
                                   "with_pending",
                                   "with_run_drive",
]
