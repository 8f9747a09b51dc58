"""The results store: one folder per simulation run, written atomically
(:mod:`manipcad.folders`)."""

from manipcad.folders import SaveInterrupted, clean_stale
from manipcad.store.results import (
    check_out_dir,
    every_for,
    load_result,
    result_document,
    save_result,
    write_csv,
)

__all__ = ["save_result", "load_result", "check_out_dir", "result_document", "clean_stale",
           "write_csv", "every_for", "SaveInterrupted"]
