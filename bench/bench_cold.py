"""The first run on a fresh machine: where its compile time goes, and A/B of trees.

Usage:
    .venv/bin/python bench/bench_cold.py kernels [--tree DIR ...] [--repeats N] [--top K]
        [--group NAME ...]
    .venv/bin/python bench/bench_cold.py run [--tree DIR ...] [--repeats N] [--scenario NAME]
        [--bundle on|off|both]
    .venv/bin/python bench/bench_cold.py phases [--tree DIR ...] [--repeats N] [--group NAME ...]

Every measurement is a fresh ``python`` process run from a tree (``PYTHONPATH`` = the tree)
with an empty ``NUMBA_CACHE_DIR`` (and, for ``run``, an empty ``FOGSIM_CACHE``: the robot's
meshes are converted and the scene compiled too). With several trees the repeats are
interleaved (tree A, tree B, tree A, ...) so the load hits them alike; the load average
(``os.getloadavg``, 2 cores) is noted before and after each measurement. CPU times are the
measure on a shared machine: wall time only means something at load < 2.

- ``kernels``: the warm-up's groups compiled one after the other in one process
  (``fogsim.run.warmup._steps``, no helper process): per group its CPU time, per numba
  dispatcher its compile CPU time inclusive and exclusive of the kernels it compiles inside
  (``numba.core.event``'s ``numba:compile`` events, process CPU time), the kernels compiled
  for more than one signature (each extra one is wasted compile time) and the CPU time of the
  imports. ``--group NAME`` (repeatable) compiles only the named groups (each group's step
  calls only its own kernels), for a quicker A/B of one group. Printed per tree: the median
  over the repeats of every figure.
- ``phases``: the ``kernels`` compile (every group, or ``--group``), its CPU time split by
  numba's compiler phase, each counted exclusive of the compiles nested in it: numba's other
  passes (bytecode, IR-level inlining of ``inline="always"`` helpers, SSA, rewrites), type
  inference, lowering to LLVM IR (Python), LLVM's parse and function passes of each new module
  (``add_ir_module``), LLVM's link, module passes and machine code (``finalize``: a kernel's
  final module holds the optimised modules of every kernel it calls, linked in, optimised and
  code-generated again), the rest (caching, wrappers' set-up, dispatch); the share of the
  LLVM instructions going through ``finalize`` that are such linked copies of callees; and the
  compiles of numba's own overloads (``np.empty``, ...), which numba makes once per argument
  types and keywords at the call (``np.empty(n, np.int64)`` and ``np.empty(n, dtype=np.int64)``
  are two) and per flag set of the caller (numba's own implementations calling them, such as
  ``np.zeros``'s, carry other flags than the kernels): per overload, the compiles and the
  distinct signatures.
- ``run``: ``fogsim run SCENARIO --seed 1 --no-pictures --out TMP`` (progress shown, so the
  warm-up reports its groups): wall, CPU (user + sys of the process and its helper), each
  process's share (the main process's CPU is the critical path's bound when the load makes
  wall time meaningless) and the warm-up's ``compiled in`` line. ``--bundle on`` (a fresh
  machine: the kernels' shipped build installed, `fogsim.run.kernel_bundle`), ``off`` (every
  kernel compiled, ``FOGSIM_KERNEL_BUNDLE=0``) or ``both`` (the default, interleaved).
  ``kernels`` and ``phases`` always compile (the build left out).

Session 41 (AMD EPYC, 2 cores, load 1-2): ``run --repeats 3`` with the shipped build against
compiling, see README "Benchmarks".
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PYTHON = sys.executable

_PROFILE = r"""
import json, sys, time
start = time.process_time()
from numba.core import event
from numba.core.dispatcher import Dispatcher
stack, inclusive, exclusive = [], {}, {}
class Compiles(event.Listener):
    def on_start(self, ev):
        f = ev.data["dispatcher"].py_func
        stack.append([f"{f.__module__}.{f.__qualname__}", time.process_time(), 0.0])
    def on_end(self, ev):
        name, begun, inner = stack.pop()
        spent = time.process_time() - begun
        inclusive[name] = inclusive.get(name, 0.0) + spent
        exclusive[name] = exclusive.get(name, 0.0) + spent - inner
        if stack:
            stack[-1][2] += spent
event.register("numba:compile", Compiles())
from fogsim.config import RunParams
from fogsim.run import warmup
params = RunParams()
groups = {"imports": time.process_time() - start}
steps = warmup._steps(params)
chosen = sys.argv[1:]
for group in (g for g in warmup.GROUPS if not chosen or g.name in chosen):
    begun = time.process_time()
    steps[group]()
    groups[group.name] = time.process_time() - begun
if not chosen:
    begun = time.process_time()
    warmup._pipeline(warmup._floor_frames(), params)
    groups["pipeline (should compile nothing)"] = time.process_time() - begun
signatures = {}
for module in list(sys.modules.values()):
    for value in list(vars(module).values()) if module is not None else ():
        if isinstance(value, Dispatcher) and len(value.signatures) > 1:
            f = value.py_func
            signatures[f"{f.__module__}.{f.__qualname__}"] = [str(s) for s in value.signatures]
json.dump({"groups": groups, "inclusive": inclusive, "exclusive": exclusive,
           "signatures": signatures}, sys.stdout)
"""
"""The ``kernels`` child: compiles the warm-up's groups in turn, prints JSON."""


_PHASES = r"""
import json, sys, time
from collections import defaultdict
from numba.core import codegen, compiler_machinery, event
PHASES = {"nopython_type_inference": "type inference", "native_lowering": "lowering"}
stack, spent_in, instrumentation = [], defaultdict(float), [0.0]
overloads = defaultdict(lambda: [0, set(), 0.0])
sizes = {"own": 0, "linked": 0}
def push(label):
    stack.append([label, time.process_time(), 0.0])
def pop():
    label, begun, inner = stack.pop()
    spent = time.process_time() - begun
    spent_in[label] += spent - inner
    if stack:
        stack[-1][2] += spent
    return spent
class Compiles(event.Listener):
    def on_start(self, ev):
        push("other (caching, wrappers' set-up, dispatch)")
    def on_end(self, ev):
        spent = pop()
        f = ev.data["dispatcher"].py_func
        if f.__module__.startswith("numba."):
            entry = overloads[f"{f.__module__}.{f.__qualname__}"]
            entry[0] += 1
            entry[1].add(str(ev.data["args"]))
            entry[2] += spent
event.register("numba:compile", Compiles())
def timed(label, function):
    def wrapper(*args, **kwargs):
        push(label)
        try:
            return function(*args, **kwargs)
        finally:
            pop()
    return wrapper
run_pass = compiler_machinery.PassManager._runPass
def timed_pass(self, index, pss, state):
    label = PHASES.get(pss.name(), "other passes (bytecode, IR inlining, SSA, rewrites)")
    return timed(label, run_pass)(self, index, pss, state)
compiler_machinery.PassManager._runPass = timed_pass
def instructions(module):
    return sum(len(list(b.instructions)) for f in module.functions for b in f.blocks)
finalize = codegen.CPUCodeLibrary.finalize
def counted_finalize(self):
    begun = time.process_time()
    sizes["own"] += instructions(self._final_module)
    for library in set(self._linking_libraries):
        sizes["linked"] += instructions(library._get_module_for_linking())
    counting = time.process_time() - begun
    instrumentation[0] += counting
    if stack:
        stack[-1][1] += counting  # the count is no compile time
    return timed("LLVM link, module passes, machine code (finalize)", finalize)(self)
codegen.CPUCodeLibrary.finalize = counted_finalize
codegen.CPUCodeLibrary.add_ir_module = timed(
    "LLVM parse, function passes (add_ir_module)", codegen.CPUCodeLibrary.add_ir_module)
from fogsim.config import RunParams
from fogsim.run import warmup
params = RunParams()
steps = warmup._steps(params)
chosen = sys.argv[1:]
begun = time.process_time()
for group in (g for g in warmup.GROUPS if not chosen or g.name in chosen):
    steps[group]()
total = time.process_time() - begun - instrumentation[0]
json.dump({"total": total, "phases": spent_in, "sizes": sizes,
           "overloads": {k: [n, len(s), t] for k, (n, s, t) in overloads.items()}}, sys.stdout)
"""
"""The ``phases`` child: compiles the warm-up's groups with each compile phase timed, prints
JSON (the instruction count of each final module's own and linked code is not timed)."""


_RUN = r"""
import atexit, resource, sys
def cpu_shares():
    own = resource.getrusage(resource.RUSAGE_SELF)
    helper = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"bench_cold CPU main {own.ru_utime + own.ru_stime:.3f} "
          f"helper {helper.ru_utime + helper.ru_stime:.3f}", file=sys.stderr)
atexit.register(cpu_shares)  # registered first: runs last, after the command's own handlers
sys.argv = ["fogsim", *sys.argv[1:]]
from fogsim.cli import entry
entry()
"""
"""The ``run`` child: the ``fogsim`` command, printing at its exit the CPU time of its own
process (all threads) and of its children (the warm-up's helper process, waited for)."""


def load_note() -> str:
    """The 1, 5 and 15 minute load averages."""
    return "load " + "/".join(f"{x:.1f}" for x in os.getloadavg())


def _env(tree: Path, scratch: Path, bundle: bool = False) -> dict[str, str]:
    """The environment of a cold child of ``tree``: empty caches in ``scratch``; the kernels'
    shipped build (`fogsim.run.kernel_bundle`) installed only with ``bundle``."""
    (scratch / "numba").mkdir()
    (scratch / "fogsim").mkdir()
    return {
        **os.environ,
        "FOGSIM_KERNEL_BUNDLE": "1" if bundle else "0",
        "PYTHONPATH": str(tree),
        "NUMBA_CACHE_DIR": str(scratch / "numba"),
        "FOGSIM_CACHE": str(scratch / "fogsim"),
        "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
        "MESA_SHADER_CACHE_DISABLE": "true",
    }


def profile_kernels(tree: Path, groups: list[str], script: str = _PROFILE) -> dict:
    """One ``kernels`` (or, with ``script`` = `_PHASES`, ``phases``) measurement of ``tree``
    (the child's JSON): ``groups`` (names; none = every group, then, for ``kernels``, the
    pipeline that should find them all in the cache)."""
    with tempfile.TemporaryDirectory() as scratch:
        done = subprocess.run(
            [PYTHON, "-W", "ignore", "-c", script, *groups],
            env=_env(tree, Path(scratch)),
            cwd=tree,
            capture_output=True,
            text=True,
            check=False,
        )
    if done.returncode != 0:
        raise SystemExit(f"kernel profile of {tree} failed:\n{done.stderr}")
    return json.loads(done.stdout)


def cold_run(tree: Path, scenario: str, bundle: bool) -> tuple[float, float, str]:
    """One cold ``fogsim run`` of ``tree``: (wall [s], CPU [s], what it printed of its compile
    or the shipped build's install and each process's CPU time)."""
    with tempfile.TemporaryDirectory() as scratch:
        env = _env(tree, Path(scratch), bundle)
        out = str(Path(scratch) / "out")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        done = subprocess.run(
            [PYTHON, "-c", _RUN, "run", scenario, "--seed", "1", "--no-pictures", "--out", out],
            env=env,
            cwd=tree,
            capture_output=True,
            text=True,
            check=False,
        )
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"cold run of {tree} failed:\n{done.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = [
        line.strip()
        for line in done.stderr.splitlines()
        if " kernels ..." in line or "installed from the shipped build" in line
    ]
    compiled = [line.strip() for line in done.stderr.splitlines() if "compiled in" in line]
    shares = [line.strip() for line in done.stderr.splitlines() if "bench_cold CPU" in line]
    return wall, cpu, "; ".join(lines + compiled + shares)


def _median_table(runs: list[dict], key: str) -> dict[str, float]:
    """Median over ``runs`` of each name's figure under ``key`` (0 where a run lacks it)."""
    names = {name for run in runs for name in run[key]}
    return {name: statistics.median(run[key].get(name, 0.0) for run in runs) for name in names}


def kernels(trees: list[Path], repeats: int, top: int, groups: list[str]) -> None:
    """The ``kernels`` command: interleaved profiles, then a table per tree."""
    runs: dict[Path, list[dict]] = {tree: [] for tree in trees}
    for i in range(repeats):
        for tree in trees:
            note = load_note()
            runs[tree].append(profile_kernels(tree, groups))
            total = sum(runs[tree][-1]["groups"].values())
            print(f"  {tree} repeat {i + 1}: {total:.2f} s CPU ({note} -> {load_note()})")
    for tree in trees:
        groups = _median_table(runs[tree], "groups")
        inclusive = _median_table(runs[tree], "inclusive")
        exclusive = _median_table(runs[tree], "exclusive")
        print(f"\n{tree}: median of {repeats}, CPU seconds")
        for name, seconds in groups.items():
            print(f"  {name:40s} {seconds:6.2f}")
        print(f"  {'total':40s} {sum(groups.values()):6.2f}")
        print(f"  kernels by inclusive compile time (top {top}): inclusive / exclusive")
        for name in sorted(inclusive, key=inclusive.get, reverse=True)[:top]:
            print(f"    {inclusive[name]:6.2f} {exclusive[name]:6.2f}  {name}")
        print(f"  exclusive time of numba's own overloads: {_numba_share(exclusive):.2f} s")
        for name, signatures in runs[tree][-1]["signatures"].items():
            print(f"  {len(signatures)} signatures: {name}")
            for signature in signatures:
                print(f"      {signature}")


def phases(trees: list[Path], repeats: int, groups: list[str]) -> None:
    """The ``phases`` command: interleaved phase profiles, then medians per tree."""
    runs: dict[Path, list[dict]] = {tree: [] for tree in trees}
    for i in range(repeats):
        for tree in trees:
            note = load_note()
            runs[tree].append(profile_kernels(tree, groups, _PHASES))
            print(
                f"  {tree} repeat {i + 1}: {runs[tree][-1]['total']:.2f} s CPU "
                f"({note} -> {load_note()})"
            )
    for tree in trees:
        total = statistics.median(run["total"] for run in runs[tree])
        print(f"\n{tree}: median of {repeats}, CPU seconds, exclusive of nested compiles")
        spent = _median_table(runs[tree], "phases")
        for name in sorted(spent, key=spent.get, reverse=True):
            print(f"  {spent[name]:6.2f} {100 * spent[name] / total:4.0f} %  {name}")
        print(f"  {total:6.2f}        total")
        sizes = runs[tree][-1]["sizes"]
        linked = sizes["linked"] / max(sizes["own"] + sizes["linked"], 1)
        print(
            f"  LLVM instructions through finalize: {sizes['own']} own, {sizes['linked']} "
            f"linked copies of callees ({100 * linked:.0f} %)"
        )
        overloads = runs[tree][-1]["overloads"]
        seconds = sum(t for _, _, t in overloads.values())
        count = sum(n for n, _, _ in overloads.values())
        print(
            f"  numba's overloads: {count} compiles, {seconds:.2f} s inclusive; "
            "compiles / distinct signatures:"
        )
        for name, (n, distinct, t) in sorted(overloads.items(), key=lambda kv: -kv[1][2]):
            if n > 1:
                print(f"    {n:3d} / {distinct:3d} {t:5.2f} s  {name}")


def _numba_share(exclusive: dict[str, float]) -> float:
    """The part of the exclusive compile time spent in numba's own functions (overloads)."""
    return sum(seconds for name, seconds in exclusive.items() if name.startswith("numba."))


def runs(trees: list[Path], repeats: int, scenario: str, bundles: list[bool]) -> None:
    """The ``run`` command: interleaved cold runs (per tree, with and/or without the shipped
    build), then medians per tree and variant."""
    variants = [(tree, bundle) for tree in trees for bundle in bundles]
    results: dict[tuple[Path, bool], list[tuple[float, float]]] = {v: [] for v in variants}
    names = {True: "shipped build", False: "compiling"}
    for i in range(repeats):
        for tree, bundle in variants:
            note = load_note()
            wall, cpu, compiled = cold_run(tree, scenario, bundle)
            results[tree, bundle].append((wall, cpu))
            print(
                f"  {tree} ({names[bundle]}) repeat {i + 1}: wall {wall:.1f} s, CPU {cpu:.1f} s "
                f"({note} -> {load_note()}): {compiled}"
            )
    for tree, bundle in variants:
        walls = [wall for wall, _ in results[tree, bundle]]
        cpus = [cpu for _, cpu in results[tree, bundle]]
        print(
            f"{tree} ({names[bundle]}): cold run {scenario} median wall "
            f"{statistics.median(walls):.1f} s, CPU {statistics.median(cpus):.1f} s over {repeats}"
        )


def main() -> None:
    """Parse the command line and measure."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=("kernels", "run", "phases"))
    parser.add_argument(
        "--tree", type=Path, action="append", help="a source tree (repeatable; default: this)"
    )
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--top", type=int, default=25, help="kernels listed (kernels)")
    parser.add_argument("--scenario", default="stage", help="scenario of the run (run)")
    parser.add_argument(
        "--bundle",
        choices=("on", "off", "both"),
        default="both",
        help="run: with the kernels' shipped build installed (a fresh machine), without "
        "(every kernel compiled), or both, interleaved",
    )
    parser.add_argument(
        "--group",
        action="append",
        default=[],
        help="only this warm-up group (kernels, phases; repeatable)",
    )
    args = parser.parse_args()
    trees = [tree.resolve() for tree in args.tree or [ROOT]]
    print(f"{load_note()}, {os.cpu_count()} CPUs, python {PYTHON}")
    if args.command == "kernels":
        kernels(trees, args.repeats, args.top, args.group)
    elif args.command == "phases":
        phases(trees, args.repeats, args.group)
    else:
        bundles = {"on": [True], "off": [False], "both": [True, False]}[args.bundle]
        runs(trees, args.repeats, args.scenario, bundles)


if __name__ == "__main__":
    main()
