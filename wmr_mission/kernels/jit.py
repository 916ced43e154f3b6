"""Kernels: plain Python, compiled by numba only where compiled code needs them.

Every per-sample function is written once, in the subset of Python numba
compiles, and declared with :func:`kernel` (or :func:`inlined`). Declaring
loads nothing: a kernel called from Python runs as plain Python, so a module
of kernels can be imported by whoever needs its other contents (a mission's
settings, for validation) without paying for numba.

Numba is loaded by the first :func:`compiled` call, which returns the
compiled form of an entry point that Python calls (the loop, the math of
paths, a campaign's pixel counts). Once loaded, numba is told through its
public extension API (``typeof_impl``) that a kernel named in compiled code is
its own compiled dispatcher, made then; a kernel shows the options it is
compiled with (``targetoptions``), so an inlined one is compiled into each
caller as numba inlines an ``njit(inline="always")`` function. The compiled
loop is the same machine code as if every kernel had been an ``njit``
function all along.

When numba is missing, ``WMR_MISSION_NO_JIT=1`` is set, or the run chose plain
Python (:func:`choose_plain_python`: a short mission's run,
wmr_mission.commands.compile), :func:`compiled` returns the plain
form instead: slower, the same equations, the same bytes. Compiled entry
points are cached on disk where a directory can be written
(wmr_mission.kernels.cache); a compile, which a miss in that cache starts,
is said on stderr as it starts, once (:func:`compiling_notice`).
"""

from __future__ import annotations

import contextlib
import copy
import importlib.util
import os
import platform
import sys
import threading
import time
import types
from collections.abc import Callable, Iterator, Mapping
from typing import Any, TypeVar, cast

from wmr_mission.version import installed_version

F = TypeVar("F", bound=Callable[..., Any])

NO_JIT = "WMR_MISSION_NO_JIT"

# With Intel's short vector math library installed (icc_rt), numba would
# vectorise loops of math functions with it: results chosen by the CPU's SIMD
# level (wmr_mission.kernels.scalar_math). Read by numba as it loads.
os.environ["NUMBA_DISABLE_INTEL_SVML"] = "1"

# Options of every compiled kernel. error_model="numpy": a division by zero
# gives inf or nan, as in plain Python, never a Python exception out of the
# compiled loop; the runner reports a non-finite input or state as a divergence.
_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}


class Kernel:
    """A per-sample function. Called from Python it runs as plain Python; named
    in compiled code it is compiled (once numba is loaded, see the module)."""

    def __init__(self, function: Callable[..., Any], inline: bool) -> None:
        self.py_func = function
        self.inline = inline
        # What numba reads of a function it may inline, as of its dispatchers.
        self.targetoptions = {**_OPTIONS, **({"inline": "always"} if inline else {})}
        self.__name__ = function.__name__
        self.__qualname__ = function.__qualname__
        self.__module__ = function.__module__
        self.__doc__ = function.__doc__
        self._dispatcher: Any = None

    def __call__(self, *args: Any) -> Any:
        return self.py_func(*args)

    def __repr__(self) -> str:
        return f"<kernel {self.__module__}.{self.__qualname__}>"

    def dispatcher(self) -> Any:
        """numba's dispatcher of this kernel (numba loaded)."""
        with _lock:
            if self._dispatcher is None:
                self._dispatcher = _njit()(cache=_state.cached, **self.targetoptions)(self.py_func)
        return self._dispatcher


class _State:
    plain_chosen = False  # choose_plain_python() was called
    numba: Any = None  # the numba module, once loaded
    ready = False  # numba loaded and taught the kernels
    set_up = False  # numba's target set up for compiling (_set_up_for_compiling)
    cached = False  # compiled code is kept on disk
    cache_class: Any = None  # numba's cache of a function, loaded as is (_cache_class)
    kernels: list[Kernel] = []  # noqa: RUF012 - every declared kernel
    entries: dict[tuple[int, bool, bool], Any] = {}  # noqa: RUF012 - compiled entry points
    judged = 0  # samples judged in this process (judged())
    save_lock: str | None = None  # the file each save to the cache locks (save_one_at_a_time)
    said: Any = None  # which compiles compiling_notice said, shared with forked processes
    say: Callable[[str], None] | None = None  # how compiles are said (compiles_said_by)


_state = _State()
# Loading numba and compiling entry points happen once, whichever thread asks first.
_lock = threading.RLock()
_set_up_lock = threading.Lock()


def _declare(function: Callable[..., Any], inline: bool) -> Kernel:
    declared = Kernel(function, inline)
    with _lock:
        _state.kernels.append(declared)
    return declared


def kernel(fn: F) -> F:
    """Declare ``fn`` a kernel (see the module)."""
    return cast(F, _declare(fn, inline=False))


def inlined(fn: F) -> F:
    """:func:`kernel`, compiled into each compiled function that calls it
    (numba's ``inline="always"``) instead of called there: for the kernels the
    loop runs once per sample with whole records (a phase, the controller, the
    estimator), which cost more to pass, tens of machine words each, than much
    of their work (docs/performance.md)."""
    return cast(F, _declare(fn, inline=True))


def choose_plain_python() -> None:
    """Run this process's kernels as plain Python, without loading numba (a
    first run while the compiled loop is not cached yet)."""
    _state.plain_chosen = True


@contextlib.contextmanager
def plain_python_meanwhile() -> Iterator[None]:
    """Run this process's kernels and entry points as plain Python inside,
    numba loaded or not, and compiled again after: a run's record made
    without compiling its loop, for what compiles from a record (the judge's
    passes, beside the loop's compile in `wmr-mission compile`)."""
    chosen = _state.plain_chosen
    _state.plain_chosen = True
    try:
        yield
    finally:
        _state.plain_chosen = chosen


def compiling() -> bool:
    """Whether :func:`compiled` compiles here: numba is installed, not turned
    off by ``WMR_MISSION_NO_JIT=1``, and plain Python was not chosen."""
    if _state.plain_chosen or os.environ.get(NO_JIT, "") not in ("", "0"):
        return False
    return _state.numba is not None or importlib.util.find_spec("numba") is not None


def loaded() -> bool:
    """Whether this process loaded numba for its kernels (and runs them
    compiled: not inside :func:`plain_python_meanwhile`)."""
    return _state.ready and not _state.plain_chosen


# The judge's compiled passes (wmr_mission.verdicts) cost a process about
# 0.03-0.05 s of CPU to load from the cache, a run's judging by numpy of a
# few thousand samples a few ms: they pay once the process has judged this
# many samples, a long run or a campaign's worker after its first rows
# (docs/performance.md, Start-up).
JUDGED_COMPILED_FROM = 100_000


def judged(samples: int) -> None:
    """Count ``samples`` as judged in this process (:func:`judging_compiled`)."""
    _state.judged += samples


def judging_compiled() -> bool:
    """Whether the judge's passes run compiled: numba loaded for the kernels,
    and JUDGED_COMPILED_FROM samples judged in this process, the record being
    judged included. Their numpy forms give the same bits."""
    return loaded() and _state.judged >= JUDGED_COMPILED_FROM


def distances_compiled() -> bool:
    """Whether the judge's distance to the path (wmr_mission.verdicts.path_distance)
    runs compiled: wherever numba is loaded for the kernels, however few the
    samples judged. Its numpy form costs about 10 us a sample (0.05 s of case
    study 1's judging), its pass a few ms to load: it makes no array and needs
    no reference counting (docs/performance.md, Start-up). The same bits."""
    return loaded()


def entries() -> list[str]:
    """The names of the compiled functions this process called or compiled,
    each loaded from the cache or compiled once."""
    dispatchers = [*_state.entries.values(), *(k._dispatcher for k in (*_state.kernels, ticks))]
    return sorted({d.py_func.__name__ for d in dispatchers if d is not None and d.signatures})


def _njit() -> Any:
    assert _state.numba is not None
    return _state.numba.njit


def load() -> bool:
    """Load numba (once) and teach it the kernels; False when not compiling."""
    if _state.ready:
        return not _state.plain_chosen
    with _lock:
        return _load()


def _load() -> bool:
    if _state.numba is not None:
        return True
    if not compiling():
        return False
    from wmr_mission.kernels import cache

    directory = cache.cache_directory()
    if directory is not None:  # before numba loads: it reads its cache directory then
        cache.point_numba_at(directory)
    with _without_scipy(), _extensions_later():
        try:
            import numba
        except ImportError:  # pragma: no cover - a numba that cannot load (another numpy)
            _state.plain_chosen = True
            return False
    from numba.extending import typeof_impl

    _state.cached = directory is not None
    _state.cache_class = _cache_class()
    if _state.said is None:  # before any worker forks from this process: shared with them
        _state.said = _said_memory()
    if directory is not None and os.name == "posix" and _numba_as_read():
        # Whatever compiles in this process (a `run` beside another, a sweep's
        # worker meeting a variant its warm-up did not compile, `wmr-mission
        # compile`'s processes) saves in turns with every other process.
        save_one_at_a_time(str(directory / SAVE_LOCK))

    @typeof_impl.register(Kernel)
    def _typeof_kernel(value: Kernel, context: Any) -> Any:
        return numba.types.Dispatcher(value.dispatcher())

    _state.numba = numba
    _teach_ticks()
    _state.ready = True
    return True


def _set_up_for_compiling() -> None:
    """numba's target set up (once, scipy refused): its typing and lowering
    registries, some 40 modules of numba imported and their thousands of
    implementations registered. Compiling needs them; loading a function from
    the cache does not (:func:`_cache_class`), so a run whose loop is cached
    never pays for them (0.12 s of CPU, docs/performance.md, Start-up)."""
    if _state.set_up:
        return
    with _set_up_lock:  # not _lock: a cache miss holds numba's compile lock
        if not _state.set_up:
            from numba.core.registry import cpu_target

            with _without_scipy():
                cpu_target.target_context.refresh()
            _inlined_copies_share_their_scope()
            _state.set_up = True


def _inlined_copies_share_their_scope() -> None:
    """numba's inliner (``InlineWorker.inline_ir``) copies the callee's IR
    block by block, each with a memo of its own: each block's variables name
    the callee's scope, so each block copies the whole scope again, blocks
    times variables. Inlined into the loop, the paper's controller (263
    blocks, 4 272 variables once its own kernels are inlined) took 10 s of
    the 44 s of CPU that case study 2's first run compiled for. Here the
    blocks of one IR are copied with one memo: the scope once, the copies of
    the blocks sharing it as the blocks did (docs/performance.md, "Compiling
    the loop"). For :data:`LOADED_AS_IS_FOR` only, whose inliner this reads."""
    from numba.core import inline_closurecall, ir

    if not _numba_as_read():
        return
    namespace = vars(inline_closurecall)
    if namespace.get("copy") is copy:  # its only use: copy.deepcopy(block)
        namespace["copy"] = _ScopeSharingCopy(ir.Block)


class _ScopeSharingCopy:
    """The ``copy`` module as numba's inliner sees it: a block copied with
    no memo of its own is copied with the memo of the other blocks of its IR
    in the same copy, held until a block of another IR, or one copied
    already (a new copy of the same IR), is copied: after the last compile
    it keeps the last IR inlined (0.5 MB once case study 2's loop compiled)."""

    def __init__(self, block_type: Any) -> None:
        self._block_type = block_type
        self._scope: Any = None
        self._memo: dict[int, Any] = {}

    def deepcopy(self, value: Any, memo: dict[int, Any] | None = None) -> Any:
        if memo is not None or not isinstance(value, self._block_type):
            return copy.deepcopy(value, memo)
        # The memo holds what it copied (copy.deepcopy keeps it alive): an id
        # in it is that block's, copied in this copy of the IR.
        if value.scope is not self._scope or id(value) in self._memo:
            self._scope, self._memo = value.scope, {}
        return copy.deepcopy(value, self._memo)

    def __getattr__(self, name: str) -> Any:
        return getattr(copy, name)


def make_runtime() -> None:
    """numba's reference-counting runtime made now (where numba is loaded),
    not as the first cached function naming it loads. The judge's passes that
    return arrays name it, and making it runs LLVM: a long run makes it before
    it gives the compiler's pages back (wmr_mission.kernels.resident), or the
    judge reads 37 MB of them back (docs/performance.md, Long missions)."""
    if not _state.ready:
        return
    from numba.core.registry import cpu_target
    from numba.core.runtime import nrt

    nrt.rtsys.initialize(cpu_target.target_context)


# The numba (major.minor) whose FunctionCache.load_overload _cache_class restates,
# whose inliner's copies _inlined_copies_share_their_scope reads, and whose
# cache's saves save_one_at_a_time wraps.
LOADED_AS_IS_FOR = "0.68"


def _numba_as_read() -> bool:
    """Whether the numba loaded is :data:`LOADED_AS_IS_FOR`, whose internals
    this module restates."""
    import numba

    return _as_read(numba.__version__)


def _as_read(version: str) -> bool:
    """Whether numba's ``version`` is :data:`LOADED_AS_IS_FOR` (major.minor)."""
    return version.split(".")[:2] == LOADED_AS_IS_FOR.split(".")


def saves_can_take_turns() -> bool:
    """Whether :func:`save_one_at_a_time` can make this process's saves to
    numba's cache take turns with another's: numba is the one it wraps
    (:data:`LOADED_AS_IS_FOR`, whose save it restates) and the system has
    flock. Loads numba."""
    return importlib.util.find_spec("fcntl") is not None and load() and _numba_as_read()


# Beside the kernels, the file each save to the cache locks while it saves
# (save_one_at_a_time).
SAVE_LOCK = "save.lock"


def save_one_at_a_time(lock: str) -> None:
    """Make each save to numba's on-disk cache from this process hold ``lock``
    (a file, locked with flock) throughout (:func:`saves_can_take_turns`);
    made as numba loads with a cache (:func:`_load`).

    numba saves an entry as: read the function's index, add the entry, write
    the index, write the entry's file, with no lock. The loop's variants are
    entries of one function (wmr_mission.kernels.loop.run_segment), so two
    processes compiling them side by side could each drop the other's entry
    from the index, or number their entries' files alike: an index could
    then name, for one variant, the file another variant's machine code was
    written to last (tests/test_compile_side_by_side.py). The compiling
    itself, the minutes, still runs side by side. On a file system that
    refuses flock (some network and FUSE ones) a save is made as numba makes
    it; `wmr-mission compile` then compiles in one process."""
    import fcntl

    from numba.core.caching import IndexDataCacheFile

    first = _state.save_lock is None
    _state.save_lock = lock  # a second call: another lock, not a second wrapper
    if not first:
        return
    save: Callable[[Any, Any, Any], None] = IndexDataCacheFile.save

    def save_holding_the_lock(self: Any, key: Any, data: Any) -> None:
        assert _state.save_lock is not None
        try:
            held = open(_state.save_lock, "a")  # noqa: SIM115 - closed below
        except OSError:  # the directory gone or read-only: numba's save says so
            save(self, key, data)
            return
        with held:
            with contextlib.suppress(OSError):  # no flock here: as numba saves
                fcntl.flock(held, fcntl.LOCK_EX)  # released as the file closes
            save(self, key, data)

    IndexDataCacheFile.save = save_holding_the_lock  # type: ignore[method-assign]


def _cache_class() -> Any:
    """numba's on-disk cache of one function, but loading an entry without
    setting numba's target up first (numba's own sets it up "to ensure it is
    initialized"): a cached function is machine code and what numba needs to
    call it, and the reference-counting runtime it links to, made here where
    its machine code names the runtime (:func:`_names_the_runtime`: 0.02 s of
    a process, never for a function compiled without reference counting, the
    loop's). A miss sets the target up for the compile that follows
    (:func:`_set_up_for_compiling`), which then finds it set up. None
    (numba's own cache, setting up as it loads) for another numba than
    :data:`LOADED_AS_IS_FOR`: its load_overload may do more than this one
    restates."""
    from numba.core.caching import FunctionCache
    from numba.core.runtime import nrt

    if not _numba_as_read():
        return None

    class LoadedAsIs(FunctionCache):
        def load_overload(self, sig: Any, target_context: Any) -> Any:
            loaded = None
            with self._guard_against_spurious_io_errors():
                loaded = self._load_overload(sig, target_context)
            if loaded is None:  # a compile follows, seconds to minutes: said as it starts
                notice = compiling_notice(getattr(self._py_func, "__module__", None))
                if notice is not None:
                    _say(notice)
                _set_up_for_compiling()
            return loaded

        def _load_overload(self, sig: Any, target_context: Any) -> Any:
            if not self._enabled:
                return None
            key = self._index_key(sig, target_context.codegen())  # type: ignore[no-untyped-call]
            data = self._cache_file.load(key)  # type: ignore[no-untyped-call]
            if data is None:
                return None
            if _names_the_runtime(data[0]):
                nrt.rtsys.initialize(target_context)
            return self._impl.rebuild(target_context, data)

    return LoadedAsIs


def _names_the_runtime(library: Any) -> bool:
    """Whether a cached function's library (numba's serialized form: a name,
    its kind, its machine code and bitcode) names a symbol of numba's
    reference-counting runtime (``NRT_incref``, ``nrt_atomic_add``, ...),
    which must then be made before the code is linked. Every such symbol's
    name holds "NRT_" or "nrt_"; a form not known here is taken to name it."""
    try:
        _, kind, data = library
        code = data[0] if kind == "object" else data
    except (TypeError, ValueError, IndexError):
        return True
    return not isinstance(code, bytes) or b"NRT_" in code or b"nrt_" in code


def _dispatcher(source: Callable[..., Any], cached: bool, options: Mapping[str, Any]) -> Any:
    """numba's dispatcher of ``source``; cached on disk by :func:`_cache_class`
    when ``cached``, else set up to compile."""
    dispatcher = _njit()(cache=cached and _state.cache_class is None, **options)(source)
    if cached and _state.cache_class is not None:
        dispatcher._cache = _state.cache_class(source)
        # numba loads its extensions (every installed package's entry points
        # scanned, 0.008 s) before each first call; only compiling needs them,
        # and a miss sets the target up, loading them (_set_up_for_compiling).
        dispatcher._compilation_chain_init_hook = _extensions_when_compiling
    elif not cached:
        _set_up_for_compiling()
    return dispatcher


def _extensions_when_compiling() -> None:
    """A cached dispatcher's hook before its first call: nothing (see :func:`_dispatcher`)."""


class _WithoutScipy:
    """An import finder refusing scipy to the thread that loads numba and sets
    up its target: numba imports scipy as it loads, only to check its version,
    and its array-math module imports scipy's BLAS as the target is set up,
    to offer ``np.dot`` on BLAS (0.13-0.15 s of a cached run,
    docs/performance.md). No kernel calls scipy; a kernel that did would
    import it when compiled."""

    def __init__(self) -> None:
        self.thread = threading.get_ident()

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> None:
        if name.split(".")[0] == "scipy" and threading.get_ident() == self.thread:
            raise ImportError(f"{name}: not needed by the kernels")


def _without_scipy() -> contextlib.AbstractContextManager[None]:
    """scipy refused to this thread for the moment (:class:`_WithoutScipy`)."""
    return _found_first(_WithoutScipy())


@contextlib.contextmanager
def _found_first(finder: Any) -> Iterator[None]:
    """``finder`` asked first for every import, for the moment."""
    sys.meta_path.insert(0, finder)
    try:
        yield
    finally:
        sys.meta_path.remove(finder)


# numba's module of extension entry points, stood in for as numba loads.
ENTRY_POINTS = "numba.core.entrypoints"


class _ExtensionsLater:
    """An import finder and loader of numba's module of extension entry points
    (:data:`ENTRY_POINTS`) as numba loads: a module whose ``init_all`` loads
    numba's own, and with it importlib.metadata (the email parser, zipfile,
    csv: 0.014-0.017 s of CPU), when first called, and then calls it; any
    other name of it is numba's own module's. numba calls ``init_all`` to
    compile, never to load a cached function (:func:`_dispatcher`): a run of
    a cached loop imports importlib.metadata nowhere (docs/performance.md,
    Start-up)."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        return (
            importlib.util.spec_from_loader(name, cast(Any, self)) if name == ENTRY_POINTS else None
        )

    def create_module(self, spec: Any) -> None:
        return None  # a plain module

    def exec_module(self, module: types.ModuleType) -> None:
        module.init_all = lambda: _numbas_entry_points().init_all()  # type: ignore[attr-defined]
        module.__getattr__ = lambda name: getattr(_numbas_entry_points(), name)  # type: ignore[method-assign]


_entry_points_lock = threading.Lock()
_entry_points: list[types.ModuleType] = []


def _numbas_entry_points() -> types.ModuleType:
    """numba's own module of extension entry points, loaded once."""
    with _entry_points_lock:
        if not _entry_points:
            import importlib.machinery

            import numba.core

            spec = importlib.machinery.PathFinder.find_spec(ENTRY_POINTS, numba.core.__path__)
            assert spec is not None
            assert spec.loader is not None
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            _entry_points.append(module)
        return _entry_points[0]


def _extensions_later() -> contextlib.AbstractContextManager[None]:
    """numba's module of extension entry points stood in for while numba
    loads (:class:`_ExtensionsLater`), for :data:`LOADED_AS_IS_FOR` only, whose
    module this reads."""
    if not _as_read(installed_version("numba") or "") or ENTRY_POINTS in sys.modules:
        return contextlib.nullcontext()
    return _found_first(_ExtensionsLater())


def compiled(fn: F, *, counted: bool = True, cached: bool = True) -> F:
    """The form of ``fn`` Python should call: numba's compiled dispatcher
    (cached on disk) when compiling, else plain Python (:func:`plain`).

    ``cached=False`` keeps what it compiles in memory only: for a loop that
    runs kernels from outside the package (a plug-in), whose edits the cache's
    stamp (wmr_mission.kernels.cache) does not see.

    ``counted=False`` compiles without numba's reference counting (``_nrt=False``,
    an option numba accepts though it documents it only for its developers),
    for the loop: it allocates nothing, and the arrays it is handed stay held
    by its Python caller for the call, so no call pays atomic count updates for
    the records it passes (docs/performance.md)."""
    if not load():
        return plain(fn)
    source = getattr(fn, "py_func", fn)
    key = (id(source), counted, cached)
    made = _state.entries.get(key)  # made once: no lock to find it (a judge asks per phase)
    if made is not None:
        return cast(F, made)
    with _lock:
        if key not in _state.entries:
            options = dict(_OPTIONS)
            if not counted and _accepts_nrt_option():  # else counted: still correct
                options["_nrt"] = False
            _state.entries[key] = _dispatcher(source, cached and _state.cached, options)
        return cast(F, _state.entries[key])


def typeable(*values: Any) -> bool:
    """Whether numba can pass each of ``values`` into compiled code (a plug-in's
    objects: a numba ``@jitclass`` instance can be, a plain Python object
    cannot); False when not compiling."""
    if not load():
        return False
    for value in values:
        try:
            _state.numba.typeof(value)
        except (ValueError, TypeError):
            return False
    return True


def _accepts_nrt_option() -> bool:
    """Whether this numba knows ``_nrt``: an unknown option would only fail at
    the first call, as a KeyError out of the compiler."""
    try:
        from numba.core.cpu import CPUTargetOptions
    except ImportError:  # pragma: no cover - a numba without its CPU target module
        return False
    return hasattr(CPUTargetOptions, "_nrt")


def bind(function: F, bindings: Mapping[str, Callable[..., Any]]) -> F:
    """A copy of ``function`` with some of the names it calls bound to other
    functions of the same signatures: the loop for one mission's estimator
    and controller (wmr_mission.sim.runner). Compiled, each copy is a function
    of its own, its kernels inlined as the original's are."""
    source = getattr(function, "py_func", function)
    namespace = {**source.__globals__, **bindings}
    return cast(
        F,
        types.FunctionType(
            source.__code__, namespace, source.__name__, source.__defaults__, source.__closure__
        ),
    )


def plain(
    function: F,
    substitutes: Mapping[Any, Callable[..., Any]] | None = None,
    _made: dict[int, Any] | None = None,
) -> F:
    """The plain-Python form of a kernel or entry point: a copy of the function
    calling the plain-Python copies of the kernels it names, and
    ``substitutes[k]`` (itself made plain) wherever it names a kernel ``k``
    there: the loop with the reference step in place of the fast kernels
    (wmr_mission.sim.reference). The same bytes as compiled, and no call
    through :class:`Kernel` per sample."""
    substitutes = substitutes or {}
    made = {} if _made is None else _made
    if _substituted(function, substitutes):
        function = cast(F, substitutes[function])
    source = getattr(function, "py_func", function)
    if not isinstance(source, types.FunctionType):
        return function
    if id(source) not in made:
        namespace = dict(source.__globals__)
        made[id(source)] = types.FunctionType(
            source.__code__, namespace, source.__name__, source.__defaults__, source.__closure__
        )
        for name, value in source.__globals__.items():
            if isinstance(value, Kernel) or _substituted(value, substitutes):
                namespace[name] = plain(value, substitutes, made)
    return cast(F, made[id(source)])


def _substituted(value: Any, substitutes: Mapping[Any, Callable[..., Any]]) -> bool:
    try:
        return value in substitutes
    except TypeError:  # unhashable
        return False


# ``ticks()``: a clock cheap enough to read twice per sample inside the loop.
# Compiled on x86-64 it counts processor cycles (the runner converts them to
# nanoseconds against time.perf_counter_ns over the run); as plain Python it
# is time.perf_counter_ns; compiled elsewhere there is no such clock: 0.
def _nanoseconds() -> int:
    return time.perf_counter_ns()


ticks = Kernel(_nanoseconds, inline=False)


def cycle_counter() -> bool:
    """Whether compiled code can read the processor's cycle counter here
    (x86-64 only: elsewhere it may not be readable from user space)."""
    return platform.machine().lower() in ("x86_64", "amd64")


def _teach_ticks() -> None:
    if not cycle_counter():

        def zero() -> int:
            return 0

        ticks._dispatcher = _njit()(nogil=True)(zero)
        return
    from llvmlite import ir
    from numba import types as numba_types
    from numba.extending import intrinsic

    @intrinsic
    def read_counter(typingctx: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            function_type = ir.FunctionType(ir.IntType(64), [])
            counter = builder.module.declare_intrinsic("llvm.readcyclecounter", fnty=function_type)
            return builder.call(counter, [])

        return numba_types.int64(), codegen

    def counter() -> int:
        return read_counter()  # type: ignore[call-arg]

    ticks._dispatcher = _njit()(nogil=True, cache=_state.cached)(counter)


# How long a compile in the foreground takes, the machine's load deciding:
# what case study 2's first run needs, 27 s of CPU, and 157 s of wall time
# with both cores busy five times over (docs/performance.md, Start-up).
ONE_VARIANT = "half a minute to 3 minutes by the machine's load"
NOTICE = (
    "wmr-mission: loading the simulation loop, compiled first if it is not in the "
    f"cache ({ONE_VARIANT}, once; from the cache, under a second; `wmr-mission compile` "
    "compiles every variant and ends this line)"
)


def foreground_notice() -> str | None:
    """The line printed before the compiled loop is loaded when the cache is
    not known to hold it (no ready marker): a compile of one variant then
    (:data:`ONE_VARIANT`); the loop's compile is then not said again
    (:func:`compiling_notice`).
    None when the loop is loaded already, or nothing is compiled."""
    from wmr_mission.kernels import cache

    if loaded() or not compiling():
        return None
    directory = cache.cache_directory()
    if directory is not None and cache.is_ready(directory):
        return None
    _said_already(LOOP)
    return NOTICE


# What each module's compiled entry points are to a user, and how long their
# compile takes from an empty cache, the machine's load deciding: the judge's
# passes 16.5 s of CPU and 20.5 s of wall time (load average 3.1), the pixel
# counts 0.6 s, the EKF band's replay 2.4 s (`python benchmarks/measure.py
# compilewaits`); under the load that took the loop 157 s, the judge's about
# 90 s (docs/performance.md, Start-up). By the first match, in this order.
LOOP = 0
COMPILED_WHAT: tuple[tuple[str, str, str], ...] = (
    ("wmr_mission.kernels.", "the simulation loop", ONE_VARIANT),
    (
        "wmr_mission.verdicts.",
        "the judge's passes",
        "15 s to a minute and a half by the machine's load",
    ),
    ("wmr_mission.campaign.", "the campaign's pixel counts", "a second or a few"),
    ("wmr_mission.output.", "the EKF band's replay", "a second or a few"),
    ("", "kernels", "seconds to minutes by the machine's load"),
)


def compiling_notice(module: str | None) -> str | None:
    """The line said as a compiled entry point of ``module`` starts compiling
    (its cache missed): what compiles, once, and about how long; None where
    this process, the process it was forked from or another forked from that
    one has said it (or :data:`NOTICE`, for the loop). A compile of the
    judge's passes after a campaign's runs would otherwise leave a terminal
    silent for a minute or more; a warm cache never misses, and says nothing."""
    group = next(
        i for i, (prefix, _, _) in enumerate(COMPILED_WHAT) if (module or "").startswith(prefix)
    )
    if not _said_first(group):
        return None
    _, what, how_long = COMPILED_WHAT[group]
    return (
        f"wmr-mission: compiling {what}, not in the cache yet ({how_long}, once; "
        "from the cache, under a second)"
    )


@contextlib.contextmanager
def compiles_said_by(say: Callable[[str], None]) -> Iterator[None]:
    """Inside, the compiles of this process and of those forked from it said
    by ``say``: a command's steps drawn on a terminal
    (wmr_mission.output.progress), which print the line above them where a
    bare line would be drawn over. A forked process (a campaign's worker)
    says it with its copy of the steps, the same rows above the same shape of
    steps, which the command redraws as it goes on."""
    before = _state.say
    _state.say = say
    try:
        yield
    finally:
        _state.say = before


def _say(line: str) -> None:
    if _state.say is not None:
        _state.say(line)
    else:
        print(line, file=sys.stderr, flush=True)


def compiles_said_elsewhere() -> None:
    """No compile is said (:func:`compiling_notice`) in this process and those
    it forks from now: `wmr-mission compile` says its own."""
    for group in range(len(COMPILED_WHAT)):
        _said_already(group)


def _said_memory() -> Any:
    """Which compiles were said, a byte each, in memory shared with the
    processes forked from this one (a campaign's workers, which would
    otherwise each say the compile they all wait on)."""
    import mmap

    return mmap.mmap(-1, len(COMPILED_WHAT))


def _said_already(group: int) -> None:
    if _state.said is None:  # before numba loads: nothing forked shares it yet
        _state.said = _said_memory()
    _state.said[group] = 1


def _said_first(group: int) -> bool:
    """Whether ``group``'s compile is said here first (and now counts as said):
    checked and set holding the cache's save lock, where there is one, so
    that two processes missing at once do not both say it."""
    if _state.said is None:
        _state.said = _said_memory()
    with _holding(_state.save_lock):
        if _state.said[group]:
            return False
        _state.said[group] = 1
        return True


@contextlib.contextmanager
def _holding(lock: str | None) -> Iterator[None]:
    """``lock`` (a file) held with flock, where there is one and it can be."""
    if lock is None:
        yield
        return
    try:
        held = open(lock, "a")  # noqa: SIM115 - closed below
    except OSError:
        yield
        return
    with held:
        with contextlib.suppress(OSError, ImportError):
            import fcntl

            fcntl.flock(held, fcntl.LOCK_EX)  # released as the file closes
        yield
