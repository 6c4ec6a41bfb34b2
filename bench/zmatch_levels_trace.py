"""Trace the frames whose z-match the nearest-level rule (``zmatch_nearest_level``) changes.

Usage:
    PYTHONPATH=. python bench/zmatch_levels_trace.py REC.npz [--set KEY=VALUE ...]

Replays the recording in line and, for every z-matched frame where the median's shift and the
nearest level's shift differ (the nearest level under the run's parameters, so
``--set zmatch_nearest_min_share=0`` shows every frame the level near 0 could take; whichever
the run applies, per ``--set``), prints one line: the
frame's place, the robot's true x, y [m], the shift each rule gives [mm] and its pairs, the
"true" shift (the mean of ``true − h`` over all matched pairs [mm]: what would put the frame's
floor points at their true heights), and for each of the two levels' pairs the mean map error
``Floor − true`` [mm], mean point error ``h − true`` [mm], and the true surfaces (heights [mm]:
count) they lie on.
"""

from __future__ import annotations

import argparse
import os
from collections import Counter

import numpy as np
from trace_replay import parse_overrides, replay_traced

os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recording")
    parser.add_argument("--set", action="append", default=[], help="KEY=VALUE override")
    args = parser.parse_args()

    from dataclasses import replace

    from fogsim.data.recording import load_recording
    from fogsim.world.truth import SceneTruth
    from mapper.mapper import FloorObstacleMapper
    from mapper.zmatch import match_z

    overrides = parse_overrides(args.set)
    rec = load_recording(args.recording)
    truth = SceneTruth.from_scenario(rec.scenario, 0.0)
    state = {"frame": None, "pos": -1}
    plain = FloorObstacleMapper.match_z

    def traced(self, points, floor_heights):
        result = plain(self, points, floor_heights)
        on = replace(self.params, zmatch_nearest_level=True)
        off = replace(self.params, zmatch_nearest_level=False)
        pts = np.asarray(points, dtype=np.float64)
        h = np.asarray(floor_heights, dtype=np.float64)
        m_on = match_z(pts, h, self._floor, self._geometry, on)
        m_off = match_z(pts, h, self._floor, self._geometry, off)
        if m_on.shift_m == m_off.shift_m:
            return result
        geo = self._geometry
        ox, oy = geo.origin_xy_m
        gx = np.floor((pts[:, 0] - ox) / geo.cell_m)
        gy = np.floor((pts[:, 1] - oy) / geo.cell_m)
        nx, ny = self._floor.shape
        ok = (gx >= 0) & (gx < nx) & (gy >= 0) & (gy < ny) & np.isfinite(h)
        idx = np.flatnonzero(ok)
        fl = self._floor[gx[idx].astype(int), gy[idx].astype(int)]
        good = np.isfinite(fl)
        idx, fl = idx[good], fl[good]
        res = fl - h[idx]
        true = truth.support_height_m(pts[idx, :2])
        eps = self.params.eps_m
        frame = state["frame"]
        xt, yt = frame.robot_pose_true[0], frame.robot_pose_true[1]
        line = (
            f"{state['pos']:4d} x={xt:5.2f} y={yt:5.2f} n={res.size:5d}"
            f" med={1e3 * m_off.shift_m:+6.1f}/{m_off.pairs:4d}"
            f" near={1e3 * m_on.shift_m:+6.1f}/{m_on.pairs:4d}"
            f" true={1e3 * np.mean(true - h[idx]):+6.1f}"
            f" used={'near' if result.shift_m == m_on.shift_m else 'med '}"
        )
        for name, level in (("MED", m_off.shift_m), ("NEAR", m_on.shift_m)):
            sel = np.abs(res - level) <= eps
            map_err = 1e3 * np.mean(fl[sel] - true[sel])
            pt_err = 1e3 * np.mean(h[idx][sel] - true[sel])
            surf = Counter(np.round(1e3 * true[sel]).astype(int).tolist())
            top = ",".join(f"{k}:{v}" for k, v in sorted(surf.items(), key=lambda kv: -kv[1])[:4])
            xs = pts[idx][sel]
            line += (
                f" | {name} map={map_err:+5.1f} pt={pt_err:+5.1f}"
                f" r={1e3 * np.hypot(xs[:, 0] - xt, xs[:, 1] - yt).mean():4.0f}mm"
                f" surf[{top}]"
            )
        print(line, flush=True)
        return result

    FloorObstacleMapper.match_z = traced

    def traced_map(self, job, plain_map):
        state["frame"] = job.data.frame
        state["pos"] = job.data.position
        return plain_map(self, job)

    replay_traced(rec, overrides, traced_map)


if __name__ == "__main__":
    main()
