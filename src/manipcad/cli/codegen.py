"""``manipcad codegen``: customized dynamics code for one robot (numba module or C99).

::

    manipcad codegen ROBOT [--out DIR] [--lang numba|c] [--stats] [--json] [--prefix P]
                           [--regulators REG.yaml]

Writes ``DIR/<prefix>_dynamics.py`` (numba) or ``DIR/<prefix>.h`` and
``DIR/<prefix>.c`` (C99), prefix the robot's name as a C identifier unless
``--prefix`` says otherwise; ``--stats`` prints the operation counts of the
generated code (``--json``: as JSON, ``{"inverse_dynamics": {"mul": N, "add": N,
"trig": N, "sqrt": N}, "mass_matrix": {...}, ...}``, files written silently).
With ``--lang c --regulators REG.yaml`` it also writes ``DIR/<prefix>_regulators.h`` and
``.c``: each regulator's update translated from the law the simulator runs
(:mod:`manipcad.control.c_code`, API in docs/codegen.md).
Bad input exits with status 2 and one line on stderr.
"""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

from rich import box

from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import RobotArgument, json_flag, option
from manipcad.cli.tables import Table
from manipcad.codegen import c_identifier, generate
from manipcad.control.files import load_regulators
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.fileio import atomic_write_text, writable_target
from manipcad.model.load import load_robot


@app.command()
@guarded
def codegen(
    robot: RobotArgument,
    out: option(str | None, "--out", "Folder to write the code into (created if missing).") = None,
    lang: option(str, "--lang", "numba or c.") = "numba",
    stats: option(bool, "--stats", "Print the operation counts of the generated code.") = False,
    as_json: json_flag("Print the counts as JSON.") = False,
    prefix: option(str | None, "--prefix", "C identifier prefix of the file and function names "
                   "(default: the robot's name).") = None,
    regulators: option(str | None, "--regulators", "Regulator file (manipcad synthesize --out): "
                       "also write each regulator's update as C (needs --lang c).") = None,
) -> None:
    """Customized inverse dynamics, mass matrix, moment components and forward dynamics."""

    if lang not in ("numba", "c"):
        raise InputError("--lang", "", f"must be 'numba' or 'c', got {lang!r}")
    if prefix is not None and not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise InputError("--prefix", "", f"must be a C identifier, got {prefix!r}")
    if out is None and not (stats or as_json):
        raise InputError("--out", "", "give a folder to write the code into, or --stats")
    if regulators is not None and (lang != "c" or out is None):
        raise InputError("--regulators", "", "needs --lang c and --out DIR (the regulators "
                                              "are written as C)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)  # data-set quirks, see robots show
        model = load_robot(robot)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)  # the fallback's reason follows
        gen = generate(model, attach=False)
    if not gen.generated:
        raise ManipcadError(f"cannot customize {robot}: {gen.reason}")
    p = prefix or c_identifier(model.name)
    reg_code = None
    if regulators is not None:
        # deferred: start-up cost: keeps manipcad.control.c_code out of the CLI's start
        from manipcad.control.c_code import regulators_c

        regs = load_regulators(regulators, model)
        reg_code = regulators_c(regs, model, p, source=Path(regulators).name)
    written = []
    if out is not None:
        folder = Path(out)
        if folder.exists() and not folder.is_dir():
            raise InputError("--out", "", f"{folder} exists and is not a folder")

        if lang == "c":
            hdr, src = gen.c_code(p)
            files = {f"{p}.h": hdr, f"{p}.c": src}
            if reg_code is not None:
                files.update({f"{p}_regulators.h": reg_code[0], f"{p}_regulators.c": reg_code[1]})
        else:
            files = {f"{p}_dynamics.py": gen.python_source()}
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError("--out", "", f"cannot write into {folder}: {exc}") from None
        for fname in files:  # every target checked before any is written
            writable_target(folder / fname)
        written = [atomic_write_text(folder / fname, text) for fname, text in files.items()]
    if as_json:  # the counts only: {"inverse_dynamics": {"mul": N, ...}, ...}
        print(json.dumps(gen.ops, indent=2))
        return
    for w in written:
        console.print(f"wrote {w}", highlight=False)
    if stats:
        table = Table(box=box.SIMPLE_HEAD, title=(
            f"{model.name} ({model.n} joints): operations of the generated code "
            "(drive terms included; longest path)"))
        for col in ("function", "mul", "add", "sin/cos", "sqrt"):
            table.add_column(col, justify="left" if col == "function" else "right")
        for name, c in gen.ops.items():
            table.add_row(name, str(c["mul"]), str(c["add"]), str(c["trig"]), str(c["sqrt"]))
        console.print(table)
