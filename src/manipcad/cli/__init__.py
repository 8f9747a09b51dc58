"""The ``manipcad`` command.

Each sub-command lives in its own module and registers itself on :data:`app`;
bad input raises :class:`manipcad.errors.ManipcadError`, which :func:`main`
turns into one line on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

from manipcad.cli.app import app, main

# sub-commands register on import
from manipcad.cli import (  # noqa: E402,F401  isort: skip
    demo, robots, simulate, size, identify, coupling, recommend, study, synthesize, verify,
    warmup)
from manipcad.cli import codegen  # noqa: E402,F401  isort: skip
from manipcad.cli import ws  # noqa: E402,F401  isort: skip
from manipcad.cli import claims  # noqa: E402,F401  isort: skip
from manipcad.cli import robustness  # noqa: E402,F401  isort: skip
from manipcad.cli import design  # noqa: E402,F401  isort: skip
from manipcad.cli import ui  # noqa: E402,F401  isort: skip
from manipcad.cli import select  # noqa: E402,F401  isort: skip
from manipcad.cli import catalog  # noqa: E402,F401  isort: skip

__all__ = ["app", "main"]
