"""RK4 in blocks of steps, compiled to a shared library and cached, or in the CasADi VM.

A long run is a sequence of calls into *blocks*: CasADi Functions that take the state after
step ``n`` and return the states after the next ``size`` RK4 steps (one column each).
The block sizes are fixed (``BLOCK_SIZES``: 10 000, 1000, 100, 10, 1), so any number of steps
is covered by at most 36 calls besides the full blocks, and a model needs one compilation
for every run, whatever its duration or decimation.

The step counter ``n`` travels with the state, ``[z…, n]`` (z the model's state of any size),
and the time of step
``n`` is ``t0 + n·h``: exact to one rounding however long the run, and the same whichever
blocks cover it, so a result does not depend on how the run was cut into calls.

Compiled path: CasADi writes the C source of the blocks (and of ``rhs``, ``rhs_jac``,
``rk4_step``); the system C compiler turns it into a shared library in ``compiled/`` of
the user cache (``BEARINGDYN_CACHE``, default ``platformdirs.user_cache_dir("bearingdyn")``),
named by the SHA-256 of the source, the compiler command, its flags and the CasADi version;
``casadi.external`` loads it. The library is written under a temporary name and renamed, so
concurrent processes (sweep workers) never see half a file. A cached library that does not
load or does not reproduce the VM's ``rk4_step`` is rebuilt. Without a working compiler the
blocks run in the CasADi virtual machine, after one warning. Both paths evaluate the same
operations in the same order: their results agree to rounding (bit for bit with the
default flags on x86-64).
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from analysis.integrate.tangent import Carry, block_tree, model_tag, tangent_step
from analysis.model import BallCounts, Model, Structure
from modelgen.locations import cache_root

BLOCK_SIZES = (10_000, 1000, 100, 10, 1)
"""RK4 steps per block, largest first; each is ten of the next."""
DEFAULT_CC = "gcc"
DEFAULT_CFLAGS = ("-O3", "-fno-math-errno", "-fno-semantic-interposition",
                  "-ffp-contract=off")
"""-O3 without fast-math: the same IEEE operations as the VM. -fno-math-errno lets sqrt
inline (no errno branch; values unchanged); -fno-semantic-interposition lets CasADi's
helper functions inline in a -fPIC library; -ffp-contract=off keeps a*b+c two roundings
even when BEARINGDYN_CFLAGS adds -march=native (FMA), so compiled and VM results stay
identical. No -march=native by default: a cache directory shared by machines of different
CPUs (a cluster home directory) must not hand one of them instructions it lacks."""
LAYOUT_VERSION = "1"
"""Bumped when the layout of the compiled library changes (part of the cache key)."""
_SELF_TEST_RTOL = 1e-12


class CompileError(RuntimeError):
    """The C compiler is missing or failed."""


def cache_dir() -> Path:
    """Folder of the compiled libraries: ``compiled/`` in the user cache
    (``$BEARINGDYN_CACHE``, else the platform's user cache folder; ``modelgen.locations``),
    beside the generated code of user specs in ``models/``."""
    return cache_root() / "compiled"


def compiler_command() -> list[str]:
    """The C compiler and its flags: $BEARINGDYN_CC (else $CC, else gcc), $BEARINGDYN_CFLAGS
    (else ``DEFAULT_CFLAGS``)."""
    cc = os.environ.get("BEARINGDYN_CC") or os.environ.get("CC") or DEFAULT_CC
    flags = os.environ.get("BEARINGDYN_CFLAGS")
    return [*shlex.split(cc), *(shlex.split(flags) if flags is not None else DEFAULT_CFLAGS)]


def rk4_blocks(funcs: Any) -> dict[int, ca.Function]:
    """The block Functions of a model's ``rk4_step``, by size.

    ``rk4_block<size>(zn [n+1], p, h, t0) -> Z [n+1 x size]``: ``zn = [z…, n]`` is the
    state (SI units) after step ``n``; column ``j`` of ``Z`` is the state after step
    ``n + j + 1``; step ``k`` runs from ``t0 + k·h`` to ``t0 + (k + 1)·h`` (s). The
    subexpressions of a step that depend on ``p``, ``h`` and ``t0`` only (cage speed, the
    rotations of the cage angle by ω_cage·h/2 and ω_cage·h, …) are computed once per call
    (``tangent.Carry.constants``): the same operations as per step, so the same values.
    """
    step, constants = tangent_step(funcs.rk4_step, Carry(constants=True), "rk4_steps1",
                                   "rk4_constants")
    inner = block_tree(step, BLOCK_SIZES, lambda size: f"rk4_steps{size}", keep_states=True)
    blocks = {}
    for size in sorted(BLOCK_SIZES):
        zn, p, h, t0 = (ca.MX.sym(name, step.sparsity_in(i))
                        for i, name in enumerate(("zn", "p", "h", "t0")))
        out = inner[size](zn, p, h, t0, constants(p, h, t0))
        blocks[size] = ca.Function(f"rk4_block{size}", [zn, p, h, t0], [out],
                                   ["zn", "p", "h", "t0"], ["Z"])
    return blocks


def _library_functions(funcs: Any) -> list[ca.Function]:
    blocks = rk4_blocks(funcs)
    return [funcs.rhs, funcs.jac, funcs.rk4_step, *(blocks[s] for s in BLOCK_SIZES)]


def _c_source(functions: list[ca.Function], prefix: str) -> str:
    cg = ca.CodeGenerator(f"{prefix}.c", {"with_header": False})
    for f in functions:
        cg.add(f)
    return cg.dump()


def compile_library(source: str, target: Path, command: list[str]) -> None:
    """Compile ``source`` to the shared library ``target`` (written atomically)."""
    exe = shutil.which(command[0])
    if exe is None:
        raise CompileError(f"C compiler '{command[0]}' not found")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=target.parent, prefix=".build-") as tmp:
            src = Path(tmp) / f"{target.stem}.c"
            src.write_text(source)
            so = Path(tmp) / target.name
            res = subprocess.run([exe, *command[1:], "-shared", "-fPIC", "-o", str(so),
                                  str(src), "-lm"], capture_output=True, text=True,
                                 timeout=600)
            if res.returncode != 0:
                tail = "\n".join((res.stderr or res.stdout).strip().splitlines()[-5:])
                raise CompileError(f"C compiler '{command[0]}' failed (exit "
                                   f"{res.returncode}):\n{tail}")
            os.replace(src, target.with_suffix(".c"))
            digest = Path(tmp) / checksum_path(target).name
            digest.write_text(file_sha256(so) + "\n")
            os.replace(so, target)
            os.replace(digest, checksum_path(target))
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise CompileError(f"could not build {target.name} in {target.parent}: {exc}") from None


def checksum_path(library: Path) -> Path:
    """``<library>.sha256``: the SHA-256 of the library as it was built, written beside it."""
    return library.with_name(library.name + ".sha256")


def file_sha256(path: Path) -> str:
    with open(path, "rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()


def intact(library: Path) -> bool:
    """Whether the cached ``library`` is the file that was built: its checksum file is there
    and equals the SHA-256 of its bytes. Checked before a library is ever loaded, since
    loading a damaged one (truncated, emptied, overwritten) can kill the process (SIGBUS)
    before any self-test runs; a library that is not intact is built again."""
    try:
        return checksum_path(library).read_text().strip() == file_sha256(library)
    except (OSError, UnicodeDecodeError):
        return False


@dataclass
class Library:
    """Functions of one model and its numbers of balls, compiled or in the VM."""

    backend: str
    """``"compiled"`` or ``"casadi-vm"``."""
    blocks: dict[int, ca.Function]
    rhs: ca.Function
    jac: ca.Function
    rk4_step: ca.Function
    path: Path | None = None
    """The shared library (compiled backend)."""


@dataclass
class _Registry:
    libraries: dict[tuple, Library] = field(default_factory=dict)
    compilations: int = 0
    warned: bool = False


_REGISTRY = _Registry()


def compilations() -> int:
    """How many libraries this process has compiled (loads from the cache do not count)."""
    return _REGISTRY.compilations


def _fallback_warning(reason: str) -> None:
    if not _REGISTRY.warned:
        _REGISTRY.warned = True
        warnings.warn(
            f"bearingdyn: {reason}; running RK4 in the CasADi virtual machine (same results, "
            f"about 10x slower). Install a C compiler (gcc), or point BEARINGDYN_CC at one and "
            f"BEARINGDYN_CACHE at a writable folder; compiled=False (--no-compile) silences "
            f"this.", RuntimeWarning,
            stacklevel=3)


def vm_library(funcs: Any) -> Library:
    """The block functions evaluated by the CasADi virtual machine."""
    return Library("casadi-vm", rk4_blocks(funcs), funcs.rhs, funcs.jac, funcs.rk4_step)


def library(model: Model, structure: BallCounts, compiled: bool = True,
            functions: Any = None) -> Library:
    """The RK4 blocks (and rhs, jac, rk4_step) of ``model`` with ``structure`` balls per
    bearing (one number for a one-bearing model, a mapping or a tuple).

    ``compiled``: load the shared library from the cache, or build it there once; when no
    compiler works, warn once and use the VM. ``compiled=False``: the VM. Memoised per
    process. ``functions``: other Functions of the model to run in place of its own (the
    speed-profile step, ``analysis.integrate.speed_profile.ProfileFunctions``: named by its
    ``tag``, self-tested on its ``test_parameters``).
    """
    command = compiler_command() if compiled else []
    structure = model.structure(structure)  # one number, a mapping or a tuple
    memo = (model.name, model.spec_sha256, structure, tuple(command), str(cache_dir()))
    if functions is not None:
        memo += (functions.tag,)
    if memo not in _REGISTRY.libraries:
        funcs = model.functions(structure) if functions is None else functions
        lib = None
        if compiled:
            try:
                lib = _compiled_library(model, structure, funcs, command)
            except CompileError as exc:
                _fallback_warning(str(exc))
        _REGISTRY.libraries[memo] = lib or vm_library(funcs)
    return _REGISTRY.libraries[memo]


def library_stem(prefix: str, model: Model, structure: Structure) -> str:
    """``<prefix>_<model>_nb<balls>``: the start of a cached library's name."""
    return f"{prefix}_{model_tag(model, structure)}"


def cached_path(stem: str, source: str, command: list[str]) -> Path:
    """Where the library of C ``source`` built by ``command`` lives in the cache: named by
    the SHA-256 of the layout version, the CasADi version, the command and the source."""
    key = hashlib.sha256("\0".join([LAYOUT_VERSION, ca.__version__, *command, source])
                         .encode()).hexdigest()
    return cache_dir() / f"{stem}_{key[:20]}.so"


def _compiled_library(model: Model, structure: Structure, funcs: Any,
                      command: list[str]) -> Library:
    functions = _library_functions(funcs)
    tag = getattr(funcs, "tag", "")
    stem = library_stem(f"bd{tag}", model, structure)
    source = _c_source(functions, stem)
    path = cached_path(stem, source, command)
    p = model.parameter_vector(model.defaults)
    if hasattr(funcs, "test_parameters"):
        p = funcs.test_parameters(p)
    if intact(path):
        lib = _checked_load(path, functions, p)
        if lib is not None:
            return lib
        # wrong though intact (its functions differ from the VM's): build it again
    compile_library(source, path, command)
    _REGISTRY.compilations += 1
    lib = _checked_load(path, functions, p)
    if lib is None:
        raise CompileError(f"the library built by '{command[0]}' does not reproduce the "
                           f"CasADi VM (check BEARINGDYN_CFLAGS: no fast-math)")
    return lib


def _checked_load(path: Path, functions: list[ca.Function], p: np.ndarray) -> Library | None:
    """The library at ``path``, or None when it does not load or its ``rk4_step`` and
    10-step block do not reproduce the VM's (``functions``) on a test state."""
    n = functions[2].size1_in(1)
    z = test_state(n)
    tests = {2: (0.1234, z, p, 1e-5), len(functions) - 2: (np.append(z, 7.0), p, 1e-5, 0.1)}
    try:
        loaded = [ca.external(f.name(), str(path)) for f in functions]
        for i, args in tests.items():
            want = np.asarray(functions[i](*args))
            got = np.asarray(loaded[i](*args))
            if not np.all(np.abs(got - want) <= _SELF_TEST_RTOL * np.abs(want).max()):
                return None  # the externals are freed here: a rebuilt file loads afresh
    except RuntimeError:  # not a library, or one with other functions or shapes
        return None
    rhs, jac, step, *blocks = loaded
    return Library("compiled", dict(zip(BLOCK_SIZES, blocks, strict=True)), rhs, jac, step,
                   path)


def test_state(n: int) -> np.ndarray:
    """A state of size ``n`` for self-tests: displacements of some µm, velocities of some
    mm/s, every value different (n = 4: [1.3e-5, -4e-6, 2e-3, -1e-3])."""
    half = n // 2
    positions = [1.3e-5, -4e-6, 7e-6, -2e-6] * (half // 4 + 1)
    velocities = [2e-3, -1e-3, 1.5e-3, -0.5e-3] * (half // 4 + 1)
    scale = [1 + 0.1 * (k // 4) for k in range(half)]
    return np.array([*(positions[k] * scale[k] for k in range(half)),
                     *(velocities[k] * scale[k] for k in range(half))])


def block_plan(n_steps: int) -> list[int]:
    """Block sizes covering ``n_steps`` steps: full blocks of the largest size, then the
    remainder digit by digit."""
    plan = []
    for size in BLOCK_SIZES:
        count, n_steps = divmod(n_steps, size)
        plan += [size] * count
    return plan


class Runner:
    """Calls a library's blocks through preallocated buffers (no per-call conversions)."""

    def __init__(self, lib: Library, p: np.ndarray, h: float, t0: float = 0.0):
        self.backend = lib.backend
        self.n = lib.rk4_step.size1_in(1)
        self._zn = np.zeros(self.n + 1)
        self._p = np.ascontiguousarray(p, dtype=float)
        self._h, self._t0 = np.array([float(h)]), np.array([float(t0)])
        self._calls: dict[int, tuple[Any, np.ndarray, Any]] = {}
        for size, fn in lib.blocks.items():
            buf, call = fn.buffer()
            out = np.empty((size, self.n + 1))  # CasADi's column-major (n+1) x size
            for i, arr in enumerate((self._zn, self._p, self._h, self._t0)):
                buf.set_arg(i, memoryview(arr))
            buf.set_res(0, memoryview(out))
            self._calls[size] = (buf, out, call)

    def blocks(self, z0: np.ndarray, n_steps: int) -> Iterator[tuple[int, np.ndarray]]:
        """Yield ``(k, states)`` per block: ``states[j]`` is ``[z…, k + j + 1]`` after step
        ``k + j + 1``. The array is reused by the next block: copy what you keep.
        """
        self._zn[:self.n] = z0
        self._zn[self.n] = 0.0
        done = 0
        for size in block_plan(n_steps):
            _, out, call = self._calls[size]
            call()
            yield done, out
            self._zn[:] = out[-1]
            done += size


def run_rk4(lib: Library, p: np.ndarray, z0: np.ndarray, h: float, n_steps: int,
            save_every: int = 1, t0: float = 0.0,
            check: Callable[[np.ndarray], None] | None = None,
            sink: Callable[[int, np.ndarray], None] | None = None) -> np.ndarray | None:
    """``n_steps`` RK4 steps of ``h`` seconds from ``z0`` at ``t0``; the states after every
    ``save_every``-th step, shape (n, 1 + n_steps // save_every), ``z0`` first.

    ``check(states)`` sees every block as it is done (rows ``[z…, k]``, ``k`` the step after
    which the row holds) and may raise to stop the run. With ``sink``, nothing is kept:
    ``sink(start, kept)`` receives the kept states of each block (``kept`` n × m, columns
    ``start … start + m − 1`` of the array that would be returned; ``z0`` as column 0 first)
    after ``check`` passed, and None is returned: a run of any length in constant memory.
    """
    runner = Runner(lib, p, h, t0)
    out = None
    if sink is None:
        out = np.empty((runner.n, 1 + n_steps // save_every))
        out[:, 0] = z0

        def sink(start: int, kept: np.ndarray) -> None:
            out[:, start:start + kept.shape[1]] = kept
    else:
        sink(0, np.asarray(z0, dtype=float).reshape(-1, 1))
    for done, block in runner.blocks(z0, n_steps):
        if check is not None:
            check(block)
        first = -(done + 1) % save_every  # row of the first step to keep
        kept = block[first::save_every, :runner.n]
        if len(kept):
            sink((done + first + 1) // save_every, kept.T)
    return out


def compiled_function(fn: ca.Function, test_args: tuple | None = None,
                      compiled: bool = True) -> ca.Function:
    """``fn`` compiled to C through the same cache as the RK4 blocks, or ``fn`` itself when
    ``compiled`` is False or no compiler works (one warning).

    The library is keyed by the SHA-256 of its C source, the compiler command and the CasADi
    version. With ``test_args`` the loaded function must reproduce ``fn`` on them (else it is
    rebuilt). Memoised per process by the function object.
    """
    return compiled_functions([fn], [test_args], compiled)[0]


def compiled_functions(fns: Sequence[ca.Function],
                       test_args: Sequence[tuple | None] | None = None,
                       compiled: bool = True) -> list[ca.Function]:
    """Several Functions compiled into one library (one C source, one compiler run; their
    common dependencies written once), as ``compiled_function``: the same cache, key and
    self-test (``test_args[i]`` for ``fns[i]``, None: none), ``fns`` themselves when
    ``compiled`` is False or no compiler works (one warning). The library is named after
    ``fns[0]``. Memoised per process by the function objects.
    """
    fns = list(fns)
    if not compiled:
        return fns
    tests = list(test_args) if test_args is not None else [None] * len(fns)
    command = compiler_command()
    memo = ("function", *(id(fn) for fn in fns), tuple(command), str(cache_dir()))
    if memo in _REGISTRY.libraries:
        return _REGISTRY.libraries[memo]
    stem = f"bd_fn_{fns[0].name()}"
    source = _c_source(fns, stem)
    path = cached_path(stem, source, command)

    def load() -> list[ca.Function] | None:
        try:
            loaded = [ca.external(fn.name(), str(path)) for fn in fns]
            for fn, ext, args in zip(fns, loaded, tests, strict=True):
                if args is None:
                    continue
                for want, got in zip(fn.call(list(args)), ext.call(list(args)), strict=True):
                    want, got = np.asarray(want), np.asarray(got)
                    if not np.all(np.abs(got - want) <= _SELF_TEST_RTOL * np.abs(want).max()):
                        return None
            return loaded
        except RuntimeError:
            return None

    result = load() if intact(path) else None
    if result is None:
        try:
            compile_library(source, path, command)
            _REGISTRY.compilations += 1
            result = load()
        except (CompileError, OSError) as exc:
            _fallback_warning(str(exc))
    _REGISTRY.libraries[memo] = result or fns
    return _REGISTRY.libraries[memo]
