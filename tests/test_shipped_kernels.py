"""The kernels shipped in the package (manipcad._shipped_kernels): built from these sources,
unpacked into a new cache folder under another copy's paths, and then nothing compiles."""

from __future__ import annotations

import io
import json
import os
import pickle
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest
from numba import types
from numba.core import config
from numba.core.serialize import dumps
from test_warmup import COVERAGE

import manipcad
from manipcad import _numba_cache
from manipcad import _shipped_kernels as sk

ROOT = Path(manipcad.__file__).parent
REPO = ROOT.parent.parent


def _fresh_env(home: Path, **extra: str) -> dict[str, str]:
    """This environment for a child on an empty ``home``: no kernel cache set and no
    opt-out inherited (numba's, the XDG cache and MANIPCAD_SHIPPED_KERNELS variables
    dropped), then ``extra``."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("NUMBA_", "XDG_", "MANIPCAD_SHIPPED"))}
    return {**env, "HOME": str(home), **extra}


def _shipped_files() -> int:
    """The number of files the bundle unpacks (its members but the manifest)."""
    with tarfile.open(sk.BUNDLE, "r:xz") as tar:
        return len([m for m in tar.getmembers() if m.name != "manifest.json"])

def test_shipped_kernels_are_built_from_these_sources():
    have = sk.read_manifest(sk.BUNDLE)
    assert have, f"{sk.BUNDLE} is missing or unreadable"
    assert have["cpu"] == sk.CPU
    assert have["sources"] == sk.sources_digest(ROOT), (
        "a kernel source changed since the shipped kernels were built: the first run of "
        "every user would compile again. Rebuild them: python tools/ship_kernels.py")


def test_the_kernel_sources_include_the_constants_kernels_read():
    """numba freezes a kernel's globals into its code: the signal layout's module holds
    no kernel (it does not import numba) yet is a kernel source; a command's module that
    only names numba in its text is not."""
    sources = sk.kernel_sources(ROOT)
    assert {"sim/loop.py", "control/signals.py", "dynamics/gear.py"} <= set(sources)
    assert "numba" not in (ROOT / "control/signals.py").read_text()
    assert "cli/warmup.py" not in sources and "_shipped_kernels.py" not in sources


def test_a_new_cache_folder_starts_with_them_and_nothing_compiles(tmp_path):
    """A copy of the package at another path (numba names its cache folders after the
    sources' absolute path) and an empty home: the first import unpacks the kernels; the
    warm-up steps and then a simulation with each kind of integrator (test_warmup's
    COVERAGE script) compile nothing: no compile event, no file added to the folder."""
    why = sk.mismatch(sk.BUNDLE, sk.sources_digest(ROOT))
    if why and "kernel sources" not in why:
        pytest.skip(f"not for this machine: {why}")  # another numba, Python or CPU family
    site = tmp_path / "site"
    shutil.copytree(ROOT, site / "manipcad", ignore=shutil.ignore_patterns("__pycache__"))
    env = _fresh_env(tmp_path / "home", PYTHONPATH=str(site))
    res = subprocess.run([sys.executable, "-c", COVERAGE, "rk4", "adaptive"], env=env,
                         capture_output=True, text=True, timeout=600, cwd=REPO)
    assert res.returncode == 0, res.stderr[-3000:]
    assert json.loads(res.stdout.strip().splitlines()[-1]) == {"compiled": [], "new": []}
    folder, = (tmp_path / "home/.cache/manipcad").glob("numba-*")
    assert json.loads((folder / sk.ORIGIN).read_text())["cpu"] == sk.CPU
    shipped = _shipped_files()
    made = [p for p in folder.rglob("*") if p.is_file() and p.suffix != ".lock"]
    assert len(made) == shipped + 1                      # the kernels and ORIGIN: no more


def _bundle(tmp_path, manifest: dict, members: dict[str, bytes]) -> Path:
    out = tmp_path / "k.tar.xz"
    with tarfile.open(out, "w:xz") as tar:
        for name, data in {"manifest.json": json.dumps(manifest).encode(), **members}.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return out


def test_install_refuses_what_does_not_fit_and_leaves_no_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(sk, "NEEDS", frozenset())        # any CPU: the test is the bundle's
    digest = sk.sources_digest(ROOT)
    here = tmp_path / "cache" / "numba-x"
    here.parent.mkdir()
    fits = sk.manifest(digest)
    old = _bundle(tmp_path, {**fits, "sources": "0" * 16}, {"top/warm-rk4": b""})
    assert sk.install(here, ROOT, digest, old) == (
        f"shipped kernels are for kernel sources {'0' * 16}, here {digest}")
    other = _bundle(tmp_path, {**fits, "numba": "0.1"}, {})
    assert "for numba 0.1" in sk.install(here, ROOT, digest, other)
    bad = _bundle(tmp_path, fits, {"pkg/nowhere/x.nbi": b""})
    assert "damaged" in sk.install(here, ROOT, digest, bad)
    escape = _bundle(tmp_path, fits, {"top/../../evil": b"x"})
    assert "leaves the cache folder" in sk.install(here, ROOT, digest, escape)
    assert "missing" in sk.install(here, ROOT, digest, tmp_path / "none.tar.xz")
    assert list(here.parent.iterdir()) == []             # nothing half-written
    assert not (tmp_path / "evil").exists()


def test_an_index_keeps_its_entries_keyed_to_this_cpu():
    """The neutral form of an index and back: the same signatures and data files, keyed to
    the given CPU; an index of code for another CPU is refused at packing."""
    sig = (types.float64[::1], types.int64)
    code = ("a" * 64, "b" * 64)
    shipped = ("x86_64-unknown-linux-gnu", sk.CPU, "")
    index = pickle.dumps("0.68.1") + dumps((b"stamp", {(sig, shipped, code): "f.1.nbc"}))
    host = ("x86_64-unknown-linux-gnu", "somecpu", "+sse2")
    back = io.BytesIO(sk._index(sk._neutral(index), host))
    version = pickle.load(back)
    stamp, overloads = pickle.loads(back.read())
    assert (version, stamp, overloads) == ("0.68.1", b"stamp", {(sig, host, code): "f.1.nbc"})
    native = pickle.dumps("0.68.1") + dumps((b"s", {(sig, host, code): "f.1.nbc"}))
    with pytest.raises(RuntimeError, match=f"not the {sk.CPU} CPU"):
        sk._neutral(native)


def test_a_cpu_without_the_instruction_sets_compiles_instead(monkeypatch, tmp_path):
    digest = sk.sources_digest(ROOT)
    here = _bundle(tmp_path, sk.manifest(digest), {})    # fits this numba, Python, triple
    monkeypatch.setattr(sk, "NEEDS", frozenset({"no-such-extension"}))
    assert sk.mismatch(here, digest) == (
        f"shipped kernels are for {sk.CPU}; this CPU lacks no-such-extension")


def test_a_failing_install_never_stops_the_import(monkeypatch, tmp_path):
    """configure() on a new folder whose install raises: the cache folder is still set up,
    the kernels then compile there, and STATUS says why."""
    def broken(*args, **kwargs):
        raise RuntimeError("no luck")

    monkeypatch.setattr(sk, "install", broken)
    monkeypatch.setattr(sk, "STATUS", "")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.delenv("MANIPCAD_SHIPPED_KERNELS", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    try:
        _numba_cache.configure()
        assert sk.STATUS == "shipped kernels not installed: RuntimeError: no luck"
        folder = Path(os.environ["NUMBA_CACHE_DIR"])
        assert folder.parent == tmp_path / "manipcad" and folder.is_dir()
        assert sk.why_not(folder) == sk.STATUS          # what `compiling kernels` says
    finally:
        monkeypatch.undo()
        config.reload_config()


def test_the_first_compile_says_why_the_shipped_kernels_did_not_fit(tmp_path):
    """With MANIPCAD_SHIPPED_KERNELS=0 on an empty home, the first command that needs
    kernels says why it compiles (in a fresh process: the cache is set up at import)."""
    env = _fresh_env(tmp_path, MANIPCAD_SHIPPED_KERNELS="0", MANIPCAD_COMPILE_WORKERS="1")
    code = ("from manipcad.cli.warmup import start_warm, finish_warm\n"
            "from manipcad.sim import warm\n"
            "warm.STEPS = {'x': ('x', lambda: None)}; warm.PHASES = (('x',),)\n"
            "finish_warm(start_warm('x'))\n")
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "(shipped kernels not used: MANIPCAD_SHIPPED_KERNELS=0)" in res.stderr


def test_two_processes_starting_at_once_share_one_complete_folder(tmp_path):
    """Two imports at the same moment on an empty home (the test suite's workers do this in
    CI): one unpacks, the other finds the folder whole or unpacks its own copy and loses
    the rename; either way the folder holds every shipped file once, nothing temporary."""
    why = sk.mismatch(sk.BUNDLE, sk.sources_digest(ROOT))
    if why:
        pytest.skip(f"not for this machine: {why}")  # another numba, Python or CPU family
    env = _fresh_env(tmp_path)
    code = (f"import os, time\nwhile not os.path.exists({str(tmp_path / 'go')!r}): "
            f"time.sleep(0.001)\nimport manipcad._shipped_kernels as s\nprint(s.STATUS)")
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE,
                              text=True) for _ in range(2)]
    (tmp_path / "go").touch()
    said = [p.communicate(timeout=300)[0].strip() for p in procs]
    assert [p.returncode for p in procs] == [0, 0]
    assert "shipped kernels installed" in said, said      # one put its folder in place
    assert set(said) <= {"", "shipped kernels installed",  # the other found it, or lost
                         "shipped kernels installed by another process"}, said
    folder, = (tmp_path / ".cache/manipcad").glob("numba-*")
    shipped = _shipped_files()
    files = [p for p in folder.rglob("*") if p.is_file()]
    assert len(files) == shipped + 1                     # and ORIGIN
    assert not list((tmp_path / ".cache/manipcad").glob(".*tmp*"))


def test_a_cpu_whose_features_cannot_be_read_compiles_instead(monkeypatch, tmp_path):
    def unknown():
        raise RuntimeError("failed to get host cpu features")

    digest = sk.sources_digest(ROOT)
    here = _bundle(tmp_path, sk.manifest(digest), {})
    monkeypatch.setattr(sk.ll, "get_host_cpu_features", unknown)
    assert sk.mismatch(here, digest) == (
        "shipped kernels not used: this CPU's features are unknown "
        "(failed to get host cpu features)")
