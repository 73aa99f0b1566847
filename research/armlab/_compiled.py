"""The one home of how a CasADi graph of armlab (one :class:`casadi.Function` per joint
count ``n``) is put in use: run by CasADi's virtual machine at once, compiled with the C
compiler in a background thread once per machine, cached on disk, loaded by later processes.

Two graphs use it: the S-curve engine of one problem
(:mod:`armlab.trajectory.profiles.graph`) and the 2-waypoint closed-form plan
(:mod:`armlab.planning.closed_graph`). Each is a :class:`Graph` made from a :class:`Spec`
(its name, its builder, the source files its key hashes, its compiler flags, its input and
output sizes); this module holds what they share:

* the mode, ``$ARMLAB_SCURVE_GRAPH`` (read at import and by :func:`reset`; it governs both
  graphs): ``auto`` (the cached library, else the VM while the library is compiled in a
  background thread, then the library), ``vm`` (the VM only), ``off`` (no graph: the numpy
  evaluation of the same formulas);
* the activation (:meth:`Graph.prepare`): the first problem of ``n`` joints of a process makes
  the graph ready in the call, so a result never depends on a thread's timing (the VM and the
  library give the same values: ``-ffp-contract=off``, tested per graph);
* the cache key (:meth:`Graph.library_path`: the sources, the casadi version, the compiler, the
  flags, the platform, ``n``, and the CPU where the flags tune for it), the atomic write of the
  library (:func:`armlab._cache.build_library`), the status (:meth:`Graph.status`);
* the bound buffers (:meth:`Graph.bound`: numpy arrays bound to a
  :meth:`casadi.Function.buffer`, one set per thread: Dask's threads may call at once) and the
  fork handling (a forked child gets a new lock and forgets the compiles under way).
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
import threading
import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab import _cache
from armlab._lazy import lazy_import

if TYPE_CHECKING:
    import casadi as ca
else:
    ca = lazy_import("casadi")

__all__ = ["Graph", "Spec", "available", "cpu_key", "reset"]

_MODES = ("auto", "vm", "off")
_LOCK = threading.Lock()
_GRAPHS: weakref.WeakSet = weakref.WeakSet()
_mode = "auto"
_generation = 0  # bumped by reset(): a background thread of an earlier one changes nothing


@dataclass(frozen=True)
class Spec:
    """What makes one graph family (one :class:`casadi.Function` per ``n``).

    Attributes
    ----------
    name : str
        Cache subfolder and file prefix (``<root>/<name>/<name>-graph-<n>-<key>.so``).
    build : callable
        ``build(n)``: the :class:`casadi.Function` of ``n`` joints, named ``symbol(n)``.
    symbol : callable
        ``symbol(n)``: the Function's name, the symbol its library exports.
    sources : tuple of Path
        The files whose text the graph is generated from (hashed into the cache key).
    cflags : tuple of str
        The compiler flags (without the sources and ``-o``).
    inputs : callable
        ``inputs(n)``: the shape of each input's bound numpy array (C order; CasADi reads it
        column-major, so a ``(4, n)`` array is an ``n x 4`` input).
    output : callable
        ``output(n)``: the size of the (one, flat) output.
    patch : callable or None
        ``patch(c_code)``: the generated C changed before it is compiled (e.g. inlined
        helpers), or None.
    what : str
        What is compiled, for error messages.
    """

    name: str
    build: Callable[[int], Any]
    symbol: Callable[[int], str]
    sources: tuple[Path, ...]
    cflags: tuple[str, ...]
    inputs: Callable[[int], tuple[tuple[int, ...], ...]]
    output: Callable[[int], int]
    patch: Callable[[str], str] | None = None
    what: str = "a graph"


def reset() -> None:
    """Forget every graph's functions in use and read ``$ARMLAB_SCURVE_GRAPH`` again (tests)."""
    global _mode, _generation
    value = os.environ.get("ARMLAB_SCURVE_GRAPH", "auto").strip().lower() or "auto"
    with _LOCK:
        _mode = value if value in _MODES else "auto"
        _generation += 1
        for g in list(_GRAPHS):
            g._clear()
    for g in list(_GRAPHS):
        g._local.__dict__.clear()


def available() -> bool:
    """Whether problems are evaluated by the graphs (``$ARMLAB_SCURVE_GRAPH`` is not ``off``)."""
    return _mode != "off"


@functools.cache
def cpu_key() -> str:
    """The processor the library is tuned for where the flags say ``-march=native``: the model
    name and a hash of the feature flags of ``/proc/cpuinfo`` (empty where it is not there:
    then the platform's machine name)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        import platform

        return platform.machine()
    model = flags = ""
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip()
        if key == "model name" and not model:
            model = value.strip()
        elif key in ("flags", "Features") and not flags:
            flags = value.strip()
    return model + " " + hashlib.sha256(flags.encode()).hexdigest()[:16]


class Graph:
    """One graph family (:class:`Spec`) put in use per ``n`` (module docstring)."""

    def __init__(self, spec: Spec) -> None:
        self.spec = spec
        self._active: dict[int, Any] = {}  # n -> the Function in use (VM or compiled)
        self._status: dict[int, str] = {}
        self._compiling: set[int] = set()
        self._vm: dict[int, Any] = {}  # n -> the graph, built once per process
        self._local = threading.local()  # per thread: n -> (function, trigger, ins, out, buf)
        with _LOCK:
            _GRAPHS.add(self)

    def _clear(self) -> None:
        self._active.clear()
        self._status.clear()
        self._compiling.clear()

    def status(self, n: int) -> str:
        """How problems of ``n`` joints are evaluated: ``"compiled"``, ``"vm"`` (with the
        reason where the compile failed, or ``"vm, compiling"``), or ``"unused"``."""
        return self._status.get(n, "unused")

    def prepare(self, n: int) -> str:
        """Make the graph of ``n`` joints ready now (the cached library, else the VM with the
        compile started in the background); its :meth:`status`."""
        if _mode != "off":
            self._activate(n)
        return self.status(n)

    def build(self, n: int):
        """The graph of ``n`` joints run by CasADi's VM, built once per process."""
        f = self._vm.get(n)
        if f is None:  # built outside the lock; two threads at once build twice
            f = self.spec.build(n)
            with _LOCK:
                f = self._vm.setdefault(n, f)
        return f

    @functools.cached_property
    def _source_hash(self) -> str:
        h = hashlib.sha256()
        for path in self.spec.sources:
            h.update(Path(path).read_bytes())
        return h.hexdigest()

    def library_path(self, n: int, cc: str, root: Path | None = None) -> Path:
        """Where the compiled graph of ``n`` joints built by ``cc`` lives in the cache
        (``root``: :func:`armlab._cache.cache_dir`)."""
        flags = " ".join(self.spec.cflags)
        parts = [self._source_hash, ca.__version__, cc, flags, sys.platform, str(n)]  # type: ignore[attr-defined]
        if "-march=native" in flags:
            parts.append(cpu_key())
        h = hashlib.sha256()
        for part in parts:
            h.update(part.encode())
            h.update(b"\0")
        root = _cache.cache_dir() if root is None else root
        name = self.spec.name
        return root / name / f"{name}-graph-{n}-{h.hexdigest()[:20]}.so"

    def compile_library(self, n: int, environ: Mapping[str, str] | None = None) -> Path:
        """The compiled graph of ``n`` joints, built now unless the cache holds it; the path
        of the library. ``environ``: the environment whose compiler and cache folder are used
        (default the process').

        Raises
        ------
        armlab._cache.CompilerUnavailable
            No C compiler, or the compile failed.
        """
        cc = _cache.compiler(environ)
        so = self.library_path(n, cc, _cache.cache_dir(environ))
        if so.exists():
            return so
        f = self.build(n)
        name = f.name()
        patch = self.spec.patch

        def sources(folder: Path) -> list[str]:
            cg = ca.CodeGenerator(name + ".c", {"with_header": False})
            cg.add(f)
            code = cg.dump()
            src = folder / (name + ".c")
            src.write_text(code if patch is None else patch(code))
            return [*self.spec.cflags, str(src), "-lm"]

        _cache.build_library(so, cc, sources, self.spec.what)
        return so

    def load_compiled(self, n: int, so: Path):
        """The compiled graph of ``n`` joints from its library ``so``."""
        return ca.external(self.spec.symbol(n), str(so))

    def _activate(self, n: int) -> None:
        """Put the function of ``n`` joints in use: the cached library, else the VM and
        (``auto``) the compile in a new thread, with the compiler and the cache folder of the
        environment now (a snapshot: a test may change the process' meanwhile)."""
        if n in self._active:
            return
        generation, environ = _generation, dict(os.environ)
        f, compiled = None, False
        if _mode == "auto":
            try:
                so = self.library_path(n, _cache.compiler(environ), _cache.cache_dir(environ))
                if so.exists():
                    f, compiled = self.load_compiled(n, so), True
            except Exception:  # noqa: BLE001 - no compiler, a damaged file: the VM below
                pass
        if f is None:
            f = self.build(n)
        with _LOCK:
            if generation != _generation or n in self._active:
                return
            compile_now = _mode == "auto" and not compiled and n not in self._compiling
            if compile_now:
                self._compiling.add(n)
            self._active[n] = f
            self._status[n] = "compiled" if compiled else "vm, compiling" if compile_now else "vm"
        if compile_now:
            args = (n, generation, environ)
            threading.Thread(target=self._compile, args=args, daemon=True).start()

    def _compile(self, n: int, generation: int, environ: dict) -> None:
        """Compile the graph of ``n`` joints and put it in use; on failure say why."""
        try:
            f = self.load_compiled(n, self.compile_library(n, environ))
        except Exception as exc:  # noqa: BLE001 - the VM stays in use, the reason is kept
            with _LOCK:
                if generation == _generation:
                    self._status[n] = f"vm ({exc})"
            return
        with _LOCK:
            if generation == _generation:
                self._active[n], self._status[n] = f, "compiled"

    def bound(self, n: int) -> tuple | None:
        """``(trigger, inputs, output)`` of this thread for ``n`` joints: the numpy arrays
        bound to the function in use (made ready first if it is not); the caller writes the
        inputs, calls ``trigger()`` and copies the output. None where a :func:`reset` came
        between (tests): the caller evaluates with numpy this once."""
        f = self._active.get(n)
        if f is None:
            self._activate(n)
            f = self._active.get(n)
            if f is None:
                return None
        slots: dict[Any, tuple] = self._local.__dict__  # this thread's, by n
        slot = slots.get(n)
        if slot is None or slot[0] is not f:
            slot = slots[n] = self._bind(f, n)
        return slot[1]

    def _bind(self, f, n: int) -> tuple:
        """A buffer of ``f`` with numpy arrays bound to its inputs and output (kept alive with
        it, so no freed array stays bound)."""
        buf, trigger = f.buffer()
        ins = tuple(np.zeros(shape) for shape in self.spec.inputs(n))
        out = np.zeros(self.spec.output(n))
        for i, x in enumerate(ins):
            buf.set_arg(i, x.data)
        buf.set_res(0, out.data)
        return f, (trigger, ins, out), buf

    def _after_fork(self) -> None:
        for n in self._compiling:
            if self._status.get(n) == "vm, compiling":
                self._status[n] = "vm"
        self._compiling.clear()


def _after_fork() -> None:
    """In a forked child: a new lock (the parent's may have been held by a thread that does
    not exist here), and the compiles under way forgotten (their threads are gone)."""
    global _LOCK
    _LOCK = threading.Lock()
    for g in list(_GRAPHS):
        g._after_fork()


os.register_at_fork(after_in_child=_after_fork)
reset()
