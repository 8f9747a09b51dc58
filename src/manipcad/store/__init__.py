"""The workspace: the results store (one folder per simulation run, written atomically)."""

from manipcad.store.results import (
    SaveInterrupted,
    check_out_dir,
    clean_stale,
    load_result,
    record_every_for,
    result_document,
    save_result,
    write_csv,
)

__all__ = ["save_result", "load_result", "check_out_dir", "result_document", "clean_stale",
           "write_csv", "record_every_for", "SaveInterrupted"]
