"""Customized per-robot dynamics: generate, cache by content hash, load, call.

:func:`generate` builds the symbolic model (:mod:`manipcad.codegen.symbolic`),
prints it as a numba module and as C99 (:mod:`manipcad.codegen.emit`), and
keeps both under ``$XDG_CACHE_HOME/manipcad/codegen/<hash>/`` (default
``~/.cache/manipcad/codegen``). The hash covers everything the kernels read
(the robot's packed table and gravity) and the generator's own source, so a
changed robot or generator gets a new folder and a stale module is never
loaded; a folder whose recorded hash differs from its name is regenerated.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
import warnings
import weakref
from pathlib import Path
from typing import NamedTuple

import numba as nb
import numpy as np
import symengine as se

from manipcad.codegen import emit, trig
from manipcad.codegen.cabi import CFUNC_SIGNATURES
from manipcad.codegen.emit import AddTo, Check, Friction, IfDrives, Let, Store
from manipcad.codegen.symbolic import Dynamics, dynamics, num
from manipcad.dynamics._inputs import as_states
from manipcad.dynamics.api import forward_dynamics, inverse_dynamics, mass_matrix
from manipcad.dynamics.components import torque_components
from manipcad.dynamics.generated import attach as attach_kernels
from manipcad.dynamics.generated import attached
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR, Robot

#: the largest number of joints customized: the mass matrix alone has n(n+1)/2
#: expressions whose trees grow with n, and numba's compile time with the code's
#: length (about 30 s at 20 joints); a larger robot runs on the general kernels
MAX_JOINTS = 20
FUNCTIONS = ("inverse_dynamics", "mass_matrix", "moment_components", "forward_dynamics")
_PREFIX_TOKEN = "@PREFIX@"
#: the single-state kernels' angle block is padded to a multiple of this (4 float64: one
#: AVX2 register; the vectorized loop then needs no scalar remainder)
_BLOCK = 4
_loaded: dict[str, object] = {}  # hash -> module


def cache_root() -> Path:
    """The folder of generated modules: $XDG_CACHE_HOME/manipcad/codegen (~/.cache default)."""
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "manipcad" / "codegen"


def _generator_digest() -> str:
    h = hashlib.sha256()
    for name in ("symbolic.py", "emit.py", "generate.py", "cabi.py", "trig.py", "lower.py"):
        h.update((Path(__file__).parent / name).read_bytes())
    h.update(se.__version__.encode())
    return h.hexdigest()


def robot_hash(robot: Robot) -> str:
    """Content hash of what the generated kernels depend on (hex, 64 characters).

    Args:
        robot: the manipulator.

    Returns:
        sha256 of the packed model table, the gravity vector and the generator's source.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen import robot_hash
        >>> puma = manipcad.load_robot("puma560")
        >>> robot_hash(puma) == robot_hash(puma.with_payload(1.0))
        False
    """
    h = hashlib.sha256()
    h.update(_generator_digest().encode())
    h.update(np.ascontiguousarray(robot.table, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(robot.gravity, dtype=np.float64).tobytes())
    return h.hexdigest()


def c_identifier(name: str) -> str:
    """A robot name as a C identifier: other characters become ``_``, lower case.

    Example:
        >>> c_identifier("UR5 arm-2")
        'ur5_arm_2'
    """
    s = re.sub(r"[^0-9A-Za-z_]", "_", name).lower()
    if not s or s[0].isdigit():
        s = "r_" + s
    return s


#: characters a text may keep inside generated code (a C comment, a Python docstring):
#: letters, digits and plain punctuation; never a quote mark, backslash, star, question
#: mark, brace, ``@`` or line break, so the text cannot end the comment or string it is
#: in (``*/``, ``"""``), continue a line (``\``), form a trigraph (``??/``) or a template
#: field (``{x}``, ``@PREFIX@``)
_CODE_TEXT = re.compile(r"[^\w .,:;()+\-#=<>\[\]!&%~^|/]")


def code_text(text: object, limit: int = 120) -> str:
    """Text from a file (a robot's or joint's name, a file name) made safe to write into
    generated code's comments and docstrings: every other character becomes ``_`` and
    the text is cut to ``limit`` characters. Every string that reaches generated code
    goes through here or :func:`c_identifier`.

    Example:
        >>> code_text('arm */ int x; /* "x"')
        'arm _/ int x; /_ _x_'
    """
    s = _CODE_TEXT.sub("_", str(text))
    return s if len(s) <= limit else s[:limit - 3] + "..."


# ------------------------------------------------------------------ functions
def _drive_expr(rotor: float, viscous: float, qdd, qd):
    return num(rotor) * qdd + num(viscous) * qd


def _id_stmts(d: Dynamics) -> list:
    fr = d.frames
    lets, red = emit.cse(d.tau)
    st = lets + [Store(("tau", i), e) for i, e in enumerate(red)]
    body = []
    for i in range(fr.n):
        e = _drive_expr(d.rotor[i], d.viscous[i], fr.qdd[i], fr.qd[i])
        if e != 0:
            body.append(AddTo(("tau", i), e))
        if d.dry_pos[i] or d.dry_neg[i]:
            body.append(Friction(("tau", i), f"qd{i}", d.dry_pos[i], d.dry_neg[i]))
    return st + [IfDrives(body)]


def _lower(d: Dynamics):
    return [(i, j) for i in range(d.frames.n) for j in range(i + 1)]


def _mass_stmts(d: Dynamics) -> list:
    idx = _lower(d)
    lets, red = emit.cse([d.H[i][j] for i, j in idx])
    st = list(lets)
    for (i, j), e in zip(idx, red, strict=True):
        if i != j and not (isinstance(e, se.Symbol) or e.is_Number):
            st.append(Let(f"H{i}_{j}", e))
            e = se.Symbol(f"H{i}_{j}")
        st.append(Store(("H", i, j), e))
        if i != j:
            st.append(Store(("H", j, i), e))
    body = [AddTo(("H", i, i), num(d.rotor[i])) for i in range(d.frames.n) if d.rotor[i]]
    return st + [IfDrives(body)]


def _components_stmts(d: Dynamics) -> list:
    n = d.frames.n
    lets, red = emit.cse([d.H[i][i] for i in range(n)] + d.velocity + d.gravity)
    st = list(lets)
    for i in range(n):
        st.append(Store(("H_ii", i), red[i]))
        st.append(Store(("h", i), red[n + i]))
        st.append(Store(("Qg", i), red[2 * n + i]))
    return st


def _fd_stmts(d: Dynamics) -> list:
    fr = d.frames
    n = fr.n
    idx = _lower(d)
    lets, red = emit.cse([d.H[i][j] for i, j in idx] + d.bias)
    st = list(lets)
    H = [[se.Integer(0)] * n for _ in range(n)]
    for (i, j), e in zip(idx, red[:len(idx)], strict=True):
        if e != 0:
            st.append(Let(f"H{i}_{j}", e, mutable=i == j))
            H[i][j] = H[j][i] = se.Symbol(f"H{i}_{j}")
    body = []
    for i, e in enumerate(red[len(idx):]):
        st.append(Let(f"b{i}", e, mutable=True))
        if d.rotor[i]:
            body.append(AddTo(f"H{i}_{i}", num(d.rotor[i])))
        if d.viscous[i]:
            body.append(AddTo(f"b{i}", num(d.viscous[i]) * fr.qd[i]))
        if d.dry_pos[i] or d.dry_neg[i]:
            body.append(Friction(f"b{i}", f"qd{i}", d.dry_pos[i], d.dry_neg[i]))
        if d.rotor[i] and H[i][i] == 0:
            raise ManipcadError("internal: a rotor on a joint that moves no mass")
    st.append(IfDrives(body))
    # H = L·D·Lᵀ (L unit lower triangular, D diagonal: the square-root-free Cholesky), then
    # L·y = tau - b and D·Lᵀ·x = y; W_ij = L_ij·D_j, iv_j = 1/D_j. A simulator calls this
    # once per stage and waits for the result, so the code is ordered for latency: each
    # column's pivot waits for the previous one through one division (no square root),
    # and every sum takes its terms in the order they become ready, the newest last, as
    # its own statement (the printed expression's order is symengine's), so the chain from
    # one pivot to the next is a multiplication, a subtraction and the division; the
    # newest term of a pivot or of W is (W_ik·W_jk)·iv_k with W_ik·W_jk formed earlier.
    L = [[None] * n for _ in range(n)]
    W = [[None] * n for _ in range(n)]
    inv = [None] * n

    def chain(name, first, terms):
        """``name = first - t_1 - t_2 - ...``, in this order (terms: (a, b) for a·b)."""
        if not terms:
            if first == 0 or isinstance(first, se.Symbol):
                return first
            st.append(Let(name, first))
            return se.Symbol(name)
        if first == 0:  # no constant part: start from the first term
            (a, b), terms = terms[0], terms[1:]
            first = -(a * b)
        st.append(Let(name, first, mutable=True))
        for a, b in terms:
            st.append(AddTo(name, -(a * b)))
        return se.Symbol(name)

    def products(i, j):
        """The terms W_ik·L_jk (k < j) of entry (i, j), oldest first; the newest as
        (W_ik·W_jk)·iv_k."""
        ks = [k for k in range(j) if W[i][k] is not None and W[j][k] is not None]
        terms = [(W[i][k], L[j][k]) for k in ks[:-1]]
        if ks:
            k = ks[-1]
            st.append(Let(f"P{i}_{j}", W[i][k] * W[j][k]))
            terms.append((se.Symbol(f"P{i}_{j}"), inv[k]))
        return terms

    for j in range(n):
        dj = chain(f"d{j}", H[j][j], products(j, j))
        if not isinstance(dj, se.Symbol) or str(dj) != f"d{j}":
            st.append(Let(f"d{j}", dj))
        st.append(Check(f"d{j}", j))
        st.append(Let(f"iv{j}", se.Pow(se.Symbol(f"d{j}"), se.Integer(-1))))
        inv[j] = se.Symbol(f"iv{j}")
        for i in range(j + 1, n):
            w = chain(f"W{i}_{j}", H[i][j], products(i, j))
            if w == 0:
                continue
            W[i][j] = w
            st.append(Let(f"L{i}_{j}", w * inv[j]))
            L[i][j] = se.Symbol(f"L{i}_{j}")
    b = [se.Symbol(f"b{i}") for i in range(n)]
    tau = [se.Symbol(f"tau{i}") for i in range(n)]
    y = [None] * n
    for i in range(n):
        st.append(Let(f"y{i}", tau[i] - b[i], mutable=True))
        for k in range(i):
            if L[i][k] is not None:
                st.append(AddTo(f"y{i}", -(L[i][k] * y[k])))
        y[i] = se.Symbol(f"y{i}")
    x = [None] * n
    for i in range(n - 1, -1, -1):
        st.append(Let(f"sol{i}", y[i] * inv[i], mutable=True))
        for k in range(n - 1, i, -1):  # the oldest solution first
            if L[k][i] is not None:
                st.append(AddTo(f"sol{i}", -(L[k][i] * x[k])))
        x[i] = se.Symbol(f"sol{i}")
        st.append(Store(("qdd", i), x[i]))
    return st


def _free_names(stmts: list) -> set[str]:
    names: set[str] = set()
    for s in stmts:
        if isinstance(s, IfDrives):
            names |= _free_names(s.body)
            continue
        if isinstance(s, Friction):
            names.add(s.qd)
            continue
        e = getattr(s, "expr", None)
        if e is not None and not isinstance(e, (int, float)):
            names |= {str(v) for v in se.sympify(e).free_symbols}
    return names


# the inputs each function reads: (argument, local prefix)
_INPUTS = {
    "inverse_dynamics": (("q", "q"), ("qd", "qd"), ("qdd", "qdd")),
    "mass_matrix": (("q", "q"),),
    "moment_components": (("q", "q"), ("qd", "qd")),
    "forward_dynamics": (("q", "q"), ("qd", "qd"), ("tau", "tau")),
}
_OUTPUTS = {
    "inverse_dynamics": ("tau",),
    "mass_matrix": ("H",),
    "moment_components": ("H_ii", "h", "Qg"),
    "forward_dynamics": ("qdd",),
}


def _read_lines(func: str, d: Dynamics, stmts: list, lang: str, indent: str, batch: bool):
    """Input reads and trig calls the statements need."""
    used = _free_names(stmts)
    # trig symbols may hide inside Let expressions: iterate until closed
    out = []
    fr = d.frames
    for arg, pre in _INPUTS[func]:
        for i in range(fr.n):
            name = f"{pre}{i}"
            need = name in used or (pre == "q" and any(
                f"{k}{i}" in used for k in ("c", "s")))
            if need:
                src = f"{arg.upper()}[k, {i}]" if batch else f"{arg}[{i}]"
                if lang == "c":
                    out.append(f"{indent}const double {name} = {arg}[{i}];")
                else:
                    out.append(f"{indent}{name} = {src}")
    pairs = _trig_pairs(d, used)
    if lang == "python" and not batch:
        # the wrapper computed them into the angle block (_trig_block)
        for p, ks in enumerate(pairs.values()):
            out += [f"{indent}{ks[w]} = T{w[0].upper()}[{p}]" for w in ("sin", "cos") if w in ks]
        return out
    for p, ((j, off), ks) in enumerate(pairs.items()):
        arg = f"q{j}" if off == 0.0 else f"q{j} + {emit._num(off)}"
        sn, cn = str(ks.get("sin", "_")), str(ks.get("cos", "_"))
        if lang == "c":
            sn, cn = (sn if sn != "_" else f"s_unused{p}"), (cn if cn != "_" else f"c_unused{p}")
            out.append(f"{indent}double {sn}, {cn};")
            out.append(f"{indent}{_PREFIX_TOKEN}_sincos({arg}, &{sn}, &{cn});")
        elif batch:  # from the vectorized pass before the loop (_trig_pass)
            out += [f"{indent}{x} = T{w}[{p} * NB + k]" for x, w in ((sn, "S"), (cn, "C"))
                    if x != "_"]
    return out


def _trig_pairs(d: Dynamics, used: set) -> dict:
    """(joint, offset) -> {"sin": symbol, "cos": symbol} of the trig values used."""
    pairs: dict = {}
    for sym, kind, j, off in d.frames.trig:
        if str(sym) in used:
            pairs.setdefault((j, off), {})[kind] = sym
    return pairs


def _trig_block(d: Dynamics, stmts: list) -> list[str]:
    """Single-state kernels: the angles in a block of a multiple of 4 on the stack, sin
    and cos of all of them in one vectorized loop (:func:`manipcad.codegen.trig.sincos_block`);
    unused slots are 0."""
    pairs = _trig_pairs(d, _free_names(stmts))
    if not pairs:
        return []
    size = -(-len(pairs) // _BLOCK) * _BLOCK
    out = [f"    T{w} = stack_vector({size})" for w in "XSC"]
    for p, (j, off) in enumerate(pairs):
        arg = f"q[{j}]" if off == 0.0 else f"q[{j}] + {emit._num(off)}"
        out.append(f"    TX[{p}] = {arg}")
    out += [f"    TX[{p}] = 0.0" for p in range(len(pairs), size)]
    out.append("    sincos_block(TX, TS, TC)")
    return out


def _trig_pass(d: Dynamics, stmts: list, first: str) -> list[str]:
    """Batch kernels: every state's angles into one vector, sin and cos of all of them in
    one vectorized loop (:func:`manipcad.codegen.trig.sincos_many`)."""
    pairs = _trig_pairs(d, _free_names(stmts))
    if not pairs:
        return []
    out = [f"    NB = {first}.shape[0]", f"    TX = np.empty({len(pairs)} * NB)",
           "    for k in range(NB):"]
    for p, (j, off) in enumerate(pairs):
        arg = f"Q[k, {j}]" if off == 0.0 else f"Q[k, {j}] + {emit._num(off)}"
        out.append(f"        TX[{p} * NB + k] = {arg}")
    out += ["    TS = np.empty_like(TX)", "    TC = np.empty_like(TX)",
            "    sincos_many(TX, TS, TC)"]
    return out


def _py_function(func: str, n: int, d: Dynamics, stmts: list, batch: bool) -> list[str]:
    """The kernel's statements as a plain function (lowered to LLVM IR by
    :func:`manipcad.codegen.lower.lowered`) and the jitted kernel around them: argument
    checks, the angles' sines and cosines, then one call of the statements (per state in a
    batch)."""
    outs = _OUTPUTS[func]
    ins = [a for a, _ in _INPUTS[func]]
    vec, mat, m3 = "float64[::1]", "float64[:, ::1]", "float64[:, :, ::1]"
    drives = func in ("inverse_dynamics", "mass_matrix", "forward_dynamics")
    if batch:
        A = [a.upper() for a in ins]
        O = [o.upper() for o in outs]
        arg_t = [mat] * len(A) + (["boolean"] if drives else []) + \
            [m3 if o == "H" else mat for o in outs]
        args = A + (["drives"] if drives else []) + O
    else:
        arg_t = [vec] * len(ins) + (["boolean"] if drives else []) + \
            [mat if o == "H" else vec for o in outs]
        args = ins + (["drives"] if drives else []) + list(outs)
    ret = "int64" if func == "forward_dynamics" else "void"
    name = func + ("_batch" if batch else "")
    sig = f"{ret}({', '.join(arg_t)})"
    trig = bool(_trig_pairs(d, _free_names(stmts)))
    # the sines and cosines (a batch's: of all states, NB a state's stride), a batch's state
    extra = (["TS", "TC"] if trig else []) + (["NB"] if batch and trig else []) \
        + (["k"] if batch else [])
    call = f"_{name}_ll({', '.join(args + extra)})"
    if batch:
        fmt = {o: (lambda *ix, o=o: f"{o.upper()}[k, {', '.join(map(str, ix))}]") for o in outs}
        fail = "k"
    else:
        fmt = {o: (lambda *ix, o=o: f"{o}[{', '.join(map(str, ix))}]") for o in outs}
        fail = "{j}"
    body = [f"def _{name}({', '.join(args + extra)}):"]
    body += _read_lines(func, d, stmts, "python", "    ", batch)
    body += emit.lines(stmts, "python", fmt, "    ", fail)
    if func == "forward_dynamics" and not batch:
        body.append("    return -1")
    lines = body + ["", "", f"_{name}_ll = lowered(_{name})", "", "",
                    '@nb.njit(cache=True, nogil=True, error_model="numpy")',
                    f"def {name}({', '.join(args)}):"]
    if batch:
        first = A[0]
        conds = [f"{first}.shape[1] != {n}"] + [f"{a}.shape != {first}.shape" for a in A[1:]]
        conds += [f"{o}.shape[0] != {first}.shape[0]" for o in O]
        lines.append(f"    if {' or '.join(conds)}:")
        lines.append(f'        raise ValueError("arrays of shape (N, {n}) expected")')
        lines += _trig_pass(d, stmts, first)
        lines.append(f"    for k in range({first}.shape[0]):")
        if func == "forward_dynamics":
            lines += [f"        bad = {call}", "        if bad >= 0:", "            return bad",
                      "    return -1"]
        else:
            lines.append(f"        {call}")
    else:
        conds = [f"{a}.shape[0] != {n}" for a in ins + [o for o in outs if o != "H"]]
        if "H" in outs:
            conds += [f"H.shape[0] != {n}", f"H.shape[1] != {n}"]
        lines.append(f"    if {' or '.join(conds)}:")
        lines.append(f'        raise ValueError("vectors of length {n} expected")')
        lines += _trig_block(d, stmts)
        lines.append(f"    {'return ' if func == 'forward_dynamics' else ''}{call}")
    return lines + ["", ""], sig


def _python_source(d: Dynamics, stmts: dict, robot_name: str, digest: str) -> str:
    """The numba module's source (single-state and batch functions of each kind)."""
    n = d.frames.n
    head = [
        f'"""Customized dynamics of \'{code_text(robot_name)}\', {n} joints: generated by '
        "manipcad.codegen.",
        "",
        "Do not edit: the file is regenerated when the robot or the generator changes.",
        "SI units: q rad or m, qd rad/s or m/s, qdd rad/s² or m/s², tau N·m or N.",
        "numba compiles each function on its first call (and caches it on disk); the",
        "statements of kernel f are the plain function _f, which manipcad.codegen.lower",
        "turns into LLVM IR directly (f calls it once); the cfunc_* wrappers are made",
        "C-ABI kernels by GeneratedDynamics.cfunc.",
        '"""',
        "",
        "import math",
        "",
        "import numba as nb",
        "from numba import carray",
        "",
        "import numpy as np",
        "from manipcad.codegen.cabi import f64_ptr, stack_vector",
        "from manipcad.codegen.lower import lowered",
        "from manipcad.codegen.trig import sincos_block, sincos_many",
        "",
        f"N = {n}",
        f'ROBOT_HASH = "{digest}"',
        "",
        "",
    ]
    body, sigs = [], []
    for func in FUNCTIONS:
        for batch in (False, True):
            lines, sig = _py_function(func, n, d, stmts[func], batch=batch)
            body += lines
            sigs.append(f'    "{func}{"_batch" if batch else ""}": "{sig}",')
    body += _cfunc_wrappers(n)
    return "\n".join(head + body + ["SIGNATURES = {"] + sigs + ["}"]) + "\n"


def _cfunc_wrappers(n: int) -> list[str]:
    """Module-level wrappers on raw addresses (see GeneratedDynamics.cfunc)."""
    def arr(x, shape=None):
        return f"carray(f64_ptr({x}), {shape or 'N'})"

    out = []
    for dr in (0, 1):
        # bool(0) / bool(1), not the literal False / True: numba types a literal flag
        # Literal[bool] and compiles a specialization of the kernel per flag; bool() of an
        # int is a plain boolean, so one compile serves both flags and the Python calls
        flag = f"bool({dr})"
        out += [f"def cfunc_inverse_dynamics_{dr}(a, b, c, d):",
                f"    inverse_dynamics({arr('a')}, {arr('b')}, {arr('c')}, {flag}, {arr('d')})",
                "    return 0", "", "",
                f"def cfunc_mass_matrix_{dr}(a, b):",
                f"    mass_matrix({arr('a')}, {flag}, {arr('b', '(N, N)')})",
                "    return 0", "", "",
                f"def cfunc_forward_dynamics_{dr}(a, b, c, d):",
                f"    return forward_dynamics({arr('a')}, {arr('b')}, {arr('c')}, {flag}, "
                f"{arr('d')})", "", ""]
    out += ["def cfunc_moment_components(a, b, c, d, e):",
            f"    moment_components({arr('a')}, {arr('b')}, {arr('c')}, {arr('d')}, {arr('e')})",
            "    return 0", "", ""]
    return out


_C_SIGNATURES = {
    "inverse_dynamics": ("void", "const double *q, const double *qd, const double *qdd, "
                                 "double *tau"),
    "mass_matrix": ("void", "const double *q, double *H"),
    "moment_components": ("void", "const double *q, const double *qd, double *H_ii, double *h, "
                                  "double *Qg"),
    "forward_dynamics": ("int", "const double *q, const double *qd, const double *tau, "
                                "double *qdd"),
}
_C_DOCS = {
    "inverse_dynamics": "Joint torques tau[n] (N·m or N) from q (rad or m), qd, qdd; drive "
                        "terms included\n   (rotor inertia J·i_r², viscous and dry friction).",
    "mass_matrix": "Joint-space inertia matrix H[n*n] (row-major, kg·m², kg or kg·m) with the "
                   "rotor inertias\n   J·i_r² on the diagonal.",
    "moment_components": "The moment components of paper 4.1: H_ii[n] (links only), h[n] "
                         "(velocity constituent,\n   N·m or N) and Qg[n] (gravity constituent).",
    "forward_dynamics": "Joint accelerations qdd[n] (rad/s² or m/s²) under torques tau[n], "
                        "drive terms included\n   (mass matrix and L·D·Lᵀ factorization). Returns "
                        "-1, or the joint index where H is not positive definite.",
}


#: the functions also emitted for the rigid body alone, ``<P>_<func>_rigid`` (a regulator
#: such as computed_torque_full takes the rigid-body H; the drive terms are its own)
_C_RIGID_DOCS = {
    "inverse_dynamics": "The same for the rigid body alone: no rotor inertia, no viscous or "
                        "dry friction of\n   the drives (the Python module's drives=False).",
    "mass_matrix": "The rigid-body joint-space inertia matrix H[n*n] (row-major), without "
                   "the rotor\n   inertias (the Python module's drives=False).",
}


def _c_sources(d: Dynamics, stmts: dict, robot_name: str, digest: str) -> tuple[str, str]:
    """(header, source) templates with the prefix as ``@PREFIX@``: portable C99."""
    n = d.frames.n
    P = _PREFIX_TOKEN
    guard = "@PREFIX_UPPER@_DYNAMICS_H"
    hdr = [f"/* Customized dynamics of '{code_text(robot_name)}' ({n} joints), generated by "
           "manipcad.codegen.",
           "   Portable C99: no allocation, libm's sin, cos and sqrt only. SI units.",
           f"   Robot hash {digest}. */",
           f"#ifndef {guard}", f"#define {guard}", "", f"#define {P}_N {n}", ""]
    src = [f"/* Customized dynamics of '{code_text(robot_name)}', generated by manipcad.codegen. "
           "Do not edit. */", f'#include "{P}.h"', "#include <math.h>", "",
           trig.C_SOURCE]
    for func in FUNCTIONS:
        ret, args = _C_SIGNATURES[func]
        proto = f"{ret} {P}_{func}({args})"
        hdr += [f"/* {_C_DOCS[func]} */", proto + ";", ""]
        st = stmts[func]
        fmt = {"tau": lambda i: f"tau[{i}]", "H": lambda i, j: f"H[{i * n + j}]",
               "H_ii": lambda i: f"H_ii[{i}]", "h": lambda i: f"h[{i}]",
               "Qg": lambda i: f"Qg[{i}]", "qdd": lambda i: f"qdd[{i}]"}
        flag = func != "moment_components"
        # the body takes a drives flag (the Python module's drives=False); the public
        # function includes the drive terms
        src += [f"static {ret} {P}_{func}_body({args}{', int drives' if flag else ''})", "{"]
        if flag:
            src.append("    (void)drives;")
        src += _read_lines(func, d, st, "c", "    ", False)
        src += emit.lines(st, "c", fmt, "    ", "{j}", drives_flag=flag)
        if func == "forward_dynamics":
            src.append("    return -1;")
        src += ["}", ""]
        names = ", ".join(a.split("*")[-1] for a in args.split(", "))
        call = f"{P}_{func}_body({names}{', 1' if flag else ''})"
        src += [proto, "{", f"    {'return ' if ret == 'int' else ''}{call};", "}", ""]
        if func in _C_RIGID_DOCS:  # the rigid body alone (drive terms off)
            rproto = f"{ret} {P}_{func}_rigid({args})"
            hdr += [f"/* {_C_RIGID_DOCS[func]} */", rproto + ";", ""]
            src += [rproto, "{", f"    {P}_{func}_body({names}, 0);", "}", ""]
    hdr += [f"#endif /* {guard} */", ""]
    return "\n".join(hdr), "\n".join(src)


# ------------------------------------------------------------------ CPython extension
_EXT_TEMPLATE = r"""/* CPython wrappers of the generated C: one-state calls, no numba dispatch. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

@SOURCE@

#define NJ @N@

/* 1 when o is a C-contiguous float64 vector of NJ entries */
static int vec(PyObject *o, const double **p)
{
    PyArrayObject *a;
    if (!PyArray_Check(o)) return 0;
    a = (PyArrayObject *)o;
    if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != NJ
        || !PyArray_IS_C_CONTIGUOUS(a)) return 0;
    *p = (const double *)PyArray_DATA(a);
    return 1;
}

static PyObject *out(int nd, double **p)
{
    npy_intp dims[2] = {NJ, NJ};
    PyObject *o = PyArray_SimpleNew(nd, dims, NPY_DOUBLE);
    if (o) *p = (double *)PyArray_DATA((PyArrayObject *)o);
    return o;
}

/* each returns None when an argument is not a float64 vector of NJ entries */
static PyObject *w_id(PyObject *self, PyObject *const *a, Py_ssize_t n)
{
    const double *q, *qd, *qdd; double *t; PyObject *o; int dr;
    (void)self;
    if (n != 4 || !vec(a[0], &q) || !vec(a[1], &qd) || !vec(a[2], &qdd)) Py_RETURN_NONE;
    dr = PyObject_IsTrue(a[3]);
    if (dr < 0 || !(o = out(1, &t))) return NULL;
    mcg_inverse_dynamics_body(q, qd, qdd, t, dr);
    return o;
}

static PyObject *w_mass(PyObject *self, PyObject *const *a, Py_ssize_t n)
{
    const double *q; double *H; PyObject *o; int dr;
    (void)self;
    if (n != 2 || !vec(a[0], &q)) Py_RETURN_NONE;
    dr = PyObject_IsTrue(a[1]);
    if (dr < 0 || !(o = out(2, &H))) return NULL;
    mcg_mass_matrix_body(q, H, dr);
    return o;
}

static PyObject *w_fd(PyObject *self, PyObject *const *a, Py_ssize_t n)
{
    const double *q, *qd, *tau; double *x; PyObject *o; int dr, bad;
    (void)self;
    if (n != 4 || !vec(a[0], &q) || !vec(a[1], &qd) || !vec(a[2], &tau)) Py_RETURN_NONE;
    dr = PyObject_IsTrue(a[3]);
    if (dr < 0 || !(o = out(1, &x))) return NULL;
    bad = mcg_forward_dynamics_body(q, qd, tau, x, dr);
    if (bad >= 0) { Py_DECREF(o); return PyLong_FromLong(bad); }
    return o;
}

static PyMethodDef methods[] = {
    {"inverse_dynamics", (PyCFunction)(void (*)(void))w_id, METH_FASTCALL, "tau or None"},
    {"mass_matrix", (PyCFunction)(void (*)(void))w_mass, METH_FASTCALL, "H or None"},
    {"forward_dynamics", (PyCFunction)(void (*)(void))w_fd, METH_FASTCALL,
     "qdd, the joint index where H is not positive definite, or None"},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "@NAME@", NULL, -1, methods,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit_@NAME@(void)
{
    import_array();
    return PyModule_Create(&module);
}
"""


def _extension(path: Path, digest: str, n: int):
    """The CPython extension of the generated C (built once into the cache folder), or None.

    It serves the one-state calls from Python (numba's dispatch of four arrays
    costs about a microsecond, more than the dynamics); None when no C compiler
    or Python headers are available: the numba kernels then serve those calls.
    """

    name = f"mcgen_{digest[:16]}"
    so = path / f"{name}{sysconfig.get_config_var('EXT_SUFFIX') or '.so'}"
    if not so.is_file():
        cc = shutil.which("cc") or shutil.which("gcc")
        inc = sysconfig.get_paths().get("include", "")
        if cc is None or not (Path(inc) / "Python.h").is_file():
            return None
        src = (path / "kernels.c.in").read_text().replace(_PREFIX_TOKEN, "mcg")
        src = src.replace('#include "mcg.h"', "")
        text = (_EXT_TEMPLATE.replace("@SOURCE@", src).replace("@N@", str(n))
                .replace("@NAME@", name))
        c_file = path / f"{name}.{os.getpid()}.c"
        c_file.write_text(text)
        tmp = so.with_suffix(f".{os.getpid()}.tmp")
        cmd = [cc, "-O2", "-ffp-contract=off", "-shared", "-fPIC", f"-I{inc}",
               f"-I{np.get_include()}", "-o", str(tmp), str(c_file), "-lm"]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            warnings.warn(f"compiling {c_file} failed ({res.stderr.strip()[:300]}); one-state "
                          "calls use the numba kernels", ManipcadWarning, stacklevel=3)
            return None
        os.replace(tmp, so)
    spec = importlib.util.spec_from_file_location(name, so)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _detached() -> None:
    """What an attached :class:`GeneratedDynamics` unpickles to (see its ``__reduce__``)."""
    return None


def _vectors(*arrays) -> bool:
    """True when every argument is a C-contiguous float64 ndarray of one dimension."""
    return all(type(a) is np.ndarray and a.ndim == 1 and a.dtype == np.float64
               and a.flags.c_contiguous for a in arrays)


class _NoExtension:
    """Stands for the extension when there is none: every call declines (None)."""

    def inverse_dynamics(self, *args):
        return None

    mass_matrix = forward_dynamics = inverse_dynamics


_NO_EXTENSION = _NoExtension()


class _LazyExtension:
    """Builds (or loads) the extension on the first one-state call, then steps aside."""

    def __init__(self, gen) -> None:
        self.gen = gen

    def _get(self):
        g = self.gen
        ext = _extension(g.path, g.hash, g.n) if g.path is not None else None
        g._x = ext if ext is not None else _NO_EXTENSION
        return g._x

    def inverse_dynamics(self, *args):
        return self._get().inverse_dynamics(*args)

    def mass_matrix(self, *args):
        return self._get().mass_matrix(*args)

    def forward_dynamics(self, *args):
        return self._get().forward_dynamics(*args)


# ------------------------------------------------------------------ the object
class MomentComponents(NamedTuple):
    """H_ii (links only, kg·m² or kg), h_i and Q_i (N·m or N), each shaped like q."""

    H_ii: np.ndarray
    velocity: np.ndarray
    gravity: np.ndarray


class GeneratedDynamics:
    """Customized kernels of one robot; made by :func:`generate`.

    Attributes:
        robot: the robot generated for.
        n: number of joints.
        hash: :func:`robot_hash` of the robot.
        generated: True for customized kernels, False for the general fallback.
        reason: why the fallback is used ("" when generated).
        ops: per function ``{"mul", "add", "trig", "sqrt"}`` counted from the
            generated single-state code ({} for the fallback).
        path: the cache folder holding ``kernels.py`` and the C templates, or None.
        seconds: generation time (symbolic work and printing), s; 0 when loaded from cache.
    """

    def __init__(self, robot: Robot, digest: str, module, ops: dict, path: Path | None,
                 seconds: float, reason: str = "") -> None:
        # the robot itself only for the general fallback (no module); generated kernels
        # hold it weakly, so that the registry of attached kernels
        # (manipcad.dynamics.generated) keeps no robot alive
        self._robot = robot if module is None else weakref.ref(robot)
        self.name, self.n, self.hash = robot.name, robot.n, digest
        self.generated = module is not None
        self.reason = reason
        self.ops, self.path, self.seconds = ops, path, seconds
        self._m = module
        self._c: dict = {}  # name -> compiled kernel
        self._cf: dict = {}  # (name, drives) -> C-ABI kernel
        # one-state calls: the CPython extension of the C code, built on first use
        self._x = _LazyExtension(self) if module is not None else _NO_EXTENSION

    @property
    def robot(self) -> Robot | None:
        """The robot the kernels were made for (None once it is gone: generated kernels
        keep no robot alive)."""
        r = self._robot
        return r() if isinstance(r, weakref.ref) else r

    def kernel(self, name: str):
        """The compiled kernel ``name`` of the generated module (compiled on first use).

        Names: ``inverse_dynamics(q, qd, qdd, drives, tau)``, ``mass_matrix(q, drives, H)``,
        ``moment_components(q, qd, H_ii, h, Qg)``, ``forward_dynamics(q, qd, tau, drives,
        qdd) -> int`` (-1, or the joint where H is not positive definite) on float64
        C-contiguous vectors, and the same with ``_batch`` on (N, n) arrays (H (N, n, n);
        forward_dynamics_batch returns -1 or the failing state). They can be called from
        other numba code.
        """
        f = self._c.get(name)
        if f is None:
            if self._m is None or name not in self._m.SIGNATURES:
                raise ManipcadError(f"no generated kernel {name!r} for {self.name!r}"
                                    + (f": {self.reason}" if self.reason else ""))
            f = getattr(self._m, name)
            self._c[name] = f
        return f

    def __reduce__(self):
        # compiled modules do not pickle: a pickled robot (a process pool, a parallel
        # sweep) arrives without its attachment, and find() reloads it from the cache
        return (_detached, ())

    def __repr__(self) -> str:
        kind = "generated" if self.generated else "general fallback"
        return f"GeneratedDynamics({self.name!r}, n={self.n}, {kind})"

    def cfunc(self, name: str, drives: bool = True):
        """A C-ABI kernel on raw addresses, for other compiled loops (the simulator's).

        A numba ``cfunc`` taking the addresses (``arr.ctypes.data``) of float64
        buffers of n entries (H: n·n, row-major) and returning an int64:

        - ``inverse_dynamics(q, qd, qdd, tau) -> 0``
        - ``mass_matrix(q, H) -> 0``
        - ``moment_components(q, qd, H_ii, h, Qg) -> 0``
        - ``forward_dynamics(q, qd, tau, qdd) -> -1`` or the joint where H is not
          positive definite.

        Passed to a numba function as an argument its type is
        ``numba.types.FunctionType(sig)`` (:attr:`CFUNC_SIGNATURES`), the same
        for every robot, so the caller compiles once and stays cacheable; the
        call takes no reference counts (numba counts them on every array
        passed to a compiled call).

        Args:
            name: one of the four names above.
            drives: include the drive terms (all but moment_components).

        Returns:
            The ``numba.core.ccallback.CFunc``; ``.address`` is its C address.

        Example:
            >>> import numpy as np, manipcad
            >>> from manipcad.codegen import generate
            >>> gen = generate(manipcad.load_robot("cylindrical"))
            >>> f = gen.cfunc("inverse_dynamics")
            >>> q, qd, qdd, tau = np.zeros(3), np.zeros(3), np.zeros(3), np.empty(3)
            >>> f.ctypes(q.ctypes.data, qd.ctypes.data, qdd.ctypes.data, tau.ctypes.data)
            0
        """
        key = (name, bool(drives))
        f = self._cf.get(key)
        if f is None:
            if name not in CFUNC_SIGNATURES:
                raise ManipcadError(f"no C-ABI kernel {name!r}: one of "
                                    f"{', '.join(CFUNC_SIGNATURES)}")
            tail = "" if name == "moment_components" else f"_{int(bool(drives))}"
            f = nb.cfunc(CFUNC_SIGNATURES[name], cache=True, nogil=True)(
                getattr(self._m, f"cfunc_{name}{tail}"))
            self._cf[key] = f
        return f

    # ---- fast single-state path, then the checked path
    def inverse_dynamics(self, q, qd, qdd, drives: bool = True) -> np.ndarray:
        """Joint torques of one state (n,) or a batch (N, n), as :func:`manipcad.inverse_dynamics`.

        Args:
            q, qd, qdd: joint positions (rad or m), velocities (rad/s or m/s),
                accelerations (rad/s² or m/s²).
            drives: add J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇).

        Returns:
            tau, N·m (N for prismatic joints), shaped like q.

        Example:
            >>> import numpy as np, manipcad
            >>> from manipcad.codegen import generate
            >>> gen = generate(manipcad.load_robot("cylindrical"))
            >>> gen.inverse_dynamics(np.zeros(3), np.zeros(3), np.zeros(3)).shape
            (3,)
        """
        tau = self._x.inverse_dynamics(q, qd, qdd, drives)
        if tau is not None:
            return tau
        m = self._m
        if m is None:
            return inverse_dynamics(self.robot, q, qd, qdd, drives=drives, use_generated=False)
        if _vectors(q, qd, qdd):
            tau = np.empty(self.n)
            try:  # the dict lookup inline: this is the call a control loop makes
                (self._c.get("inverse_dynamics") or self.kernel("inverse_dynamics"))(
                    q, qd, qdd, drives, tau)
                return tau
            except (TypeError, ValueError):
                pass
        (Q, QD, QDD), single = as_states(self.n, q=q, qd=qd, qdd=qdd)
        tau = np.empty(Q.shape)
        self.kernel("inverse_dynamics_batch")(Q, QD, QDD, bool(drives), tau)
        return tau[0] if single else tau

    def mass_matrix(self, q, drives: bool = True) -> np.ndarray:
        """H(q), (n, n) or (N, n, n), as :func:`manipcad.mass_matrix` (kg·m², kg, kg·m).

        Args:
            q: joint positions, rad or m, (n,) or (N, n).
            drives: add the rotor inertias J·i_r² on the diagonal.

        Returns:
            The joint-space inertia matrix.

        Example:
            >>> import numpy as np, manipcad
            >>> from manipcad.codegen import generate
            >>> gen = generate(manipcad.load_robot("cylindrical"))
            >>> gen.mass_matrix(np.zeros(3)).shape
            (3, 3)
        """
        H = self._x.mass_matrix(q, drives)
        if H is not None:
            return H
        m = self._m
        if m is None:
            return mass_matrix(self.robot, q, drives=drives, use_generated=False)
        if _vectors(q):
            H = np.empty((self.n, self.n))
            try:
                self.kernel("mass_matrix")(q, drives, H)
                return H
            except (TypeError, ValueError):
                pass
        (Q,), single = as_states(self.n, q=q)
        H = np.empty((Q.shape[0], self.n, self.n))
        self.kernel("mass_matrix_batch")(Q, bool(drives), H)
        return H[0] if single else H

    def moment_components(self, q, qd, qdd=None):
        """H_ii, h_i and Q_i (paper 4.1) as :func:`manipcad.moment_components`.

        Args:
            q, qd: joint positions (rad or m) and velocities (rad/s or m/s), (n,) or (N, n).
            qdd: accepted for symmetry with the other calls and unused: the three
                constituents do not depend on the accelerations.

        Returns:
            :class:`MomentComponents` (H_ii kg·m² or kg, velocity and gravity N·m or
            N), each shaped like q; the fields of
            :class:`manipcad.analysis.realtime.MomentComponents`.

        Example:
            >>> import numpy as np, manipcad
            >>> from manipcad.codegen import generate
            >>> gen = generate(manipcad.load_robot("cylindrical"))
            >>> mc = gen.moment_components(np.array([0.0, 0.2, 0.5]), np.array([1.0, 0, 0]))
            >>> round(float(mc.velocity[2]), 3)  # centrifugal force on the reach, N
            -0.391
        """
        m = self._m
        if m is None:
            tc = torque_components(self.robot, q, qd, np.zeros_like(np.asarray(q, float)))
            return MomentComponents(tc.H_ii, tc.velocity, tc.gravity)
        (Q, QD), single = as_states(self.n, q=q, qd=qd)
        out = [np.empty(Q.shape) for _ in range(3)]
        self.kernel("moment_components_batch")(Q, QD, *out)
        return MomentComponents(*(o[0] for o in out)) if single else MomentComponents(*out)

    def forward_dynamics(self, q, qd, tau, drives: bool = True) -> np.ndarray:
        """Joint accelerations (rad/s² or m/s²) under torques tau (N·m or N).

        The generated mass matrix and bias (inverse dynamics at q̈ = 0) with an
        unrolled L·D·Lᵀ factorization (the square-root-free Cholesky); the same as
        :func:`manipcad.forward_dynamics`.

        Args:
            q, qd, tau: (n,) or (N, n).
            drives: include the drive terms (rotor inertia, viscous and dry friction).

        Returns:
            q̈, shaped like q.

        Raises:
            ManipcadError: the mass matrix is not positive definite at some state.

        Example:
            >>> import numpy as np, manipcad
            >>> from manipcad.codegen import generate
            >>> gen = generate(manipcad.load_robot("cylindrical"))
            >>> q = np.array([0.3, 0.2, 0.1]); tau = gen.inverse_dynamics(q, q, q)
            >>> bool(np.allclose(gen.forward_dynamics(q, q, tau), q))  # q̈ = q here
            True
        """
        qdd = self._x.forward_dynamics(q, qd, tau, drives)
        if qdd is not None:
            if type(qdd) is int:
                raise ManipcadError("the mass matrix is not positive definite at "
                                    f"joint {qdd}: a joint moves no mass")
            return qdd
        m = self._m
        if m is None:
            return forward_dynamics(self.robot, q, qd, tau, drives=drives, method="crba",
                                    use_generated=False)
        if _vectors(q, qd, tau):
            qdd = np.empty(self.n)
            try:
                bad = self.kernel("forward_dynamics")(q, qd, tau, drives, qdd)
            except (TypeError, ValueError):
                pass
            else:
                if bad >= 0:
                    raise ManipcadError("the mass matrix is not positive definite at "
                                        f"joint {bad}: a joint moves no mass")
                return qdd
        (Q, QD, T), single = as_states(self.n, q=q, qd=qd, tau=tau)
        qdd = np.empty(Q.shape)
        bad = self.kernel("forward_dynamics_batch")(Q, QD, T, bool(drives), qdd)
        if bad >= 0:
            raise ManipcadError(f"the mass matrix is not positive definite at state {bad}: "
                                "a joint moves no mass (add inertia or a drive)")
        return qdd[0] if single else qdd

    # ---- C
    def c_code(self, prefix: str | None = None) -> tuple[str, str]:
        """(header, source) of the portable C99 code, functions named ``<prefix>_...``.

        Args:
            prefix: C identifier prefix; default the robot's name as a C identifier.

        Returns:
            The texts of ``<prefix>.h`` and ``<prefix>.c``.

        Raises:
            ManipcadError: the prefix is not a C identifier, or the robot was not
                customized (the fallback has no C code).
        """
        if not self.generated or self.path is None:
            raise ManipcadError(f"no C code for {self.name!r}: {self.reason}")
        p = c_identifier(self.name) if prefix is None else prefix
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", p):
            raise ManipcadError(f"--prefix must be a C identifier, got {p!r}")
        hdr = (self.path / "kernels.h.in").read_text().replace(
            "@PREFIX_UPPER@", p.upper()).replace(_PREFIX_TOKEN, p)
        src = (self.path / "kernels.c.in").read_text().replace(_PREFIX_TOKEN, p)
        return hdr, src

    def python_source(self) -> str:
        """The text of the generated numba module."""
        if self.path is None:
            raise ManipcadError(f"no generated module for {self.name!r}: {self.reason}")
        return (self.path / "kernels.py").read_text()


# ------------------------------------------------------------------ generate
def _load_module(path: Path, digest: str):
    mod = _loaded.get(digest)
    if mod is not None:
        return mod
    name = f"manipcad_generated_{digest[:16]}"
    spec = importlib.util.spec_from_file_location(name, path / "kernels.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    if getattr(mod, "ROBOT_HASH", None) != digest:
        raise ManipcadError(f"{path}: the generated module's hash does not match the robot")
    _loaded[digest] = mod
    return mod


def build(robot: Robot) -> tuple[str, str, str, dict]:
    """Generate the sources of one robot, writing no file.

    Args:
        robot: the manipulator.

    Returns:
        (numba module source, C header template, C source template, ops): the C
        texts hold ``@PREFIX@`` for the function prefix; ops as :attr:`GeneratedDynamics.ops`.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen.generate import build
        >>> py, h, c, ops = build(manipcad.load_robot("cylindrical"))
        >>> "def inverse_dynamics(" in py and "@PREFIX@_inverse_dynamics(" in h
        True
    """
    digest = robot_hash(robot)
    d = dynamics(robot)
    stmts = {"inverse_dynamics": _id_stmts(d), "mass_matrix": _mass_stmts(d),
             "moment_components": _components_stmts(d), "forward_dynamics": _fd_stmts(d)}
    py = _python_source(d, stmts, robot.name, digest)
    hdr, src = _c_sources(d, stmts, robot.name, digest)
    ops = {f: emit.count_ops(py, f) for f in FUNCTIONS}
    return py, hdr, src, ops


def generate(robot: Robot, *, cache_dir: str | Path | None = None, attach: bool = True,
             max_joints: int = MAX_JOINTS) -> GeneratedDynamics:
    """Customized dynamics kernels of one robot, generated once and cached by content hash.

    Args:
        robot: the manipulator (numbers fixed: DH, URDF or YAML, drives included).
        cache_dir: folder of generated modules; default :func:`cache_root`.
        attach: let :func:`manipcad.inverse_dynamics`, :func:`manipcad.mass_matrix`
            and :func:`manipcad.forward_dynamics` use these kernels for this robot
            object (``use_generated=True``, their default).
        max_joints: robots with more joints fall back to the general kernels
            (with a :class:`ManipcadWarning` saying so).

    Returns:
        :class:`GeneratedDynamics` with ``inverse_dynamics``, ``mass_matrix``,
        ``moment_components``, ``forward_dynamics``, ``ops`` and ``c_code``.

    Example:
        >>> import numpy as np, manipcad
        >>> from manipcad.codegen import generate
        >>> gen = generate(manipcad.load_robot("puma560"))
        >>> gen.ops["inverse_dynamics"]["mul"] <= 210
        True
    """
    if not isinstance(robot, Robot):
        raise ManipcadError(f"generate needs a Robot, got {type(robot).__name__}")
    digest = robot_hash(robot)
    if robot.n > max_joints:
        reason = (f"{robot.name!r} has {robot.n} joints; the generator customizes robots of at "
                  f"most {max_joints} joints (symbolic work and compile time grow with n²): "
                  "using the general kernels")
        warnings.warn(reason, ManipcadWarning, stacklevel=2)
        return GeneratedDynamics(robot, digest, None, {}, None, 0.0, reason)
    root = Path(cache_dir) if cache_dir is not None else cache_root()
    path = root / f"{c_identifier(robot.name)[:40]}-{digest[:24]}"
    seconds = 0.0
    meta_file = path / "meta.json"
    meta = None
    if meta_file.is_file():
        try:
            meta = json.loads(meta_file.read_text())
        except (OSError, ValueError):
            meta = None
        if not meta or meta.get("hash") != digest:
            shutil.rmtree(path, ignore_errors=True)
            meta = None
    if meta is None:
        t0 = time.perf_counter()
        py, hdr, src, ops = build(robot)
        seconds = time.perf_counter() - t0
        meta = {"hash": digest, "robot": robot.name, "n": robot.n, "ops": ops,
                "seconds": seconds}
        tmp = root / f".tmp-{os.getpid()}-{digest[:24]}"
        try:
            tmp.mkdir(parents=True, exist_ok=True)
            (tmp / "kernels.py").write_text(py)
            (tmp / "kernels.h.in").write_text(hdr)
            (tmp / "kernels.c.in").write_text(src)
            (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
            try:
                tmp.rename(path)
            except OSError:  # another process finished first: use its copy
                shutil.rmtree(tmp, ignore_errors=True)
        except OSError as exc:
            raise ManipcadError(f"cannot write the generated code under {root}: {exc}") from None
    module = _load_module(path, digest)
    gen = GeneratedDynamics(robot, digest, module, meta["ops"], path, seconds)
    if attach:
        attach_kernels(robot, gen)
    return gen


# ------------------------------------------------------------------ for compiled loops
def find(robot: Robot, *, cache_dir: str | Path | None = None) -> GeneratedDynamics | None:
    """The robot's generated kernels if they exist (attached, or in the cache); never generates.

    Args:
        robot: the manipulator.
        cache_dir: folder of generated modules; default :func:`cache_root`.

    Returns:
        :class:`GeneratedDynamics` (attached to the robot), or None when
        :func:`generate` has not run for this robot's content.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen import find, generate
        >>> arm = manipcad.load_robot("cylindrical")
        >>> _ = generate(arm)
        >>> find(arm) is not None
        True
    """
    gen = attached(robot)
    if gen is not None:
        return gen
    if robot.n > MAX_JOINTS:
        return None
    digest = robot_hash(robot)
    root = Path(cache_dir) if cache_dir is not None else cache_root()
    path = root / f"{c_identifier(robot.name)[:40]}-{digest[:24]}"
    try:
        meta = json.loads((path / "meta.json").read_text())
    except (OSError, ValueError):
        return None
    if meta.get("hash") != digest:
        return None
    return generate(robot, cache_dir=root)


_DUMMIES: dict = {}


def _dummy(name: str):
    """A C-ABI kernel of ``name``'s signature that does nothing and returns -2."""
    f = _DUMMIES.get(name)
    if f is None:
        nargs = len(CFUNC_SIGNATURES[name].args)
        args = ", ".join(f"a{i}" for i in range(nargs))
        ns: dict = {}
        exec(f"def f({args}):\n    return -2\n", ns)  # one source per arity
        f = nb.cfunc(CFUNC_SIGNATURES[name], nogil=True)(ns["f"])
        _DUMMIES[name] = f
    return f


def simulation_kernels(robot: Robot, table: np.ndarray, *, use_generated: bool = True):
    """C-ABI kernels a compiled simulator can call for ``robot`` with body table ``table``.

    The generated kernels serve when they exist for the robot (see :func:`find`)
    and ``table`` is the robot's own table (drive terms included) or that table
    with the joint-referred drive columns zeroed (the rigid body); any other
    table (e.g. elastic gears on some joints only) gets the general kernels.

    Args:
        robot: the manipulator.
        table: the (n, TABLE_COLS) body table the simulator integrates.
        use_generated: False: always the general kernels.

    Returns:
        ``(use, forward_dynamics, mass_matrix, moment_components)``: ``use`` is
        True when the three C-ABI kernels (:meth:`GeneratedDynamics.cfunc`) are
        the robot's generated ones — forward dynamics with or without the drive
        terms as ``table`` says, mass matrix and moment components of the links;
        otherwise placeholders of the same types (returning -2) and ``use`` False.

    Example:
        >>> import manipcad
        >>> from manipcad.codegen import generate, simulation_kernels
        >>> arm = manipcad.load_robot("cylindrical")
        >>> _ = generate(arm)
        >>> simulation_kernels(arm, arm.table)[0]
        True
    """

    gen = find(robot) if use_generated else None
    drives = None
    if gen is not None:
        cols = [COL_JR, COL_BV, COL_FCP, COL_FCN]
        own = robot.table
        rest = np.ones(own.shape[1], bool)
        rest[cols] = False
        if np.array_equal(table, own):
            drives = True
        elif np.array_equal(table[:, rest], own[:, rest]) and not np.any(table[:, cols]):
            drives = False
    if drives is None:
        return False, _dummy("forward_dynamics"), _dummy("mass_matrix"), \
            _dummy("moment_components")
    return (True, gen.cfunc("forward_dynamics", drives), gen.cfunc("mass_matrix", False),
            gen.cfunc("moment_components"))
