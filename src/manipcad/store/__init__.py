"""The workspace: the results store (one folder per simulation run, written atomically)."""

from manipcad.store.results import check_out_dir, load_result, result_document, save_result

__all__ = ["save_result", "load_result", "check_out_dir", "result_document"]
