"""Kernels compiled ahead of time: numba's cache of a run's kernels, shipped with the package.

A machine's first run compiled every kernel a run calls (:mod:`fogsim.run.warmup`): 28 s of
its 31.7 s wall on the 2 cores of an AMD EPYC, 55 s of CPU (session 40), most of it numba's
front end (with ``NUMBA_OPT=0`` the compile still took 28 of 35 s CPU), so no trim of the
compile reaches issue #14's 12 s. The kernels are compiled ahead of time instead:

- :func:`build` (``python -m fogsim.run.kernel_bundle``) warms a run's kernels up in a child
  process that compiles for LLVM's ``x86-64-v2`` CPU (:data:`BUILD_CPU`: the x86-64 of 2009
  on, SSE4.2 and POPCNT, no AVX) into an empty numba cache, and packs that cache into one
  file, ``assets/kernels/<platform>-<python>-numba<version>.tar.xz`` (1.7 MB), with a
  manifest of what it was compiled for and from (:data:`MANIFEST`);
- a warm-up that finds a kernel cold (:class:`fogsim.run.warmup.KernelWarmUp`) first installs
  the bundle into numba's cache (:func:`install`), then compiles only what is still missing;
  what maps without a warm-up (a replay's report, ``fogsim tune``'s trials, ``fogsim
  compare``) installs it once a process (`fogsim.run.warmup.install_shipped_kernels`). The
  build also holds the elevation map's kernels (``fogsim compare``).

numba keys a cached kernel by its signature, the bytecode's hash and the code generator's
*magic tuple* (target triple, CPU name, CPU features), and looks an entry up under the tuple
of the machine it runs on. :func:`install` writes the bundle's index files with their keys'
tuple made this machine's (:func:`rekeyed_index`): numba then loads the build's code as its
own. Nothing else of numba's flow changes: a signature the bundle lacks is compiled and added
to the same index as before.

The bundle applies when the machine's target triple (architecture and OS), CPython version
(the cache files' names and the bytecode hashes), numba version (numba ignores an index of
another version) and the kernel modules' stamps (`mapper.kernel_cache.package_stamp`: one
hash of every kernel module of a package) are the manifest's, the CPU has every feature the
build's code uses (:data:`BUILD_CPU_FEATURES`), and numba is not told which CPU to compile
for (``NUMBA_CPU_NAME``, ``NUMBA_CPU_FEATURES``: that CPU's code is what the user asked for);
otherwise nothing is installed and the first run compiles as before.
`tests/test_kernel_bundle.py` fails when the shipped bundle's stamps are not the sources':
after an edit of a kernel module, rebuild it (``python -m fogsim.run.kernel_bundle``, about
30-40 s on 2 cores).

Measured (AMD EPYC, 2 cores, session 41): the stage's first run on an empty numba and fogsim
cache 31.7 s → 7.0 s wall (the scene's compile and the kernels' load included); its maps are
bit for bit those of code compiled for the host (every array of ``maps.npz``): the kernels
use no fast-math, so LLVM may not fuse or reorder floating-point operations for either CPU.
``FOGSIM_KERNEL_BUNDLE=0`` leaves the bundle out: the first run compiles for this CPU.

Why ``x86-64-v2`` and not LLVM's ``generic`` x86-64 (session 41's build): generic code has
only SSE2, which has no rounding instruction, so every ``floor`` (a cell index, a layer) is a
call into the C library; SSE4.1's ``roundsd`` computes the same value inline. The stage's
mapper update, 300 frames of seed 1 (``bench/bench_mapper.py --stages`` children, AMD EPYC,
load about 1, session 42): 0.870 ms generic, 0.794 ms ``x86-64-v2``, 0.778-0.794 ms compiled
for the host (Zen 4, AVX-512); ``x86-64-v3`` (AVX2, FMA) 0.791 ms, which would shut out the
machines without AVX2 for no measurable gain. Warm, as a user runs them
(``bench/bench_run.py stage --repeats 5 --replay REC --tree OLD --tree NEW``, interleaved,
load 2.0-2.5): the stage walk 4.75 → 4.40 s wall (the main thread's CPU 2.90 → 2.60 s), the
replay of its recording 3.45 → 3.20 s; the same maps, byte for byte (stage run and replay).
"""

from __future__ import annotations

import argparse
import io
import json
import lzma
import os
import pickle
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numba
from llvmlite import binding as llvm
from numba.core.dispatcher import Dispatcher
from numba.core.registry import cpu_target

from fogsim.atomic import write_bytes_atomic
from fogsim.errors import FogsimError, KernelBundleError, OutputError
from fogsim.paths import ASSETS_DIR

__all__ = [
    "BUILD_CPU",
    "BUILD_CPU_FEATURES",
    "BUNDLE_DIR",
    "ENV_SWITCH",
    "MANIFEST",
    "BundleTarget",
    "Installed",
    "build",
    "bundle_path",
    "enabled",
    "host_cpu_features",
    "install",
    "rekeyed_index",
    "runs_here",
    "shipped_name",
]

BUNDLE_DIR = ASSETS_DIR / "kernels"
"""Where the shipped bundle lives (installed with the package's other data)."""

MANIFEST = "manifest.json"
"""The bundle's first member: its :class:`BundleTarget` and its folders' stamps, as JSON."""

ENV_SWITCH = "FOGSIM_KERNEL_BUNDLE"
"""Environment variable: ``0`` leaves the bundle out (the first run compiles for this CPU)."""

BUILD_CPU = "x86-64-v2"
"""The CPU the build's code is compiled for (LLVM's name; its features, none added)."""

BUILD_CPU_FEATURES = ("cx16", "popcnt", "sahf", "sse3", "sse4.1", "sse4.2", "ssse3")
"""What :data:`BUILD_CPU` has beyond the x86-64 baseline (LLVM's feature names): a machine
whose CPU lacks one of them would stop at an illegal instruction, so :func:`install` installs
nothing there."""


@dataclass(frozen=True)
class BundleTarget:
    """What a bundle's code was compiled for, and a machine's own.

    Attributes:
        triple: LLVM target triple (architecture, vendor, OS), e.g. ``x86_64-unknown-linux-gnu``.
        python: CPython's version tag in numba's cache file names, e.g. ``py311``.
        numba: numba's version (numba ignores an index written by another).
    """

    triple: str
    python: str
    numba: str

    @classmethod
    def here(cls) -> BundleTarget:
        """This process's target."""
        return cls(
            triple=str(cpu_target.target_context.codegen().magic_tuple()[0]),
            python=f"py{sys.version_info.major}{sys.version_info.minor}{sys.abiflags}",
            numba=numba.__version__,
        )

    @property
    def file_name(self) -> str:
        """The bundle's file name for this target."""
        return f"{self.triple}-{self.python}-numba{self.numba}.tar.xz"


@dataclass(frozen=True)
class Installed:
    """What :func:`install` wrote.

    Attributes:
        bundle: The bundle file.
        indexes: Index files written (one per cached function), each with its code files.
        cpu: The CPU the code was compiled for (LLVM's name, e.g. ``x86-64-v2``).
    """

    bundle: Path
    indexes: int
    cpu: str


def enabled() -> bool:
    """Whether warm-ups install the bundle (``FOGSIM_KERNEL_BUNDLE`` is not ``0``)."""
    return os.environ.get(ENV_SWITCH, "1").strip() != "0"


def host_cpu_features() -> frozenset[str]:
    """The features of this machine's CPU, by LLVM's names (empty when LLVM cannot tell)."""
    try:
        features = llvm.get_host_cpu_features()
    except RuntimeError:  # LLVM has no feature list for this host
        return frozenset()
    return frozenset(name for name, present in features.items() if present)


def runs_here(cpu: Mapping[str, Any]) -> bool:
    """Whether a build for ``cpu`` (the manifest's ``cpu``: name, features) is this machine's.

    It is when this CPU has every feature the build's code uses and numba is not told which
    CPU to compile for (``NUMBA_CPU_NAME``, ``NUMBA_CPU_FEATURES``).
    """
    if numba.config.CPU_NAME is not None or numba.config.CPU_FEATURES is not None:
        return False
    return set(cpu["features"]) <= host_cpu_features()


def bundle_path(target: BundleTarget | None = None) -> Path:
    """The shipped bundle's path for ``target`` (this machine's when None); it may not exist."""
    return BUNDLE_DIR / (target or BundleTarget.here()).file_name


def _folder_key(py_file: str) -> str:
    """A kernel's source folder, e.g. ``mapper/scanline``.

    Relative to the folder holding the ``mapper`` and ``fogsim`` packages: the same in a
    checkout and in an installed wheel.
    """
    folder = Path(py_file).resolve().parent
    for parent in folder.parents:
        if (parent / "mapper").is_dir() and (parent / "fogsim").is_dir():
            return folder.relative_to(parent).as_posix()
    return folder.as_posix()


def _jsonable(stamp: Any) -> Any:
    """A numba source stamp as JSON holds it (a tuple of numbers becomes a list)."""
    return json.loads(json.dumps(stamp))


def cache_folders(kernels: Iterable[Dispatcher]) -> dict[str, tuple[Path, Any]]:
    """The numba cache folder and source stamp per source folder of ``kernels``.

    Keyed by :func:`_folder_key`: the folder numba caches that source folder's kernels in, in
    this process (``NUMBA_CACHE_DIR``, beside the sources, or the user-wide folder), and the
    stamp it writes into their index files.
    """
    folders: dict[str, tuple[Path, Any]] = {}
    for kernel in kernels:
        cache = getattr(kernel, "_cache", None)
        cache_file = getattr(cache, "_cache_file", None)
        if cache_file is None:
            continue
        key = _folder_key(kernel.py_func.__code__.co_filename)
        folders.setdefault(key, (Path(cache._cache_path), cache_file._source_stamp))
    return folders


def _read_index(data: bytes) -> tuple[str, Any, dict]:
    """An index file's numba version, source stamp and ``{key: code file name}``."""
    stream = io.BytesIO(data)
    version = pickle.load(stream)
    stamp, overloads = pickle.loads(stream.read())
    return version, stamp, overloads


def shipped_name(code_name: str) -> str:
    """An installed code file's name: numba's ``<base>.<n>.nbc`` as ``<base>.<n>.shipped.nbc``.

    numba names a new entry's code file ``<base>.<n>.nbc`` with the lowest ``n`` its index does
    not use yet; a process compiling a kernel while another installs the bundle could pick the
    bundle's name for another signature, and whichever wrote last would leave an index entry
    pointing at another signature's code. Under names numba never picks, a race between them
    can only lose an index entry (compiled again later), never mismatch one.
    """
    return f"{code_name.removesuffix('.nbc')}.shipped.nbc"


def rekeyed_index(data: bytes, magic_tuple: tuple) -> bytes:
    """An index file whose entries' code generator tuple is ``magic_tuple``.

    numba's index key is ``(signature, magic tuple, (bytecode hash, closure hash))``; only the
    tuple changes, and each code file's name becomes its :func:`shipped_name`. The version and
    the source stamp stay.
    """
    version, stamp, overloads = _read_index(data)
    rekeyed = {
        (key[0], tuple(magic_tuple), key[2]): shipped_name(name) for key, name in overloads.items()
    }
    return pickle.dumps(version, protocol=-1) + pickle.dumps((stamp, rekeyed), protocol=-1)


def _fresh(index_path: Path, stamp: Any) -> bool:
    """Whether numba would use the index file at ``index_path`` (its version and stamp)."""
    try:
        version, found, overloads = _read_index(index_path.read_bytes())
    except (OSError, EOFError, pickle.UnpicklingError, ValueError, TypeError):
        return False
    return version == numba.__version__ and found == stamp and bool(overloads)


def _read_bytes(tar: tarfile.TarFile, name: str) -> bytes:
    """A member's bytes (KeyError: no such member)."""
    handle = tar.extractfile(name)
    if handle is None:
        raise KernelBundleError(f"kernel bundle {tar.name}: {name} is not a file")
    return handle.read()


def install(kernels: Iterable[Dispatcher], bundle: Path | None = None) -> Installed | None:
    """Put the bundle's compiled kernels into numba's cache where they apply.

    For each source folder of ``kernels`` whose stamp is the manifest's, every index file of
    the bundle whose counterpart in numba's cache folder is not fresh (absent, stale or of
    another numba) is written with its code files, rekeyed to this machine
    (:func:`rekeyed_index`); each file atomically, the code files before their index, so a
    process reading the cache meanwhile never finds an index without its code. A fresh index
    (a kernel compiled here) is never overwritten.

    Args:
        kernels: The kernels whose folders are installed (every function numba cached in
            those folders is, their callees too).
        bundle: The bundle file; None: :func:`bundle_path`.

    Returns:
        What was written, or None when nothing was: no bundle for this machine, the bundle
        left out (:func:`enabled`), not applying (another triple, CPython, numba or source
        stamp), or every index fresh already.

    Raises:
        KernelBundleError: The bundle cannot be read (corrupt, truncated) or a cache file
            cannot be written; what was written before stays (each file whole, numba reads
            an index only with its code).
    """
    path = bundle_path() if bundle is None else bundle
    if not enabled() or not path.is_file():
        return None
    try:
        return _install(kernels, path)
    except (OSError, EOFError, lzma.LZMAError, tarfile.TarError) as exc:
        raise KernelBundleError(f"cannot read kernel bundle {path}: {exc}") from exc
    except (KeyError, TypeError, ValueError, pickle.UnpicklingError) as exc:
        raise KernelBundleError(f"kernel bundle {path} is corrupt: {exc!r}") from exc
    except OutputError as exc:
        raise KernelBundleError(str(exc)) from exc


def _install(kernels: Iterable[Dispatcher], path: Path) -> Installed | None:
    """:func:`install` of the bundle at ``path`` (its errors as they come)."""
    here = BundleTarget.here()
    folders = cache_folders(kernels)
    magic = cpu_target.target_context.codegen().magic_tuple()
    indexes = 0
    with tarfile.open(path, "r:xz") as tar:
        manifest = json.loads(_read_bytes(tar, MANIFEST))
        if BundleTarget(**manifest["target"]) != here or not runs_here(manifest["cpu"]):
            return None
        # Read once, in the archive's order: an xz stream cannot seek back without
        # decompressing again from its start.
        members = {member.name: _read_bytes(tar, member.name) for member in tar if member.isfile()}
        for folder, stamp in manifest["stamps"].items():
            if folder not in folders or _jsonable(folders[folder][1]) != stamp:
                continue
            cache_path = folders[folder][0]
            for name in sorted(members):
                if not name.startswith(f"{folder}/") or not name.endswith(".nbi"):
                    continue
                base = name[len(folder) + 1 :]
                if "/" in base or _fresh(cache_path / base, folders[folder][1]):
                    continue
                index = members[name]
                code_names = sorted(set(_read_index(index)[2].values()))
                if any(f"{folder}/{code}" not in members for code in code_names):
                    continue  # an incomplete bundle: this function compiles as before
                for code in code_names:
                    write_bytes_atomic(cache_path / shipped_name(code), members[f"{folder}/{code}"])
                write_bytes_atomic(cache_path / base, rekeyed_index(index, magic))
                indexes += 1
    return Installed(path, indexes, manifest["cpu"]["name"]) if indexes else None


def _compile_into(manifest_path: Path) -> None:
    """The build's child: warm up every :func:`build_params` run, write the cache's manifest.

    Runs with :data:`BUILD_CPU` and an empty ``NUMBA_CACHE_DIR`` (:func:`build`). The manifest
    names, per source folder of the warm-up's kernels, numba's cache folder and its stamp.
    """
    from fogsim.run import warmup  # the warm-up imports this module

    for params in build_params():
        warmup.warm_up_kernels(params, stream=None)
    _elevation_map()
    kernels = [kernel for group in warmup.GROUPS for kernel in group.kernels]
    folders = cache_folders(kernels)
    manifest = {
        "target": asdict(BundleTarget.here()),
        "magic_tuple": list(cpu_target.target_context.codegen().magic_tuple()),
        "cpu": {"name": BUILD_CPU, "features": list(BUILD_CPU_FEATURES)},
        "stamps": {key: _jsonable(stamp) for key, (_, stamp) in sorted(folders.items())},
        "caches": {key: str(cache) for key, (cache, _) in sorted(folders.items())},
    }
    manifest_path.write_text(json.dumps(manifest, indent=1))


def _elevation_map() -> None:
    """Compile the elevation map's kernels on a row of synthetic floor points.

    ``fogsim compare``'s ``elevation`` map: no warm-up group has them (a run does not call
    them).
    """
    import numpy as np

    from mapper.elevation_map import ElevationMap

    points = np.column_stack([np.linspace(0.5, 1.5, 50), np.zeros(50), np.zeros(50)])
    ElevationMap().update(points, np.full(50, np.nan), np.array([0.0, 0.0, 0.9]))


def build_params() -> list:
    """The runs whose kernels the bundle holds: the stage scenario in depth and stereo mode.

    A replay calls the same kernels but the self-filter's; other scenarios, robots and
    parameter values call them with the same types.
    """
    from fogsim.config import load_scenario, resolve_params
    from fogsim.run.runner import sensor_fields

    stage = load_scenario("stage")
    stereo = replace(stage, camera=replace(stage.camera, mode="stereo"))
    return [resolve_params(s, None, sensor_fields(s)) for s in (stage, stereo)]


def _tar_bytes(manifest: Mapping[str, Any], caches: Mapping[str, Path]) -> bytes:
    """The bundle's bytes: the manifest, then every file of each cache folder.

    Sorted, without times or owners: the same cache packs to the same bytes.
    """
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:xz") as tar:

        def add(name: str, data: bytes) -> None:
            info = tarfile.TarInfo(name)
            info.size, info.mode, info.mtime = len(data), 0o644, 0
            tar.addfile(info, io.BytesIO(data))

        public = {key: manifest[key] for key in ("target", "magic_tuple", "cpu", "stamps")}
        add(MANIFEST, json.dumps(public, indent=1, sort_keys=True).encode())
        for folder, cache in sorted(caches.items()):
            for file in sorted(cache.iterdir()):
                if file.suffix in (".nbi", ".nbc"):
                    add(f"{folder}/{file.name}", file.read_bytes())
    return buffer.getvalue()


def build(out_dir: Path = BUNDLE_DIR) -> Path:
    """Compile a run's kernels for :data:`BUILD_CPU` and pack them into ``out_dir``.

    The compile runs in a child process (``NUMBA_CPU_NAME`` :data:`BUILD_CPU`,
    ``NUMBA_CPU_FEATURES`` empty, an empty ``NUMBA_CACHE_DIR``, the bundle left out); bundles
    of other numba or CPython versions in ``out_dir`` are removed (one bundle is shipped).

    Returns:
        The bundle written.

    Raises:
        FogsimError: The child failed (its standard error ends the message).
    """
    with tempfile.TemporaryDirectory(prefix="fogsim-kernels-") as scratch:
        manifest_path = Path(scratch) / MANIFEST
        env = {
            **os.environ,
            "NUMBA_CPU_NAME": BUILD_CPU,
            "NUMBA_CPU_FEATURES": "",
            "NUMBA_CACHE_DIR": str(Path(scratch) / "numba"),
            ENV_SWITCH: "0",
        }
        child = subprocess.run(
            [sys.executable, "-m", "fogsim.run.kernel_bundle", "--compile-into", manifest_path],
            env=env,
            capture_output=True,
            text=True,
        )
        if child.returncode != 0:
            raise FogsimError(f"compiling the kernel bundle failed: {child.stderr[-2000:]}")
        manifest = json.loads(manifest_path.read_text())
        caches = {key: Path(path) for key, path in manifest["caches"].items()}
        data = _tar_bytes(manifest, caches)
    target = out_dir / BundleTarget(**manifest["target"]).file_name
    write_bytes_atomic(target, data)
    for old in out_dir.glob("*.tar.xz"):
        if old != target:
            old.unlink()
    return target


def main(argv: list[str] | None = None) -> int:
    """``python -m fogsim.run.kernel_bundle [--out DIR]``: build the bundle."""
    parser = argparse.ArgumentParser(
        prog="python -m fogsim.run.kernel_bundle", description=main.__doc__
    )
    parser.add_argument("--out", type=Path, default=BUNDLE_DIR, help="folder of the bundle")
    parser.add_argument("--compile-into", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.compile_into is not None:
        _compile_into(args.compile_into)
        return 0
    start = time.perf_counter()
    path = build(args.out)
    size_mb = path.stat().st_size / 1e6
    print(f"{path} ({size_mb:.1f} MB) in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
