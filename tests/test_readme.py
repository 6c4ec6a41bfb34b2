"""Every code block of README.md runs as printed (or is checked as what it is).

The blocks are taken from the README in order and run in one temporary folder, as a new user
would run them one after the other from the checkout's root (``scenarios/`` is linked in):

* ```` ```python ```` blocks are executed as printed;
* ```` ```bash ```` blocks are split into commands; every ``fogsim ...`` command runs through
  :func:`fogsim.cli.main` with its arguments as printed, except for the documented speed-ups of
  :data:`SPEED_UPS` (each keeps what the command exercises); commands that are not ``fogsim``
  (set-up, cluster, viewer) are listed in :data:`NOT_RUN` with the reason and what checks them
  instead — any other command fails the test;
* ```` ```toml ```` blocks are parsed with tomllib and their tables built into the parameter
  dataclasses; ```` ```text ```` blocks are output samples, checked against the output they
  show. An untagged block fails the test.
"""

import contextlib
import importlib.util
import io
import re
import shlex
import tomllib
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import tomli_w

from fogsim.cli import main
from fogsim.eval.maps import load_maps
from fogsim.run.targets import load_targets
from mapper import MapperParams, SegmentationParams

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

SPEED_UPS = {
    "fogsim tune scenarios --quick": (
        {"--trials": "2", "--workers": "1"},
        "40 trials are 40 replays of the same recordings; 2 trials still record the quick "
        "subset, score the defaults and one sampled trial and write every output (the table's "
        "top 2 rows are the sample's). One worker: the process pool is tests/test_tune.py's.",
    ),
    "fogsim tune stage box_removal": (
        {"--trials": "1", "--workers": "1"},
        "100 trials of two full recordings take minutes; 1 trial still simulates and records "
        "stage and box_removal by name and scores the defaults' trial.",
    ),
}
"""Command prefix → (replaced option values, reason)."""

NOT_RUN = {
    "python3 -m venv .venv": "the set-up; tests/test_install.py installs fogsim in a fresh venv",
    ".venv/bin/pip install -q -e .": "the set-up; tests/test_install.py installs the package",
    ".venv/bin/pip install -q -e .[dev]": "the set-up of the test suite this test runs in",
    ".venv/bin/python -m pytest -q -n 2": "the test suite itself (this test is part of it)",
    "python -m mujoco.viewer --mjcf scene.xml": (
        "needs a display; the test loads scene.xml with mujoco.MjModel.from_xml_path, as the "
        "viewer does first"
    ),
    "pip install fogsim[ray]": "installs on every machine of a cluster",
    "ray start --head --port=6379": "starts a Ray cluster (a machine of its own)",
    "ray start --address=HEAD_IP:6379": "joins a Ray cluster from another machine",
    (
        "fogsim tune scenarios --quick --param p_occ=0.55:0.95 --trials 200 --ray HEAD_IP:6379"
        " --out runs/tune-ray"
    ): ("needs the cluster above; tests/test_tune.py runs tune on a local Ray instance"),
}
"""Commands (as printed, options with their values) that this test does not run, and why."""

BAG_DEPTH_TOPIC = "/head/depth/image_rect_raw"
"""The depth topic of the README's ``robot_walk/`` bag, which the test writes first."""


@dataclass(frozen=True)
class Block:
    line: int
    lang: str
    text: str


def readme_blocks() -> list[Block]:
    """Every fenced block of the README with its language and first line number."""
    lines = README.read_text(encoding="utf-8").splitlines()
    blocks, start = [], None
    for number, line in enumerate(lines, 1):
        fence = re.fullmatch(r"\s*```(\w*)", line)
        if fence is None:
            continue
        if start is None:
            start, lang, indent = number, fence.group(1), line.index("`")
        else:
            body = [text[indent:] for text in lines[start : number - 1]]
            blocks.append(Block(start, lang, "\n".join(body) + "\n"))
            start = None
    assert start is None, f"README.md:{start}: unclosed code block"
    return blocks


def commands(block: Block) -> list[list[str]]:
    """The shell commands of a bash block: lines joined, comments dropped, split at ``&&``."""
    out = []
    for raw in block.text.replace("\\\n", " ").splitlines():
        for part in raw.split("&&"):
            argv = shlex.split(part, comments=True)
            if argv:
                out.append(argv)
    return out


def printed(argv: list[str]) -> str:
    return " ".join(argv)


def fogsim_arguments(argv: list[str]) -> list[str] | None:
    """The arguments of a ``fogsim`` command (also ``.venv/bin/fogsim``), else None."""
    if Path(argv[0]).name != "fogsim":
        return None
    args = list(argv[1:])
    command = "fogsim " + printed(args)
    for prefix, (options, _reason) in SPEED_UPS.items():
        if command.startswith(prefix):
            for option, value in options.items():
                args[args.index(option) + 1] = value
    return args


def run_python(block: Block, namespace_out: dict | None = None) -> str:
    out = io.StringIO()
    namespace: dict = {}
    with contextlib.redirect_stdout(out):
        exec(compile(block.text, f"{README}:{block.line}", "exec"), namespace)
    if namespace_out is not None:
        namespace_out.update(namespace)
    return out.getvalue()


def write_readme_bag(path: Path) -> None:
    spec = importlib.util.spec_from_file_location("real_data", ROOT / "examples" / "real_data.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    example.write_bag(path, BAG_DEPTH_TOPIC)


def test_every_readme_block_runs_in_order(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    write_readme_bag(tmp_path / "robot_walk")
    ran, toml_blocks, output_blocks = [], [], []
    for block in readme_blocks():
        where = f"README.md:{block.line}"
        if block.lang == "python":
            run_python(block)
        elif block.lang == "bash":
            for argv in commands(block):
                if printed(argv) in NOT_RUN:
                    continue
                args = fogsim_arguments(argv)
                assert args is not None, f"{where}: `{printed(argv)}` is neither run nor listed"
                code = main(args)
                assert code == 0, f"{where}: `{printed(argv)}` exit {code}: {capsys.readouterr()}"
                ran.append(printed(argv))
        elif block.lang == "toml":
            toml_blocks.append(tomllib.loads(block.text))
        else:
            assert block.lang == "text", f"{where}: untagged or unknown language {block.lang!r}"
            output_blocks.append(block)
    assert len(ran) >= 8
    # the outputs the README names are there
    for path in (
        "runs/stage/report.json",
        "runs/stage/maps.npz",
        "runs/stage/fog_map.png",
        "runs/stage/difference.png",
        "runs/stage/fig3_panels.png",
        "rec/stage.npz",
        "runs/stage_p08/report.json",
        "runs/tune/best_params.toml",
        "runs/tune/trials.md",
        "runs/tune/summary.json",
        "runs/tune/tune.db",
        "rec/walk.npz",
        "runs/walk/maps.npz",
        "runs/walk_fog/metadata.yaml",
        "mine.npz",
    ):
        assert (tmp_path / path).stat().st_size > 0, path
    assert mujoco.MjModel.from_xml_path("scene.xml").nbody > 10  # what the viewer opens
    # "`fogsim run --replay mine.npz` maps it": the minimal file's floor, 0.9 m below the camera
    assert main(["run", "--replay", "mine.npz", "--out", "runs/mine", "--quiet"]) == 0
    mine = load_maps(tmp_path / "runs/mine/maps.npz")
    floor = mine.fog_types == 1
    assert floor.sum() >= 20 and np.allclose(mine.fog_heights_m[floor], 0.0, atol=0.002)
    # the targets sample is a valid targets file (`fogsim suite --targets`)
    targets = [block for block in toml_blocks if block.get("format") == "fogsim-targets"]
    assert len(targets) == 1
    (tmp_path / "targets.toml").write_text(tomli_w.dumps(targets[0]))
    assert load_targets(tmp_path / "targets.toml").target[0].worst == 1.5
    # the other TOML sample is the tune's best_params.toml: same tables and keys, valid values
    (sample,) = [block for block in toml_blocks if block.get("format") != "fogsim-targets"]
    written = tomllib.loads((tmp_path / "runs/tune/best_params.toml").read_text())
    assert {k: sorted(v) for k, v in sample.items()} == {k: sorted(v) for k, v in written.items()}
    MapperParams(**sample["mapper"])
    SegmentationParams(**sample["segmentation"])
    # the output sample is trials.md's table: same header, rows of the same width
    (table,) = output_blocks
    trials = (tmp_path / "runs/tune/trials.md").read_text().splitlines()
    sample_rows = table.text.splitlines()
    assert sample_rows[0] in trials, "README's trials.md header differs from the tune's"
    assert all(row.count("|") == sample_rows[0].count("|") for row in sample_rows)


def test_the_mapper_library_example_finds_the_floor_at_zero():
    (block,) = [b for b in readme_blocks() if "FloorObstacleMapper(params)" in b.text]
    namespace: dict = {}
    out = run_python(block, namespace)
    floor = namespace["types"] == namespace["CellType"].FLOOR
    assert floor.sum() > 1000  # the floor in view, 4 cm cells
    assert abs(float(namespace["np"].median(namespace["heights"][floor]))) < 1e-3
    assert "floor cells, median height 0.0000 m" in out


def test_every_exception_is_a_readme_command():
    """A speed-up or a not-run entry that matches nothing in the README is stale."""
    printed_commands = [
        printed(argv)
        for block in readme_blocks()
        if block.lang == "bash"
        for argv in commands(block)
    ]
    for command in NOT_RUN:
        assert command in printed_commands, f"NOT_RUN: {command!r} is not in the README"
    for prefix in SPEED_UPS:
        assert any(c.startswith(prefix) for c in printed_commands), f"SPEED_UPS: {prefix!r}"
