"""Compiled functions cached by content: ``njit`` as Numba's, with ``cache=True`` keyed by what the code is.

Numba's own disk cache lives next to the source file and is valid while the *file* keeps its modification time
and size: every exported build of the engine (a new folder, new times) compiles every function again, and a
function is not recompiled when a function it calls, in another file, changes. Here the key of a compiled
function is a hash of

- its own syntax tree, without docstring, comments or line numbers (`ast.dump` of the definition),
- its compile options (``parallel``, ``error_model``, ``inline`` ...),
- the values of the module-level constants it reads (Numba freezes them into the machine code),
- and, recursively, the keys of the compiled functions and intrinsics it calls,

plus the versions of Python, Numba and NumPy. The machine code goes to ``<cache_dir>/jit`` (``$DEM_CACHE_DIR``,
else ``~/.cache/dem-engine``) in files named by the function's name and key (not its module: a function
generated alike into the kernel modules of two scenes is one file), shared by every build: a commit that changes a docstring, a comment, a function
no kernel calls or a module without compiled code compiles nothing; one that changes a contact law compiles
the functions that call it, and only those. `content_key` is also the dependency part of the key of the
generated step kernels (`engine.kernels.build_kernel`).

The key is computed at a function's first call (every module is imported by then), not at decoration.

Runs started together (``harness run -j N``) often need the same new function: a compilation holds a file lock
named by the function's key (``<cache_dir>/jit/<key>.lock``, the `filelock` package), so a second process waits
for the first and loads its machine code instead of compiling it too. Locks are taken caller before callee,
along the call graph, so two processes never wait for each other; the operating system drops a dead process'
lock.
"""
from __future__ import annotations

import ast
import hashlib
import inspect
import os
import pickle
import sys
import textwrap
import types
from pathlib import Path

import numba
import numpy as np
from filelock import FileLock, Timeout
from numba.core import sigutils
from numba.core import types as nbtypes
from numba.core.caching import CompileResultCacheImpl, FunctionCache, IndexDataCacheFile, _Cache, _CacheLocator
from numba.core.dispatcher import Dispatcher
from numba.core.extending import _Intrinsic
from numba.core.runtime import rtsys
from numba.np.ufunc.parallel import _launch_threads

from . import cache_limit
from .cache_limit import cache_dir

#: what every key includes: machine code depends on the compiler and on NumPy's implementations
TOOLCHAIN = f"python {sys.version_info[:3]} numba {numba.__version__} numpy {np.__version__}"


def _strip_docstring(node):
    body = getattr(node, "body", None)
    if (isinstance(body, list) and body and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str)):
        node.body = body[1:] or [ast.Pass()]
    return node


def _code_text(code) -> str:
    """A stable text of a code object (bytecode, names, constants; no positions), for functions whose source
    cannot be read."""
    consts = [_code_text(c) if isinstance(c, types.CodeType) else repr(c) for c in code.co_consts]
    return f"{code.co_code.hex()} {code.co_names} {code.co_varnames} {consts}"


def _tree(fn) -> str:
    """The function's definition as a syntax tree dump: no docstring, comments, decorators or positions."""
    try:
        source = textwrap.dedent(inspect.getsource(fn))
    except (OSError, TypeError):
        return _code_text(fn.__code__)
    node = ast.parse(source).body[0]
    for inner in ast.walk(node):
        _strip_docstring(inner)
    if hasattr(node, "decorator_list"):
        node.decorator_list = []
    return ast.dump(node, annotate_fields=False)


def _names(code) -> set:
    """Global and attribute names a code object (and the code objects nested in it) reads."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names(const)
    return names


def _constant(value):
    """A stable text for a module-level value Numba would freeze into the code; None for what it cannot."""
    if isinstance(value, (bool, int, float, complex, str, bytes, type(None))):
        return repr(value)
    if isinstance(value, (tuple, list)):
        parts = [_constant(v) for v in value]
        return None if None in parts else f"{type(value).__name__}({', '.join(parts)})"
    if isinstance(value, dict):
        parts = [(_constant(k), _constant(v)) for k, v in value.items()]
        return None if any(None in p for p in parts) else repr(sorted(parts))
    if isinstance(value, np.ndarray):
        return f"array({value.dtype}, {value.shape}, {hashlib.sha256(value.tobytes()).hexdigest()})"
    if isinstance(value, np.generic):
        return f"{type(value).__name__}({value!r})"
    return None


_keys: dict = {}
_ACTIVE = "<being hashed>"


def content_key(obj) -> str:
    """The content key of a compiled function (Dispatcher), an intrinsic or a plain Python function (module
    docstring). Cycles (mutual recursion) hash the function's name in place of its key."""
    fn = obj.py_func if isinstance(obj, Dispatcher) else obj._defn if isinstance(obj, _Intrinsic) else obj
    known = _keys.get(fn)
    if known is _ACTIVE:
        return f"{fn.__module__}.{fn.__qualname__}"
    if known is not None:
        return known
    _keys[fn] = _ACTIVE
    try:
        parts = [TOOLCHAIN, _tree(fn)]
        if isinstance(obj, Dispatcher):
            parts.append(repr(sorted((k, repr(v)) for k, v in obj.targetoptions.items())))
        if fn.__closure__:
            parts += [_dependency(cell.cell_contents) or "?" for cell in fn.__closure__]
        namespace = fn.__globals__
        for name in sorted(_names(fn.__code__)):
            if name in namespace:
                parts.append(f"{name}={_dependency(namespace[name], _names(fn.__code__))}")
        key = hashlib.sha256("\n".join(parts).encode()).hexdigest()
    except BaseException:
        del _keys[fn]
        raise
    _keys[fn] = key
    return key


def _dependency(value, attributes=()) -> str | None:
    """What a global read by a compiled function contributes to its key."""
    if isinstance(value, (Dispatcher, _Intrinsic)):
        return content_key(value)
    if isinstance(value, types.ModuleType):
        # a module of this package used as `mesh.closest_point`: the compiled functions it reads from it
        if value.__name__.split(".")[0] != __name__.split(".")[0]:
            return value.__name__
        return ";".join(f"{a}:{_dependency(getattr(value, a))}" for a in sorted(attributes) if hasattr(value, a))
    if isinstance(value, type) and issubclass(value, tuple) and hasattr(value, "_fields"):
        return f"namedtuple {value.__module__}.{value.__qualname__}{value._fields}"
    if isinstance(value, (types.FunctionType, types.BuiltinFunctionType, type)):
        return f"{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', value)}"
    return _constant(value)


def _record_fields(ty, out: list):
    """The field names of every namedtuple type in ty (a type or a tuple of types), depth first."""
    if isinstance(ty, tuple):
        for t in ty:
            _record_fields(t, out)
    elif isinstance(ty, nbtypes.BaseNamedTuple):
        cls = ty.instance_class
        # a class may say how its fields lie in memory beyond their names (engine/state.py ParticleState)
        out.append(f"{cls.__module__}.{cls.__qualname__}{tuple(cls._fields)}{getattr(cls, 'layout_key', '')}")
        _record_fields(tuple(ty.types), out)
    elif isinstance(ty, nbtypes.BaseTuple):
        _record_fields(tuple(ty.types), out)


class _ContentLocator(_CacheLocator):
    """Machine code in <cache_dir>/jit, valid while the content key is (not the file's time)."""

    def __init__(self, key: str):
        self._key = key
        self._path = str(cache_dir() / "jit")

    def ensure_cache_path(self):
        os.makedirs(self._path, exist_ok=True)

    def get_cache_path(self):
        return self._path

    def get_source_stamp(self):
        return self._key

    def get_disambiguator(self):
        return self._key[:24]

    #: set just before a `_ContentCache` is made (the locator protocol passes only the function)
    pending: dict = {}

    @classmethod
    def from_function(cls, py_func, py_file):
        key = cls.pending.get(py_func)
        return None if key is None else cls(key)


class _ContentImpl(CompileResultCacheImpl):
    _locator_classes = [_ContentLocator]

    def get_filename_base(self, fullname, abiflags):
        # the function's name and key, not its module's: a function generated alike into the kernel modules of
        # two scenes (the same pair pass, other walls) is one file, compiled once
        qualname = fullname.split(".", 1)[1].replace("<", "").replace(">", "")
        return f"{qualname}-{self.locator.get_disambiguator()}"


#: what reading a cache file of another engine build may raise: its pickled signatures name the classes of the
#: arguments (namedtuples such as engine.mesh.MeshList) by module and name, and a build that no longer has such a
#: class, or has it elsewhere, cannot read them
_UNREADABLE = (ImportError, AttributeError, FileNotFoundError, EOFError, pickle.UnpicklingError)


class _TolerantIndex(IndexDataCacheFile):
    """A function's cache index that another build wrote with signatures this build cannot read: empty (its
    entries are compiled again and the index written anew), not an error that stops the run."""

    def _load_index(self):
        try:
            return super()._load_index()
        except _UNREADABLE:
            return {}


class _ContentCache(FunctionCache):
    """Numba's function cache with the content key as file name, stamp and index key."""

    _impl_class = _ContentImpl

    def __init__(self, py_func, key: str):
        self._key = key
        _ContentLocator.pending[py_func] = key
        try:
            super().__init__(py_func)
        finally:
            del _ContentLocator.pending[py_func]
        self._cache_file = _TolerantIndex(cache_path=self._cache_path, filename_base=self._impl.filename_base,
                                          source_stamp=self._impl.locator.get_source_stamp())

    def load_overload(self, sig, target_context):
        # Numba's refreshes the target context first, which imports every module of implementations (numpy's
        # functions, scipy's BLAS check: about a second at each engine start) that only compiling needs; loading
        # machine code needs the runtime (NRT) alone, and a compilation refreshes the context itself
        rtsys.initialize(target_context)
        # the threading layer before any machine code is linked in. Numba starts it for code whose cache entry says
        # it runs parallel loops (`_reload_parfors`), and an entry says so only where Numba compiled such a loop
        # itself: a function compiled while its parallel callees came from this cache (shared by every build, so
        # at every commit that changes the caller alone) does not, and loaded first in a process its loops call
        # into a layer nobody started - a segmentation fault (tests/engine/test_jit.py). Idempotent; the engine
        # starts the layer anyway for its first parallel loop.
        _launch_threads()
        with self._guard_against_spurious_io_errors():
            try:
                loaded = self._load_overload(sig, target_context)
            except _UNREADABLE:
                # the code was compiled in a generated module that no longer exists (engine/kernels.py), a prune
                # removed it meanwhile (engine/cache_limit.py), or it names a class this build does not have: compile
                return None
            if loaded is not None:  # used now: the last to go when the cache is pruned
                cache_limit.touch(self._cache_file._index_path)
            return loaded
        return None  # an I/O error the guard swallowed

    def save_overload(self, sig, data):
        super().save_overload(sig, data)
        cache_limit.note_write()

    def _index_key(self, sig, codegen):
        # a namedtuple argument is typed by its class and field types, not names: fields renamed or reordered
        # keep the signature, so their names go into the key
        fields = []
        _record_fields(sig.args if hasattr(sig, "args") else sig, fields)
        return sig, codegen.magic_tuple(), self._key, tuple(fields)


class _LazyContentCache(_Cache):
    """Stands in for the cache until the first compilation asks for it, then keys it by content."""

    def __init__(self, dispatcher):
        self._dispatcher = dispatcher
        self._cache = None
        self._enabled = True

    def _real(self):
        if self._cache is None:
            self._cache = _ContentCache(self._dispatcher.py_func, content_key(self._dispatcher))
            if not self._enabled:
                self._cache.disable()
        return self._cache

    @property
    def cache_path(self):
        return self._real().cache_path

    def load_overload(self, sig, target_context):
        return self._real().load_overload(sig, target_context) if self._enabled else None

    def save_overload(self, sig, data):
        if self._enabled:
            self._real().save_overload(sig, data)

    def enable(self):
        self._enabled = True
        if self._cache is not None:
            self._cache.enable()

    def disable(self):
        self._enabled = False
        if self._cache is not None:
            self._cache.disable()

    def flush(self):
        self._real().flush()


#: seconds a compilation waits for another process compiling the same function before it compiles on its own (a
#: process stopped in a debugger, say, must not hold every other run forever)
LOCK_WAIT = 600.0
#: one lock object per key and process: they are re-entrant (a recursive function compiles inside its own
#: compilation), two objects on one file are not
_locks: dict = {}


def _compile_locked(dispatcher):
    """dispatcher.compile under the file lock of its content key (module docstring): a signature it has
    already compiled or loaded in this process takes no lock."""
    compile_unlocked = dispatcher.compile

    def compile(sig):
        args, _ = sigutils.normalize_signature(sig)
        if tuple(args) in dispatcher.overloads:
            return compile_unlocked(sig)
        key = content_key(dispatcher)
        lock = _locks.get(key)
        if lock is None:
            folder = cache_dir() / "jit"
            folder.mkdir(parents=True, exist_ok=True)
            lock = _locks[key] = FileLock(str(folder / f"{key}.lock"), timeout=LOCK_WAIT)
        try:
            lock.acquire()
        except Timeout:
            return compile_unlocked(sig)
        try:
            # compiles, or loads what the process that held the lock saved
            return compile_unlocked(sig)
        finally:
            lock.release()

    dispatcher.compile = compile


def njit(*args, **options):
    """numba.njit; ``cache=True`` caches by content in <cache_dir>/jit, compiling under a lock per key (module
    docstring)."""
    cache = options.pop("cache", False)

    def decorate(fn):
        dispatcher = numba.njit(**options)(fn)
        if cache:
            dispatcher._cache = _LazyContentCache(dispatcher)
            _compile_locked(dispatcher)
        return dispatcher

    if args and callable(args[0]):
        return decorate(args[0])
    return decorate
