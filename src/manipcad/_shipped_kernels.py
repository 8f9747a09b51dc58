"""The numba kernels shipped with the package: built once for a baseline CPU, unpacked into
an empty kernel cache so a first run compiles nothing.

numba compiles every kernel on first use and keeps the machine code in its on-disk cache
(:mod:`manipcad._numba_cache`); on an empty cache the simulator's cores alone take tens of
seconds. :func:`build` compiles what ``manipcad warmup`` compiles (every integrator's core,
the dynamics, drives and regulators) for :data:`CPU`, x86-64-v3 (AVX2, FMA, BMI2: Intel
since Haswell, 2013, AMD since Excavator, 2015), and packs the cache folder into
:data:`BUNDLE` with a manifest: numba's version, Python's, the target triple, the CPU and
the digest of the kernel sources it was built from.

When :func:`manipcad._numba_cache.configure` creates a new cache folder it calls
:func:`install`: if the manifest matches this numba, this Python, this triple and these
sources, and this CPU has the instruction sets of :data:`CPU`, the files are unpacked under
this copy's paths (numba names a cache folder after the absolute path of the source folder)
and each entry is keyed to this CPU, since numba looks entries up by the CPU it would
compile for. numba does not fuse or reorder floating-point operations without fastmath, so
the results are bit for bit those of kernels compiled here (``benchmarks/rk4_job.py``
digests); the speed is within a few per cent (docs/performance.md). Anything else (another
numba or Python, an older or ARM CPU, changed sources) compiles as before; :data:`STATUS`
says which.

Rebuild after changing a kernel (tests/test_shipped_kernels.py fails until then)::

    python tools/ship_kernels.py

Example:
    >>> from manipcad._shipped_kernels import read_manifest, BUNDLE
    >>> sorted(read_manifest(BUNDLE))
    ['cpu', 'numba', 'python', 'sources', 'triple']
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import llvmlite.binding as ll
import numba
from numba.core.caching import _CacheLocator
from numba.core.registry import cpu_target
from numba.core.serialize import dumps

#: the shipped kernels: a tar.xz of a kernel cache folder, with ``manifest.json``
BUNDLE = Path(__file__).with_name("kernels.tar.xz")
#: the CPU the shipped kernels are compiled for (numba's ``NUMBA_CPU_NAME``, LLVM's name)
CPU = "x86-64-v3"
#: the instruction sets :data:`CPU` implies (LLVM's feature names), which this CPU must have
NEEDS = frozenset({"cx16", "sahf", "popcnt", "sse3", "sse4.1", "sse4.2", "ssse3",  # v2
                   "avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave"})
#: what became of the shipped kernels in this process ("" until a new cache folder is made)
STATUS = ""

#: the file in a kernel cache folder that says it started with the shipped kernels (their
#: manifest)
ORIGIN = "shipped.json"
#: the file in a kernel cache folder that says why it did not (one line)
NOT_SHIPPED = "not-shipped.txt"

_TOP, _OWN, _PKG = "top/", "cache/", "pkg/"


#: modules that import numba but hold no kernel: the cache's own set-up
_NO_KERNELS = frozenset({"_numba_cache.py", "_shipped_kernels.py"})
_USES_NUMBA = re.compile(rb"^[ \t]*(?:import|from)[ \t]+numba\b", re.M)
_IMPORTS = re.compile(rb"^[ \t]*(?:from[ \t]+(manipcad[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#]*)"
                      rb"|import[ \t]+(manipcad[\w.]*))", re.M)


def kernel_sources(root: Path) -> list[str]:
    """The modules (package-relative paths) of the package at ``root`` whose text goes into
    numba's machine code: those that import numba, and the package's modules they import
    (numba freezes the globals a kernel reads, e.g. the signal layout of
    :mod:`manipcad.control.signals`, into the code, and its cache checks only the kernel's
    own file)."""
    files = set()
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        rel = os.path.relpath(folder, root).replace(os.sep, "/")
        files.update(n if rel == "." else f"{rel}/{n}" for n in names if n.endswith(".py"))
    found = set()
    for rel in files:
        with open(os.path.join(root, rel), "rb") as f:
            text = f.read()
        if b"numba" not in text or not _USES_NUMBA.search(text) or rel in _NO_KERNELS:
            continue
        found.add(rel)
        for frm, names, imp in _IMPORTS.findall(text):
            mod = (frm or imp).decode().split(".")[1:]
            subs = [n.split()[0] for n in names.decode().strip("()").replace("\n", ",")
                    .split(",") if n.strip()]
            for parts in [mod, *([*mod, n] for n in subs)]:
                for cand in ("/".join([*parts, "__init__.py"]), "/".join(parts) + ".py"):
                    if cand in files:
                        found.add(cand)
    return sorted(found)


def sources_digest(root: Path) -> str:
    """The digest (16 hex digits) of the kernel sources (:func:`kernel_sources`) of the
    package at ``root``: their package-relative paths and contents."""
    digest = hashlib.sha1()
    for rel in kernel_sources(root):
        digest.update(rel.encode())
        with open(os.path.join(root, rel), "rb") as f:
            digest.update(f.read())
    return digest.hexdigest()[:16]


def _subpath(py_file: Path) -> str:
    """numba's cache sub-folder for the functions of ``py_file`` (named after its folder's
    absolute path)."""
    return _CacheLocator.get_suitable_cache_subpath(str(py_file))


def _package_dirs(root: Path) -> dict[str, str]:
    """numba's cache sub-folder name -> the package-relative folder ("." for the root) for
    every folder of the package at ``root``."""
    dirs = [root, *(p for p in root.rglob("*") if p.is_dir() and p.name != "__pycache__")]
    return {_subpath(d / "_.py"): d.relative_to(root).as_posix() for d in dirs}


def manifest(digest: str) -> dict[str, str]:
    """What shipped kernels must match to be used here: numba's and Python's versions, the
    target triple, the CPU they are compiled for and the kernel sources' digest
    (:func:`sources_digest`)."""
    return {"numba": numba.__version__, "python": "{}.{}".format(*sys.version_info[:2]),
            "triple": ll.get_process_triple(), "cpu": CPU, "sources": digest}


def read_manifest(bundle: Path) -> dict[str, str]:
    """The manifest of a bundle, its first member (:func:`pack` writes it first, so it
    is read without decompressing the rest); {} when there is no bundle or it is
    unreadable."""
    try:
        with tarfile.open(bundle, "r:xz") as tar:
            first = tar.next()
            if first is None or first.name != "manifest.json":
                return {}
            return json.loads(tar.extractfile(first).read())
    except (OSError, tarfile.TarError, ValueError):
        return {}


def mismatch(bundle: Path, digest: str) -> str:
    """Why the bundle cannot be used here ("" when it can)."""
    return _unfit(bundle, read_manifest(bundle), digest)


def _unfit(bundle: Path, have: dict[str, str], digest: str) -> str:
    """Why a bundle with the manifest ``have`` cannot be used here ("" when it can)."""
    if not have:
        return f"no shipped kernels ({bundle.name} missing or unreadable)"
    want = manifest(digest)
    for key in ("sources", "numba", "python", "triple", "cpu"):
        if have.get(key) != want[key]:
            what = "kernel sources" if key == "sources" else key
            return f"shipped kernels are for {what} {have.get(key)}, here {want[key]}"
    try:
        host = ll.get_host_cpu_features()
    except RuntimeError as exc:  # llvmlite cannot read them on some hosts
        return f"shipped kernels not used: this CPU's features are unknown ({exc})"
    lacks = sorted(f for f in NEEDS if not host.get(f, False))
    if lacks:
        return f"shipped kernels are for {CPU}; this CPU lacks {', '.join(lacks)}"
    return ""


def _host_magic() -> tuple:
    """numba's (triple, CPU name, CPU features) key of code compiled in this process."""
    return cpu_target.target_context.codegen().magic_tuple()


class _Loads:
    """Pickles as ``pickle.loads(data)``: an object carried as its own pickle, rebuilt only
    when numba reads the index (the signature's types may import manipcad's modules, which
    must not happen while the package is still setting up its cache)."""

    def __init__(self, data: bytes):
        self.data = data

    def __reduce__(self):
        return pickle.loads, (self.data,)


class _Plain(pickle.Unpickler):
    """Unpickles built-in values only (a shipped index in its neutral form)."""

    def find_class(self, module, name):
        raise pickle.UnpicklingError(f"{module}.{name} in a shipped kernel index")


def _neutral(index: bytes) -> bytes:
    """A numba cache index (``*.nbi``) of code for :data:`CPU` in a neutral form: built-in
    values only, each entry's signature kept as its own pickle. Raises RuntimeError on an
    entry compiled for another CPU."""
    f = io.BytesIO(index)
    version = pickle.load(f)
    stamp, overloads = pickle.loads(f.read())
    entries = []
    for (sig, magic, code), name in overloads.items():
        if magic[1:] != (CPU, ""):
            raise RuntimeError(f"an entry compiled for {magic}, not the {CPU} CPU")
        entries.append((dumps(sig), magic[0], code, name))
    return pickle.dumps((version, stamp, entries), protocol=4)


def _index(neutral: bytes, host: tuple) -> bytes:
    """numba's cache index from its neutral form (:func:`_neutral`), keyed to the CPU
    ``host`` (numba's magic tuple: triple, CPU name, features); entries for another target
    triple are dropped."""
    version, stamp, entries = _Plain(io.BytesIO(neutral)).load()
    overloads = {(_Loads(sig), host, code): name
                 for sig, triple, code, name in entries if triple == host[0]}
    out = io.BytesIO()
    pickle.dump(version, out, protocol=-1)
    out.write(dumps((stamp, overloads)))
    return out.getvalue()


def _place(name: str, folder: Path, own: str, dirs: dict[str, str]) -> Path:
    """Where the bundle's member ``name`` goes in the cache folder ``folder``: the inverse
    of :func:`pack`'s names (``top/`` the folder itself, ``cache/`` numba's sub-folder for
    the folder's own modules ``own``, ``pkg/<folder of the package>/`` the sub-folder
    ``dirs`` names for it here). Raises ValueError on any other name."""
    if ".." in Path(name).parts or Path(name).is_absolute():
        raise ValueError(f"member {name!r} leaves the cache folder")
    area, rest = name[:name.find("/") + 1], name[name.find("/") + 1:]
    if area == _TOP:
        return folder / rest
    if area == _OWN:
        return folder / own / rest
    rel, _, file = rest.rpartition("/")
    if area == _PKG and rel in dirs:
        return folder / dirs[rel] / file
    raise ValueError(f"unexpected member {name!r}")


def install(here: Path, root: Path, digest: str, bundle: Path = BUNDLE) -> str:
    """Unpack the shipped kernels into the new, not yet existing cache folder ``here`` for
    the package at ``root`` whose kernel sources have ``digest``.

    Unpacks into a temporary folder beside ``here`` and renames it into place, so a
    process starting at the same time sees either nothing or the whole cache. Returns
    what happened, for :data:`STATUS`: "shipped kernels installed" or why not.
    """
    have = read_manifest(bundle)
    why = _unfit(bundle, have, digest)
    if why:
        return why
    host = _host_magic()
    own = _subpath(here / "_.py")
    dirs = {rel: name for name, rel in _package_dirs(root).items()}
    tmp = here.with_name(f".{here.name}.{os.getpid()}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)  # left by a process of the same number
    try:
        tmp.mkdir()
        with tarfile.open(bundle, "r:xz") as tar:
            for member in tar.getmembers():
                if not member.isfile() or member.name == "manifest.json":
                    continue
                dest = _place(member.name, tmp, own, dirs)
                data = tar.extractfile(member).read()
                if dest.suffix == ".nbi":
                    data = _index(data, host)
                dest.parent.mkdir(parents=True, exist_ok=True)
                dest.write_bytes(data)
        (tmp / ORIGIN).write_text(json.dumps(have, indent=1))
        os.rename(tmp, here)
    except OSError:
        shutil.rmtree(tmp, ignore_errors=True)
        if here.is_dir():  # another process put its copy in place first
            return "shipped kernels installed by another process"
        return "shipped kernels not installed: the cache folder is not writable"
    except (tarfile.TarError, ValueError, pickle.UnpicklingError, EOFError) as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        return f"shipped kernels not installed: {bundle.name} is damaged ({exc})"
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return "shipped kernels installed"


def start(here: Path, root: Path, digest: str) -> str:
    """Make the new kernel cache folder ``here``: with the shipped kernels where they fit
    (:func:`install`), else empty with :data:`NOT_SHIPPED` saying why (also when
    ``MANIPCAD_SHIPPED_KERNELS=0``). Never raises for a failed install: the kernels then
    compile as before. Sets and returns :data:`STATUS`."""
    global STATUS
    if os.environ.get("MANIPCAD_SHIPPED_KERNELS", "1") == "0":
        STATUS = "shipped kernels not used: MANIPCAD_SHIPPED_KERNELS=0"
    else:
        try:
            STATUS = install(here, root, digest)
        except Exception as exc:  # noqa: BLE001 - a head start must never stop the import
            STATUS = f"shipped kernels not installed: {type(exc).__name__}: {exc}"
    if not STATUS.startswith("shipped kernels installed"):
        here.mkdir(exist_ok=True)
        (here / NOT_SHIPPED).write_text(STATUS + "\n")
    return STATUS


def why_not(folder: Path | None) -> str:
    """Why the kernel cache ``folder`` did not start with the shipped kernels ("" when it
    did, or when it is not known)."""
    try:
        return (folder / NOT_SHIPPED).read_text().strip() if folder is not None else ""
    except OSError:
        return ""


def pack(cache: Path, root: Path, out: Path, info: dict[str, str],
         skip: frozenset[str] = frozenset()) -> None:
    """Write the kernel cache folder ``cache`` of the package at ``root`` to ``out`` (a
    tar.xz) with the manifest ``info``, its paths made relative to the package; sub-folders
    named in ``skip`` are left out. Raises RuntimeError on a file it could not place again."""
    dirs = _package_dirs(root)
    own = _subpath(cache / "_.py")
    tmp = out.with_name(out.name + ".tmp")
    with tarfile.open(tmp, "w:xz", preset=9) as tar:
        blob = json.dumps(info, indent=1).encode()
        entry = tarfile.TarInfo("manifest.json")
        entry.size = len(blob)
        tar.addfile(entry, io.BytesIO(blob))
        for path in sorted(cache.rglob("*")):
            rel = path.relative_to(cache)
            if path.is_dir() or path.suffix == ".lock" or rel.parts[0] in skip:
                continue
            if len(rel.parts) == 1:
                arc = _TOP + rel.name
            elif len(rel.parts) == 2 and rel.parts[0] == own:
                arc = _OWN + rel.name
            elif len(rel.parts) == 2 and rel.parts[0] in dirs:
                arc = f"{_PKG}{dirs[rel.parts[0]]}/{rel.name}"
            else:
                raise RuntimeError(f"cannot place {rel} of the kernel cache")
            data = path.read_bytes()
            if path.suffix == ".nbi":
                data = _neutral(data)
            entry = tarfile.TarInfo(arc)
            entry.size = len(data)
            tar.addfile(entry, io.BytesIO(data))
    os.replace(tmp, out)


def build(out: Path = BUNDLE) -> dict[str, str]:
    """Compile every kernel ``manipcad warmup`` compiles for :data:`CPU`, in a fresh
    process on an empty cache folder, and pack that folder into ``out``; the manifest.

    Raises RuntimeError naming the step when the warm-up fails or the folder holds
    something this module cannot place again.
    """
    root = Path(__file__).parent
    info = manifest(sources_digest(root))
    if not info["triple"].startswith("x86_64"):
        raise RuntimeError(f"{CPU} kernels are built on an x86-64 machine, not {info['triple']}")
    with tempfile.TemporaryDirectory() as work:
        cache = Path(work) / "numba"
        # the robots' generated code (manipcad.codegen) goes to the temporary folder too:
        # it is made per robot on the user's machine, so its kernels are not shipped
        # features "": those the CPU's name implies, not this machine's
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "NUMBA_CPU_NAME": CPU,
               "NUMBA_CPU_FEATURES": "", "XDG_CACHE_HOME": work,
               "PYTHONPATH": str(root.parent)}
        done = subprocess.run([sys.executable, "-m", "manipcad", "warmup"], env=env,
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"manipcad warmup failed:\n{done.stdout}{done.stderr}")
        generated = frozenset(_subpath(d / "_.py")
                              for d in Path(work).glob("manipcad/codegen/*"))
        pack(cache, root, out, info, generated)
    return info
