"""Check that two trees segment recorded frames identically, bit for bit.

Replays each recording (``fogsim.run.runner.replay_report``, no pictures) once from every tree,
in a child process with ``PYTHONPATH`` = the tree, and records for every ``segment_depth`` call
(the pipeline's exact arguments) a SHA-256 digest of each field of its `SegmentationResult`
(arrays: dtype, shape and bytes; nested tables field by field), and of the tilt-filtered result
the run maps. Prints, per recording, the
frames compared and every frame and field that differ; exit 1 if any does.

Run: ``.venv/bin/python bench/segmentation_identity.py --reference /work/wt-base
[--tree THIS_TREE] [RECORDING.npz ...]`` (default recordings: stage depth seed 1 and stereo
stage seed 5, 832 frames each).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_RECORDINGS = ("/work/rec/stage_depth_s1.npz", "/work/rec/stage_stereo_s5.npz")


def field_digests(value: object, prefix: str = "") -> dict[str, str]:
    """Digest of every field of a (nested) dataclass: name → SHA-256 (first 16 hex digits)."""
    import numpy as np

    out: dict[str, str] = {}
    if dataclasses.is_dataclass(value):
        for field in dataclasses.fields(value):
            out.update(field_digests(getattr(value, field.name), f"{prefix}{field.name}."))
        return out
    digest = hashlib.sha256()
    if isinstance(value, np.ndarray):
        digest.update(f"{value.dtype.str}{value.shape}".encode())
        digest.update(np.ascontiguousarray(value).tobytes())
    else:
        digest.update(f"{type(value).__name__}:{value!r}".encode())
    out[prefix.rstrip(".")] = digest.hexdigest()[:16]
    return out


def digest_recording(path: str) -> list[dict[str, str]]:
    """Replay ``path`` and digest every segmentation result, in call order, and the result the
    run maps after the tilt filter (fields ``filtered.*``: `mapper.tilt_filter.apply_tilt`)."""
    from fogsim.data.recording import load_recording
    from fogsim.mapping import segmenter
    from fogsim.run.runner import replay_report
    from mapper.segmentation import segment_depth

    digests: list[dict[str, str]] = []
    unfiltered = segmenter.FrameSegmenter.__call__

    def filtered(self, frame):
        result = unfiltered(self, frame)
        digests[-1].update(field_digests(result, "filtered."))
        return result

    segmenter.FrameSegmenter.__call__ = filtered

    def segment(depth_m, intrinsics, transform_camera_to_robot, params):
        result = segment_depth(depth_m, intrinsics, transform_camera_to_robot, params)
        digests.append(field_digests(result))
        return result

    replay_report(load_recording(path), segment=segment, segment_ahead=False)
    return digests


def run_child(tree: Path, recordings: list[str], out: Path) -> None:
    """Digest the recordings with ``tree``'s code in a child process into ``out`` (JSON)."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MUJOCO_GL": "egl"}
    command = [sys.executable, str(Path(__file__).resolve()), "--child", str(out), *recordings]
    subprocess.run(command, env=env, cwd=tree, check=True)


def compare(reference: list[dict[str, str]], candidate: list[dict[str, str]]) -> list[str]:
    """The differences of two digest lists, one line each (empty: identical)."""
    if len(reference) != len(candidate):
        return [f"frame counts differ: {len(reference)} vs {len(candidate)}"]
    lines = []
    for frame, (a, b) in enumerate(zip(reference, candidate, strict=True)):
        names = sorted(set(a) | set(b))
        differing = [name for name in names if a.get(name) != b.get(name)]
        if differing:
            lines.append(f"frame {frame}: {', '.join(differing)}")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="*", default=list(DEFAULT_RECORDINGS))
    parser.add_argument("--reference", type=Path, help="the tree to compare with")
    parser.add_argument("--tree", type=Path, default=ROOT, help="the tree checked (this one)")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        digests = {path: digest_recording(path) for path in args.recordings}
        args.child.write_text(json.dumps(digests))
        return 0
    if args.reference is None:
        parser.error("--reference TREE is required")
    with tempfile.TemporaryDirectory() as folder:
        outputs = {}
        for name, tree in (("reference", args.reference), ("tree", args.tree)):
            outputs[name] = Path(folder) / f"{name}.json"
            run_child(tree.resolve(), args.recordings, outputs[name])
        reference = json.loads(outputs["reference"].read_text())
        candidate = json.loads(outputs["tree"].read_text())
    failed = False
    for path in args.recordings:
        lines = compare(reference[path], candidate[path])
        verdict = "identical" if not lines else f"{len(lines)} frames differ"
        print(f"{path}: {len(reference[path])} frames, {verdict}")
        for line in lines[:20]:
            print(f"  {line}")
        failed |= bool(lines)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
