"""Tests of fogsim tune: search space, objective, the study loop, resume, pool vs Ray."""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from processes import kill_driver, process_alive, process_children
from report_factory import class_scores, event, make_report, row, safety_with

from fogsim.errors import FogsimError
from fogsim.tune import (
    ParamSpec,
    SamplerKind,
    TuneConfig,
    best_params_toml,
    tune,
)
from fogsim.tune.objective import (
    TERM_NAMES,
    ObjectiveTerms,
    ObjectiveWeights,
    SuiteEntry,
    objective_terms,
    score_parameters,
)

NAMES = ("p_occ", "eps_m", "nu", "seg.min_points")
NAMES_TUNABLE = ("p_occ", "nx", "cell_m", "seg.fill_passes", "seg.min_depth_m")
DEFAULTS = {"p_occ": 0.6, "eps_m": 0.03, "seg.min_points": 20}
TESTS_DIR = Path(__file__).resolve().parent

# ----------------------------------------------------------------------------- stand-ins


@dataclass(frozen=True)
class FakeRecording:
    """Stands in for fogsim.data.recording.Recording: the report function reads ``offset_mm``."""

    offset_mm: float
    delay_s: float = 0.0
    frames: tuple[int, ...] = (0, 1, 2)
    has_truth: bool = True


def fake_report(recording, overrides):
    """A report whose objective is known: Table I error minimal at p_occ=0.8, eps_m=0.01."""
    if recording.delay_s:
        time.sleep(recording.delay_s)
    p_occ = overrides["p_occ"]
    eps_m = overrides["eps_m"]
    min_points = overrides.get("seg.min_points", 20)
    error_mm = 100.0 * (p_occ - 0.8) ** 2 + 1000.0 * abs(eps_m - 0.01) + recording.offset_mm
    correct = 100 - abs(min_points - 30) // 5
    return make_report(
        [row("ground", error_mm)],
        region=125,
        seen=100,
        correct=correct,
        events=[event("box", 25 if p_occ < 0.9 else None)],
    )


def fake_suite(delay_s: float = 0.0) -> list[SuiteEntry]:
    return [
        SuiteEntry("stage", FakeRecording(1.0, delay_s), frame_rate_hz=12.5),
        SuiteEntry("box_removal", FakeRecording(2.0, delay_s), frame_rate_hz=12.5),
    ]


def specs() -> tuple[ParamSpec, ...]:
    return (
        ParamSpec.parse("p_occ=0.55:0.95", NAMES),
        ParamSpec.parse("eps_m=0.005:0.05:log", NAMES),
        ParamSpec.parse("seg.min_points=10:50", NAMES),
    )


def config(out: Path, trials: int = 12, pictures: bool = False, **kwargs) -> TuneConfig:
    return TuneConfig(
        params=specs(), trials=trials, out_dir=out, progress=False, pictures=pictures, **kwargs
    )


def expected_objective(p_occ: float, eps_m: float, min_points: int) -> float:
    """Hand-computed objective of fake_report, mean over the suite (offsets 1 and 2 mm)."""
    wrong_pct = float(abs(min_points - 30) // 5)
    clearing_s = 2.0 if p_occ < 0.9 else 10.0
    base = 100.0 * (p_occ - 0.8) ** 2 + 1000.0 * abs(eps_m - 0.01)
    return base + 1.5 + wrong_pct + 0.1 * 20.0 + clearing_s  # 20 % of the region unknown


# ----------------------------------------------------------------------------- search space


def test_param_spec_parses_float_log_and_int_ranges():
    p = ParamSpec.parse("p_occ=0.55:0.95", NAMES)
    assert (p.name, p.low, p.high, p.log, p.integer) == ("p_occ", 0.55, 0.95, False, False)
    e = ParamSpec.parse("eps_m=0.005:0.05:log", NAMES)
    assert e.log and not e.integer
    n = ParamSpec.parse("seg.min_points=10:50", NAMES)
    assert n.integer and (n.low, n.high) == (10, 50)
    assert ParamSpec.parse(n.to_text(), NAMES) == n
    assert ParamSpec.parse(e.to_text(), NAMES) == e
    assert e.grid(3) == pytest.approx([0.005, math.sqrt(0.005 * 0.05), 0.05], rel=1e-12)
    assert n.grid(3) == [10, 30, 50]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("p_occ", "must look like name=lo:hi"),
        ("p_occ=0.5", "must look like name=lo:hi"),
        ("p_occ=0.5:0.9:lin", "must look like name=lo:hi"),
        ("bogus=0:1", "unknown parameter 'bogus'"),
        ("p_occ=a:0.9", "lower bound 'a' is not a number"),
        ("p_occ=0.9:0.5", "low < high"),
        ("eps_m=0:0.05:log", "log range needs low > 0"),
        ("p_occ=0.5:inf", "must be finite"),
    ],
)
def test_param_spec_rejects_bad_input_naming_the_problem(text, message):
    with pytest.raises(FogsimError, match=message):
        ParamSpec.parse(text, NAMES)


def test_param_names_come_from_the_mapper_parameter_classes():
    from fogsim.tune import parameter_defaults, tunable_parameter_names
    from mapper.params import MapperParams
    from mapper.segmentation import SegmentationParams

    names = tunable_parameter_names()
    for name in ("p_occ", "eps_m", "nu", "delta_m", "p_sense", "p_min", "p_max"):
        assert name in names
    assert "seg.min_plane_pixels" in names
    assert "seg.correct_tilt" not in names  # booleans are switches, not tunable ranges
    defaults = parameter_defaults(["p_occ", "seg.min_plane_pixels"])
    assert defaults == {
        "p_occ": MapperParams().p_occ,
        "seg.min_plane_pixels": SegmentationParams().min_plane_pixels,
    }
    with pytest.raises(FogsimError, match="not tunable parameters: \\['bogus'\\]"):
        parameter_defaults(["bogus"])
    with pytest.raises(FogsimError, match="unknown parameter 'p_ooc'"):
        ParamSpec.parse("p_ooc=0.5:0.9")


def test_config_rejects_duplicates_and_bad_counts(tmp_path):
    p = ParamSpec.parse("p_occ=0.55:0.95", NAMES)
    with pytest.raises(FogsimError, match="more than once"):
        TuneConfig(params=(p, p), trials=3, out_dir=tmp_path)
    with pytest.raises(FogsimError, match="trials must be >= 1"):
        TuneConfig(params=(p,), trials=0, out_dir=tmp_path)
    with pytest.raises(FogsimError, match="at least one --param"):
        TuneConfig(params=(), trials=3, out_dir=tmp_path)
    with pytest.raises(ValueError, match="'anneal' is not a valid SamplerKind"):
        TuneConfig(params=(p,), trials=3, out_dir=tmp_path, sampler="anneal")


# ----------------------------------------------------------------------------- objective


def test_objective_terms_of_a_hand_made_report():
    report = make_report(
        [
            row("ground", -1.0),
            row("sill", 3.0),
            row("step_3", None, surface_cells=9),  # charged 50 mm
            row("platform", None, surface_cells=0),  # never in view
        ],
        region=5000,  # most of the scored area is never in view: it does not count
        in_view=500,
        seen=400,
        in_view_seen=400,
        correct=390,
        obstacle=class_scores(truth_seen=20, labelled=10, true_positive=8),  # 60 % missed
        obstacle_truth_cells=30,
        safety=safety_with(12, on_obstacle=2),
        events=[event("a", 25), event("b", None)],
    )
    weights = ObjectiveWeights()
    terms = objective_terms(report, weights, frame_rate_hz=12.5)
    assert terms.table1_mm == pytest.approx((1 + 3 + 50) / 3, abs=1e-12)
    assert terms.cell_error_pct == pytest.approx(2.5, abs=1e-12)
    assert terms.unknown_pct == pytest.approx(20.0, abs=1e-12)
    assert terms.obstacle_missed_pct == pytest.approx(60.0, abs=1e-12)
    assert terms.unsafe_cells == 12
    assert terms.clearing_s == pytest.approx((2.0 + 10.0) / 2, abs=1e-12)
    assert terms.table1_rows == 3 and terms.seen_cells == 400
    assert terms.value(weights) == pytest.approx(18.0 + 2.5 + 2.0 + 3.0 + 0.12 + 6.0, abs=1e-12)
    heavy = ObjectiveWeights(
        table1_mm=2.0,
        cell_error_pct=0.0,
        unknown_pct=0.0,
        obstacle_missed_pct=0.0,
        unsafe_cells=1.0,
        clearing_s=0.5,
    )
    assert terms.value(heavy) == pytest.approx(36.0 + 12.0 + 3.0, abs=1e-12)


def test_obstacles_the_fog_never_labels_are_all_missed_and_no_obstacle_is_no_term():
    never = make_report(
        [row("ground", 0.0)], region=10, seen=10, correct=10, obstacle_truth_cells=5
    )  # 5 true obstacle cells, all left unknown
    assert objective_terms(never, ObjectiveWeights(), 12.5).obstacle_missed_pct == 100.0
    none = make_report([row("ground", 0.0)], region=10, seen=10, correct=10)
    terms = objective_terms(none, ObjectiveWeights(), 12.5)
    assert terms.obstacle_missed_pct is None
    assert terms.value(ObjectiveWeights(obstacle_missed_pct=100.0)) == 0.0


def test_objective_without_events_has_no_clearing_term():
    terms = ObjectiveTerms(
        table1_mm=2.0,
        cell_error_pct=1.0,
        unknown_pct=10.0,
        obstacle_missed_pct=None,
        unsafe_cells=0,
        clearing_s=None,
        table1_rows=1,
        seen_cells=10,
    )
    assert terms.value(ObjectiveWeights(clearing_s=100.0)) == 4.0


def test_weights_from_assignments_and_their_errors():
    weights = ObjectiveWeights.from_assignments(["table1_mm=2", "clearing_s=0.5"])
    assert (weights.table1_mm, weights.cell_error_pct, weights.clearing_s) == (2.0, 1.0, 0.5)
    with pytest.raises(FogsimError, match="unknown objective weight 'speed'"):
        ObjectiveWeights.from_assignments(["speed=1"])
    with pytest.raises(FogsimError, match="must be finite and >= 0"):
        ObjectiveWeights(table1_mm=-1.0)
    zero = dict.fromkeys(TERM_NAMES, 0.0)
    with pytest.raises(FogsimError, match="all 0"):
        ObjectiveWeights(**zero)
    assert ObjectiveWeights(**{**zero, "unsafe_cells": 1.0}).unsafe_cells == 1.0
    with pytest.raises(FogsimError, match="must look like name=value"):
        ObjectiveWeights.from_assignments(["table1_mm"])


def test_score_parameters_is_the_mean_over_the_suite():
    score = score_parameters(
        fake_suite(),
        {"p_occ": 0.7, "eps_m": 0.02, "seg.min_points": 40},
        ObjectiveWeights(),
        fake_report,
    )
    assert score.objective == pytest.approx(expected_objective(0.7, 0.02, 40), abs=1e-9)
    assert set(score.terms) == {"stage", "box_removal"}
    assert score.terms["box_removal"]["table1_mm"] - score.terms["stage"]["table1_mm"] == (
        pytest.approx(1.0, abs=1e-12)
    )
    assert score.report_s >= 0 and score.objective_s >= 0


# ----------------------------------------------------------------------------- the study


def read_trials(db: Path) -> list[tuple[int, str]]:
    with sqlite3.connect(db) as con:
        return con.execute("SELECT number, state FROM trials ORDER BY number").fetchall()


def test_tune_beats_defaults_and_writes_results(tmp_path):
    import matplotlib

    style = {k: matplotlib.rcParams[k] for k in ("axes.facecolor", "axes.grid", "font.size")}
    result = tune(
        config(tmp_path, trials=25, seed=3, pictures=True),
        fake_suite(),
        report_function=fake_report,
        defaults=DEFAULTS,
    )
    defaults_value = expected_objective(0.6, 0.03, 20)
    assert result.defaults_value == pytest.approx(defaults_value, abs=1e-9)
    assert result.best_value <= result.defaults_value
    assert result.best_value < defaults_value - 10.0  # the search really improved on them
    assert result.complete == 25
    p = result.best_params
    assert result.best_value == pytest.approx(
        expected_objective(p["p_occ"], p["eps_m"], p["seg.min_points"]), abs=1e-9
    )
    # Results: a pasteable TOML block, the table, one picture per parameter, a summary.
    block = tomllib.loads((tmp_path / "best_params.toml").read_text())
    assert block["mapper"] == {"p_occ": p["p_occ"], "eps_m": p["eps_m"]}
    assert block["segmentation"] == {"min_points": p["seg.min_points"]}
    assert isinstance(block["segmentation"]["min_points"], int)
    table = (tmp_path / "trials.md").read_text()
    assert "(defaults)" in table or "defaults" in (tmp_path / "summary.json").read_text()
    assert len([ln for ln in table.splitlines() if ln.startswith("| ")]) == 1 + 10
    for name in ("p_occ", "eps_m", "seg.min_points"):
        png = tmp_path / f"objective_{name}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Optuna's slice plot switches pyplot to ggplot; the pictures must not leave that behind.
    assert {k: matplotlib.rcParams[k] for k in style} == style
    assert [n for n, _ in read_trials(tmp_path / "tune.db")] == list(range(25))


def test_same_seed_same_trials_bit_for_bit(tmp_path):
    runs = []
    for name in ("a", "b"):
        tune(
            config(tmp_path / name, trials=10, seed=7),
            fake_suite(),
            report_function=fake_report,
            defaults=DEFAULTS,
        )
        import optuna

        study = optuna.load_study(
            study_name="fogsim-tune", storage=f"sqlite:///{tmp_path / name / 'tune.db'}"
        )
        runs.append([(t.number, t.params, t.value) for t in study.trials])
    assert runs[0] == runs[1]
    assert runs[0][0][1] == DEFAULTS  # the defaults are trial 0


def test_grid_sampler_covers_the_grid_and_the_defaults(tmp_path):
    cfg = TuneConfig(
        params=specs()[:2],
        trials=100,
        out_dir=tmp_path,
        sampler=SamplerKind.GRID,
        grid_points=2,
        progress=False,
        pictures=False,
    )
    result = tune(cfg, fake_suite(), report_function=fake_report, defaults=DEFAULTS)
    assert result.complete == 9  # (2 grid values + the default) per axis, squared
    # Hand-computed over {0.55, 0.6, 0.95} x {0.005, 0.03, 0.05}: p_occ 0.95 never clears.
    assert result.best_params == pytest.approx({"p_occ": 0.6, "eps_m": 0.005}, rel=1e-12)


def test_best_params_toml_block():
    text = best_params_toml({"p_occ": 0.7, "seg.min_points": 12.0}, specs(), "tuned\nsecond line")
    assert text.splitlines()[:2] == ["# tuned", "# second line"]
    assert tomllib.loads(text) == {"mapper": {"p_occ": 0.7}, "segmentation": {"min_points": 12}}


def test_best_params_toml_text_mapper_first_floats_by_repr_integers_whole():
    values = {"seg.min_points": 12.0, "p_occ": 0.7, "eps_m": 1e-05}
    assert best_params_toml(values, specs(), "c") == (
        "# c\n[mapper]\np_occ = 0.7\neps_m = 1e-05\n\n[segmentation]\nmin_points = 12\n"
    )
    assert best_params_toml({"seg.min_points": 12}, specs(), "c") == (
        "# c\n[segmentation]\nmin_points = 12\n"
    )


def test_override_keys_split_into_scenario_tables():
    from fogsim.config import split_override_key

    assert split_override_key("p_occ") == ("mapper", "p_occ")
    assert split_override_key("seg.min_plane_pixels") == ("segmentation", "min_plane_pixels")


def test_a_trial_dead_before_its_heartbeat_is_failed_and_retried(tmp_path):
    import warnings

    import optuna
    from optuna.trial import TrialState

    from fogsim.tune.recovery import TrialHeartbeat, fail_dead_trials, open_storage

    cfg = TuneConfig(params=specs(), trials=3, out_dir=tmp_path, heartbeat_s=1, grace_s=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.filterwarnings("ignore", message="Heartbeat of storage", category=UserWarning)
        storage = open_storage(cfg)
        study = optuna.create_study(storage=storage, study_name=cfg.study_name)
        dead = study.ask()  # its run was killed here: no heartbeat, no parameters
        live = study.ask()
        heartbeat = TrialHeartbeat(storage, cfg.study_name, cfg.heartbeat_s)
        try:
            heartbeat.add(live.number)
            specs()[0].suggest(live)
            fail_dead_trials(study, storage, grace_s=60.0)  # not older than the grace: kept
            assert [t.state for t in study.trials] == [TrialState.RUNNING] * 2
            fail_dead_trials(study, storage, grace_s=0.0)
        finally:
            heartbeat.close()
    trials = study.trials
    assert trials[dead.number].state == TrialState.FAIL
    assert trials[live.number].state == TrialState.RUNNING  # fresh heartbeat, has parameters
    retries = [t for t in trials if t.system_attrs.get("failed_trial") == dead.number]
    assert [t.state for t in retries] == [TrialState.WAITING]


def test_resume_refuses_a_study_made_with_other_settings(tmp_path):
    tune(config(tmp_path, trials=3), fake_suite(), report_function=fake_report, defaults=DEFAULTS)
    other = TuneConfig(
        params=specs(),
        trials=3,
        out_dir=tmp_path,
        progress=False,
        weights=ObjectiveWeights(table1_mm=2.0),
    )
    with pytest.raises(FogsimError, match="made with other weights"):
        tune(other, fake_suite(), report_function=fake_report, defaults=DEFAULTS)


def test_failing_trials_are_recorded_and_counted(tmp_path):
    def broken(recording, overrides):
        if overrides["p_occ"] > 0.75:
            raise RuntimeError("mapper exploded")
        return fake_report(recording, overrides)

    result = tune(
        config(tmp_path, trials=10, seed=1), fake_suite(), report_function=broken, defaults=DEFAULTS
    )
    assert result.trials == 10 and 1 <= result.complete < 10
    states = [s for _, s in read_trials(tmp_path / "tune.db")]
    assert states.count("FAIL") == 10 - result.complete

    def always_broken(recording, overrides):
        raise RuntimeError("no mapper today")

    message = r"first 4 trials of this run all failed.*no mapper today"
    with pytest.raises(FogsimError, match=message):
        tune(config(tmp_path / "broken", trials=50), fake_suite(), report_function=always_broken,
             defaults=DEFAULTS)  # fmt: skip
    assert len(read_trials(tmp_path / "broken" / "tune.db")) == 4


KILL_SCRIPT = textwrap.dedent(
    """
    import sys
    sys.path[:0] = [{root!r}, {tests!r}]
    from pathlib import Path
    from fogsim.tune import TuneConfig, tune
    import test_tune as t
    cfg = TuneConfig(params=t.specs(), trials=40, out_dir=Path({out!r}), progress=False,
                     heartbeat_s=1, grace_s=2, workers={workers})
    tune(cfg, t.fake_suite(delay_s={delay}), report_function=t.fake_report, defaults=t.DEFAULTS)
    """
)


def start_kill_script(out: Path, workers: int = 1, delay_s: float = 0.1) -> subprocess.Popen:
    script = KILL_SCRIPT.format(
        root=str(TESTS_DIR.parent), tests=str(TESTS_DIR), out=str(out), workers=workers,
        delay=delay_s,
    )  # fmt: skip
    return subprocess.Popen(
        [sys.executable, "-c", script], env={**os.environ, "PYTHONHASHSEED": "0"}
    )


def wait_for_completed_trials(proc: subprocess.Popen, db: Path, count: int) -> None:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if db.exists():
            try:
                states = [s for _, s in read_trials(db)]
            except sqlite3.OperationalError:
                states = []
            if states.count("COMPLETE") >= count:
                return
        assert proc.poll() is None, "the tune ended before it could be killed"
        time.sleep(0.05)
    pytest.fail("the tune made no progress in 60 s")


def test_resume_after_kill_continues_the_trial_count(tmp_path):
    out = tmp_path / "run"
    proc = start_kill_script(out)
    try:
        wait_for_completed_trials(proc, out / "tune.db", 4)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    before = read_trials(out / "tune.db")
    done_before = [n for n, s in before if s == "COMPLETE"]
    assert 4 <= len(done_before) < 40
    time.sleep(3.5)  # the killed trial's heartbeat goes stale (grace 2 s, 1 s resolution)
    cfg = TuneConfig(
        params=specs(), trials=10, out_dir=out, progress=False, heartbeat_s=1, grace_s=2
    )
    result = tune(cfg, fake_suite(), report_function=fake_report, defaults=DEFAULTS)
    after = read_trials(out / "tune.db")
    assert result.complete == max(10, len(done_before))
    # The old trials are kept as they were; numbering continues after them.
    assert after[: len(before)][: len(done_before)] == before[: len(done_before)]
    assert [n for n, _ in after] == list(range(len(after)))
    # A trial killed while running is failed and its parameters tried again (not lost).
    running_before = [n for n, s in before if s == "RUNNING"]
    import optuna

    study = optuna.load_study(study_name="fogsim-tune", storage=f"sqlite:///{out / 'tune.db'}")
    for number in running_before:
        assert study.trials[number].state.name == "FAIL"
        retried = [
            t
            for t in study.trials
            if t.system_attrs.get("failed_trial") == number and t.state.name == "COMPLETE"
        ]
        assert len(retried) == 1
        # A trial is retried with every parameter it had been given. Killed between Optuna's
        # ask and its suggestions (or between two suggestions) it has none (or some): the retry
        # keeps those and samples the rest; killed after them, all are the same.
        killed = study.trials[number].params
        assert killed.items() <= retried[0].params.items()
        assert set(retried[0].params) == {spec.name for spec in specs()}
    assert study.trials[0].params == DEFAULTS


# ----------------------------------------------------------------------------- pool and Ray


def test_process_pool_and_ray_give_the_same_trials(tmp_path):
    ray = pytest.importorskip("ray", reason="ray is not installed (optional extra 'ray')")
    from ray import cloudpickle

    pool = tune(
        config(tmp_path / "pool", trials=6, seed=5, workers=2),
        fake_suite(),
        report_function=fake_report,
        defaults=DEFAULTS,
    )
    by_value = (sys.modules[__name__], sys.modules["report_factory"])  # tests/ is not on Ray's path
    for module in by_value:
        cloudpickle.register_pickle_by_value(module)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        on_ray = tune(
            config(tmp_path / "ray", trials=6, seed=5, workers=2, ray_address="auto"),
            fake_suite(),
            report_function=fake_report,
            defaults=DEFAULTS,
        )
    finally:
        ray.shutdown()
        for module in by_value:
            cloudpickle.unregister_pickle_by_value(module)
    assert on_ray.complete == pool.complete == 6
    assert on_ray.best_params == pool.best_params
    assert on_ray.best_value == pool.best_value
    assert on_ray.defaults_value == pool.defaults_value
    import optuna

    trials = [
        [
            (t.number, t.params, t.value)
            for t in optuna.load_study(
                study_name="fogsim-tune", storage=f"sqlite:///{tmp_path / name / 'tune.db'}"
            ).trials
        ]
        for name in ("pool", "ray")
    ]
    assert trials[0] == trials[1]


# ----------------------------------------------------------------------------- real replay


def synthetic_box_removal_suite(frames: int = 70) -> list[SuiteEntry]:
    """The box_removal scenario's world, ray-cast (no MuJoCo): a standing robot looks at a flat
    box that is removed at 4.0 s; 1 % depth noise. Replayed by the real pipeline."""
    import numpy as np
    from synthetic_depth import Box, add_depth_noise, look_down_camera, render_boxes

    from fogsim.config import load_scenario
    from fogsim.data.frame import Frame
    from fogsim.data.recording import Recording
    from fogsim.world.truth import SceneTruth
    from mapper.intrinsics import PinholeIntrinsics

    scenario = load_scenario("box_removal")
    box = scenario.object("flat_box")
    intrinsics = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    camera_in_robot = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0)
    robot_pose = np.array([0.3, 0.5, 0.0, 0.0])
    camera_in_world = np.eye(4)
    camera_in_world[:3, 3] = robot_pose[:3]
    camera_in_world = camera_in_world @ camera_in_robot
    rng = np.random.default_rng(11)
    out, truths = [], []
    for i in range(frames):
        time_s = i / scenario.frame_rate_hz
        boxes = [Box(tuple(box.center), tuple(box.size))] if time_s < 4.0 else []
        depth = add_depth_noise(render_boxes(intrinsics, camera_in_world, boxes), 0.01, rng)
        out.append(
            Frame(
                index=i,
                time_s=time_s,
                depth_m=depth.astype(np.float32),
                intrinsics=intrinsics,
                transform_camera_to_robot_believed=camera_in_robot,
                robot_pose_believed=robot_pose,
                transform_camera_to_world_true=camera_in_world,
                robot_pose_true=robot_pose,
            )
        )
        truths.append(SceneTruth.from_scenario(scenario, time_s))
    recording = Recording(frames=out, scenario=scenario, truths=truths, intrinsics=intrinsics)
    return [SuiteEntry("box_removal", recording, scenario.frame_rate_hz)]


def test_small_tune_on_the_quick_subset_is_at_least_as_good_as_the_defaults(tmp_path):
    from fogsim.config import load_scenario
    from fogsim.paths import SCENARIOS_DIR
    from fogsim.run.runner import replay_report
    from fogsim.run.suite import QUICK_MAX_FRAMES, QUICK_SCENARIOS
    from fogsim.tune import parameter_defaults
    from fogsim.tune.suite import load_suite

    # The suite's quick subset, simulated once into the cache, then only replayed.
    suite = load_suite(SCENARIOS_DIR, tmp_path / "recordings", quick=True)
    assert sorted(e.name for e in suite) == sorted(QUICK_SCENARIOS)
    assert all(len(e.recording.frames) <= QUICK_MAX_FRAMES for e in suite)
    assert len(list((tmp_path / "recordings").glob("*.npz"))) == len(QUICK_SCENARIOS)
    params = (
        ParamSpec.parse("p_occ=0.55:0.95"),
        ParamSpec.parse("eps_m=0.005:0.05:log"),
        ParamSpec.parse("seg.min_plane_pixels=10:60"),
    )
    cfg = TuneConfig(params=params, trials=4, out_dir=tmp_path, seed=2, progress=False)
    result = tune(cfg, suite, report_function=replay_report)  # the real replay
    # The defaults are trial 0 and measured: the same as replaying with the library defaults.
    defaults = parameter_defaults([p.name for p in params])
    direct = score_parameters(suite, defaults, cfg.weights, replay_report)
    assert result.defaults_value == direct.objective
    assert result.best_value <= result.defaults_value
    assert result.complete == 4
    # The best block pastes into a scenario file and loads back with those values.
    text = (
        load_scenario("box_removal").source_path.read_text()
        + "\n"
        + (tmp_path / "best_params.toml").read_text()
    )
    pasted = tmp_path / "box_removal_tuned.toml"
    pasted.write_text(text)
    tuned = load_scenario(pasted)
    assert tuned.mapper["p_occ"] == result.best_params["p_occ"]
    assert tuned.segmentation["min_plane_pixels"] == result.best_params["seg.min_plane_pixels"]
    # A second load reuses the cached recordings (same scenario hash): no new file.
    again = load_suite(SCENARIOS_DIR, tmp_path / "recordings", quick=True)
    assert [len(e.recording.frames) for e in again] == [len(e.recording.frames) for e in suite]
    assert len(list((tmp_path / "recordings").glob("*.npz"))) == len(QUICK_SCENARIOS)


def test_cli_tune_from_a_recording_file_and_resume(tmp_path, capsys):
    from fogsim.cli import main
    from fogsim.data.recording import save_recording

    (entry,) = synthetic_box_removal_suite(frames=60)
    rec = entry.recording
    suite_dir = tmp_path / "suite"
    save_recording(
        suite_dir / "box_removal.npz", rec.frames, scenario=rec.scenario, truths=rec.truths
    )
    argv = [
        "tune",
        str(suite_dir),
        "--param",
        "p_occ=0.55:0.95",
        "--trials",
        "2",
        "--out",
        str(tmp_path / "out"),
        "--no-progress",
        "--no-pictures",
        "--seed",
        "1",
    ]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "[mapper]" in printed and "| rank | trial | objective" in printed
    argv[argv.index("--trials") + 1] = "3"
    assert main(argv) == 0  # resumes: one more trial
    assert [n for n, s in read_trials(tmp_path / "out" / "tune.db")] == [0, 1, 2]
    assert main([*argv, "--weight", "table1_mm=5"]) == 2  # other weights: refused
    assert "made with other weights" in capsys.readouterr().err
    assert main(["tune", str(suite_dir), "--param", "p_occ=0.9:0.5", "--out", "x"]) == 2


# ----------------------------------------------------------------------------- hardening


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_killing_the_driver_ends_its_pool_workers(tmp_path):
    from fogsim.run.orphans import PARENT_POLL_S

    out = tmp_path / "run"
    proc = start_kill_script(out, workers=2, delay_s=0.3)
    workers: list[int] = []
    try:
        wait_for_completed_trials(proc, out / "tune.db", 2)
        workers = process_children(proc.pid)
        assert len(workers) == 2 and all(process_alive(w) for w in workers)
    finally:
        left = kill_driver(proc, workers, PARENT_POLL_S + 5.0)
    assert not left, "orphaned tune workers still run"


def test_a_run_restarted_within_the_grace_period_fails_the_killed_runs_trials(tmp_path):
    import dataclasses
    import warnings

    import optuna
    from optuna.trial import TrialState

    from fogsim.tune.recovery import TrialHeartbeat, open_storage

    cfg = TuneConfig(
        params=specs(), trials=2, out_dir=tmp_path, progress=False, heartbeat_s=1, grace_s=2
    )
    started = time.monotonic()
    tune(cfg, fake_suite(), report_function=fake_report, defaults=DEFAULTS)
    # Two trials' work on this machine at this moment: the restart below does at most as much
    # besides its wait (one trial), so the bound holds on a loaded machine too.
    work_s = time.monotonic() - started
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.filterwarnings("ignore", message="Heartbeat of storage", category=UserWarning)
        storage = open_storage(cfg)
        study = optuna.load_study(study_name=cfg.study_name, storage=storage)
        killed, live = study.ask(), study.ask()
        heartbeat_killed = TrialHeartbeat(storage, cfg.study_name, cfg.heartbeat_s)
        heartbeat_live = TrialHeartbeat(storage, cfg.study_name, cfg.heartbeat_s)
        heartbeat_killed.add(killed.number)  # a run killed while scoring it
        heartbeat_live.add(live.number)  # a run that lives on
        killed_params = {p.name: p.suggest(killed) for p in specs()}
        for spec in specs():
            spec.suggest(live)
        heartbeat_killed.close()
        try:
            started = time.monotonic()
            result = tune(  # restarted at once: the killed trial is not stale yet
                dataclasses.replace(cfg, trials=3),
                fake_suite(),
                report_function=fake_report,
                defaults=DEFAULTS,
            )
            waited_s = time.monotonic() - started
        finally:
            heartbeat_live.close()
    trials = optuna.load_study(study_name=cfg.study_name, storage=storage).trials
    assert result.complete == 3
    assert trials[killed.number].state == TrialState.FAIL  # not left RUNNING forever
    assert trials[live.number].state == TrialState.RUNNING  # it kept beating: left alone
    retries = [t for t in trials if t.system_attrs.get("failed_trial") == killed.number]
    assert [(t.state, t.params) for t in retries] == [(TrialState.WAITING, killed_params)]
    assert waited_s < cfg.grace_s + cfg.heartbeat_s + work_s + 10.0  # bounded wait


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("p_occ=0.3:0.9", r"the lower bound 0\.3 is not allowed: mapper\.p_occ: .*\(0\.5, 1\)"),
        ("p_occ=0.6:1.2", r"the upper bound 1\.2 is not allowed: .*in \(0\.5, 1\)"),
        ("nx=50.5:120", r"nx is an integer parameter; write both bounds as integers"),
        ("nx=50.0:120.0", r"nx is an integer parameter"),
        ("nx=0:120", r"the lower bound 0 is not allowed: mapper\.nx: .*a positive int"),
        ("nx=100:50000", r"the upper bound 50000 is not allowed: .*at most 4194304 columns"),
        ("seg.fill_passes=1:100", r"the upper bound 100 .*fill_passes must be an integer in"),
        ("cell_m=0.0001:0.04:log", r"the lower bound 0\.0001 .*\[0\.001, 1\.0\]"),
        ("seg.min_depth_m=0.01:20", r"the upper bound 20\.0 .*min_depth_m .* must be < max_dep"),
    ],
)
def test_ranges_outside_what_a_parameter_allows_are_refused_before_any_trial(
    tmp_path, text, message
):
    from fogsim.tune import check_ranges

    spec = ParamSpec.parse(text)
    with pytest.raises(FogsimError, match=rf"--param {re.escape(spec.to_text())}: {message}"):
        check_ranges([spec])
    cfg = TuneConfig(params=(spec,), trials=3, out_dir=tmp_path / "out", progress=False)
    with pytest.raises(FogsimError, match=message):
        tune(cfg, fake_suite(), report_function=fake_report)  # library names: checked
    assert not (tmp_path / "out").exists()  # refused before the study was made


def test_ranges_a_parameter_allows_pass():
    from fogsim.tune import check_ranges

    texts = ("p_occ=0.55:0.95", "eps_m=0.005:0.05:log", "nx=50:120", "seg.grow_sigma_factor=1:9")
    check_ranges([ParamSpec.parse(t) for t in texts])


@pytest.mark.parametrize(
    "address",
    ["nohost", "host:0", "host:65536", "host:abc", ":6379", "", "ray://head:10001", "[zz]:1",
     "head :6379", "10.0.0.5:6379:1"],
)  # fmt: skip
def test_invalid_ray_addresses_are_refused_naming_what_is_allowed(tmp_path, address):
    with pytest.raises(FogsimError, match=r"must be auto, local or HOST:PORT with a port in"):
        config(tmp_path, ray_address=address)


@pytest.mark.parametrize(
    "address", ["auto", "local", "10.0.0.5:6379", "[::1]:6379", "head-node.lan:6379"]
)
def test_valid_ray_addresses_are_accepted(tmp_path, address):
    assert config(tmp_path, ray_address=address).ray_address == address


def closed_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_an_unreachable_ray_head_is_a_named_error_before_any_work(tmp_path, capsys):
    from fogsim.cli import main

    suite_dir = tmp_path / "suite"
    suite_dir.mkdir()
    address = f"127.0.0.1:{closed_port()}"
    started = time.monotonic()
    argv = ["tune", str(suite_dir), "--param", "p_occ=0.55:0.95", "--out", str(tmp_path / "out")]
    assert main([*argv, "--ray", address, "--no-progress"]) == 2
    assert time.monotonic() - started < 10.0
    err = capsys.readouterr().err
    assert f"--ray {address}: cannot reach a Ray head there" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()
    assert main([*argv, "--ray", "host:99999"]) == 2
    assert "must be auto, local or HOST:PORT" in capsys.readouterr().err


RAY_SCRIPT = textwrap.dedent(
    """
    import json, socket, sys, time
    sys.path[:0] = [{root!r}]
    from fogsim.errors import FogsimError
    from fogsim.tune.executors import RayExecutor
    from fogsim.tune.objective import ObjectiveWeights
    {body}
    """
)


def run_ray_script(body: str) -> str:
    pytest.importorskip("ray", reason="ray is not installed (optional extra 'ray')")
    script = RAY_SCRIPT.format(root=str(TESTS_DIR.parent), body=textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_a_ray_head_that_never_answers_is_given_up_after_the_timeout():
    out = run_ray_script(
        """
        listener = socket.socket()  # accepts connections, never speaks Ray
        listener.bind(("127.0.0.1", 0))
        listener.listen(8)
        address = "127.0.0.1:%d" % listener.getsockname()[1]
        started = time.monotonic()
        try:
            RayExecutor([], ObjectiveWeights(), None, address, 1, connect_s=3.0)
        except FogsimError as exc:
            print(json.dumps([time.monotonic() - started, str(exc)]))
        """
    )
    elapsed_s, message = json.loads(out.strip().splitlines()[-1])
    assert elapsed_s < 3.0 + 5.0
    assert message.startswith("--ray 127.0.0.1:") and ("within 3 s" in message or "join" in message)


def test_ray_local_listens_on_the_loopback_address_only():
    out = run_ray_script(
        """
        try:
            executor = RayExecutor([], ObjectiveWeights(), None, "local", 1)
            import psutil  # Ray's dependency (vendored by Ray: importable once Ray is)
        except Exception as exc:
            print(json.dumps({"failed": repr(exc)}))
            sys.exit(0)
        try:
            listening = set()
            for proc in [psutil.Process(), *psutil.Process().children(recursive=True)]:
                try:
                    connections = proc.net_connections(kind="inet")
                except psutil.Error:
                    continue
                listening |= {c.laddr.ip for c in connections if c.status == psutil.CONN_LISTEN}
            print(json.dumps({"listening": sorted(listening)}))
        finally:
            executor.close()
        """
    )
    result = json.loads(out.strip().splitlines()[-1])
    if "failed" in result:
        pytest.skip(f"Ray or psutil cannot run here: {result['failed']}")
    assert result["listening"], "no Ray server found listening"
    assert set(result["listening"]) <= {"127.0.0.1", "::ffff:127.0.0.1", "::1"}


PARAM_TEXTS = st.one_of(
    st.text(max_size=20),
    st.builds(
        "{}={}:{}{}".format,
        st.sampled_from([*NAMES_TUNABLE, "bogus", ""]),
        st.one_of(st.floats(), st.integers(-(10**6), 10**6), st.text(max_size=4)),
        st.one_of(st.floats(), st.integers(-(10**6), 10**6), st.text(max_size=4)),
        st.sampled_from(["", ":log", ":lin", ":"]),
    ),
)


@settings(derandomize=True, max_examples=150, deadline=None)
@given(text=PARAM_TEXTS)
def test_any_param_text_is_accepted_or_refused_with_a_message(text):
    from fogsim.tune import check_ranges

    try:
        spec = ParamSpec.parse(text)
        check_ranges([spec])
    except FogsimError as exc:
        assert str(exc).startswith("--param") or "parameter" in str(exc)
    else:
        assert spec.low < spec.high and math.isfinite(spec.low) and math.isfinite(spec.high)


@settings(derandomize=True, max_examples=40, deadline=None)
@given(text=PARAM_TEXTS)
def test_cli_tune_with_a_refused_range_exits_2_before_writing(tmp_path_factory, text):
    from fogsim.cli import main
    from fogsim.tune import check_ranges

    try:
        check_ranges([ParamSpec.parse(text)])
        assume(False)  # an allowed range would start a tune: not this test's business
    except FogsimError:
        pass
    out = tmp_path_factory.mktemp("cli") / "out"
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["tune", "stage", f"--param={text}", "--out", str(out), "--no-progress"])
    assert code == 2 and err.getvalue().startswith("fogsim: error: ")
    assert not out.exists()


@settings(derandomize=True, max_examples=150, deadline=None)
@given(address=st.one_of(st.text(max_size=24), st.from_regex(r"[a-z0-9.\[\]:]{0,12}:\d{0,6}")))
def test_any_ray_address_is_accepted_or_refused_with_a_message(address):
    from fogsim.run.ray_cluster import parse_ray_address

    try:
        endpoint = parse_ray_address(address)
    except FogsimError as exc:
        assert str(exc).startswith(f"--ray {address!r}: must be auto, local or HOST:PORT")
    else:
        assert endpoint is None or 1 <= endpoint.port <= 65535


def test_the_command_line_imports_optuna_only_for_tune():
    """Every ``fogsim`` command builds the tune parser; only ``fogsim tune`` needs Optuna."""
    root = Path(__file__).resolve().parent.parent
    code = (
        "import sys\n"
        "import fogsim.cli\n"
        "assert 'optuna' not in sys.modules, 'fogsim.cli imported optuna'\n"
        "from fogsim.tune import tune\n"
        "assert 'optuna' in sys.modules\n"
    )
    env = dict(os.environ, PYTHONPATH=str(root))
    subprocess.run([sys.executable, "-c", code], env=env, check=True)


# ----------------------------------------------------------------------------- segmentation cache


def _without_times(report):
    """A report with its timing reduced to the frame counts (times differ run to run)."""
    import dataclasses

    timing = report.timing
    counts = (timing.frames, timing.withdrawn_frames, timing.z_matched_frames)
    return dataclasses.replace(report, timing=counts)


def test_trials_with_cached_segmentations_give_the_reports_of_segmenting_afresh():
    from fogsim.run.runner import replay_report
    from fogsim.tune.segment_cache import SegmentationCache

    (entry,) = synthetic_box_removal_suite(frames=50)
    cache = SegmentationCache()
    trials = ({"p_occ": 0.7}, {"p_occ": 0.6, "eps_m": 0.02})
    for number, overrides in enumerate(trials):
        afresh = replay_report(entry.recording, overrides)
        cached = replay_report(entry.recording, overrides, segment=cache.segment)
        assert _without_times(cached) == _without_times(afresh)
        # The first trial segments every frame once; the second only reads the cache.
        assert (cache.misses, cache.hits) == (50, 50 * number)
    assert _without_times(afresh) != _without_times(replay_report(entry.recording, trials[0]))


def test_a_tuned_segmentation_parameter_is_segmented_afresh_every_trial(monkeypatch):
    import fogsim.tune.segment_cache as segment_cache
    from fogsim.run.runner import replay_report
    from fogsim.tune.segment_cache import SegmentationCache, cached_replay_report

    (entry,) = synthetic_box_removal_suite(frames=20)
    # Another parameter value is another key: never a result of the other value.
    cache = SegmentationCache()
    for pixels in (10.0, 60.0):
        overrides = {"seg.min_plane_pixels": pixels}
        cached = replay_report(entry.recording, overrides, segment=cache.segment)
        assert _without_times(cached) == _without_times(replay_report(entry.recording, overrides))
    assert (cache.misses, cache.hits) == (40, 0)
    # tune's report function does not even ask the process's cache then; otherwise it does.
    process_cache = SegmentationCache()
    monkeypatch.setattr(segment_cache, "_PROCESS_CACHE", process_cache)
    cached_replay_report(entry.recording, {"seg.min_plane_pixels": 10.0, "p_occ": 0.7})
    assert (process_cache.misses, process_cache.stored_bytes) == (0, 0)
    for _ in range(2):
        cached_replay_report(entry.recording, {"p_occ": 0.7})
    assert (process_cache.misses, process_cache.hits) == (20, 20)


def test_the_cache_keeps_results_up_to_its_byte_cap_read_only():
    import numpy as np

    from fogsim.config import resolve_params
    from fogsim.tune.segment_cache import SegmentationCache, result_bytes
    from mapper.segmentation import segment_depth

    (entry,) = synthetic_box_removal_suite(frames=3)
    params = resolve_params(entry.recording.scenario).segmentation
    frames = entry.recording.frames
    args = [(f.depth_m, f.intrinsics, f.transform_camera_to_robot_believed, params) for f in frames]
    key_bytes = frames[0].depth_m.nbytes + np.asarray(args[0][2]).nbytes
    one = result_bytes(segment_depth(*args[0])) + key_bytes
    assert one > 4 * 88 * 72  # at least the points of the image's pixels
    cache = SegmentationCache(max_bytes=one + one // 2)  # room for one frame's result
    first = [cache.segment(*a) for a in args]
    assert cache.stored_bytes == one and cache.misses == 3
    again = [cache.segment(*a) for a in args]
    assert again[0] is first[0] and again[1] is not first[1] and again[2] is not first[2]
    assert (cache.misses, cache.hits) == (5, 1)
    np.testing.assert_array_equal(again[1].points, first[1].points)
    with pytest.raises(ValueError, match="read-only"):
        first[0].points[0, 0] = 1.0  # shared between trials: nobody may write into it
    with pytest.raises(FogsimError, match="max_bytes must be >= 0, got -1"):
        SegmentationCache(max_bytes=-1)


# ----------------------------------------------------------------------------- cells in view cache


def test_trials_with_cached_cells_in_view_give_the_reports_of_making_them_afresh():
    import numpy as np

    from fogsim.eval.archive import cells_in_view
    from fogsim.run.runner import replay_report
    from fogsim.tune.segment_cache import ViewCache

    (entry,) = synthetic_box_removal_suite(frames=30)
    views = ViewCache()
    for overrides in ({"p_occ": 0.7}, {"p_occ": 0.6, "eps_m": 0.02}):
        afresh = replay_report(entry.recording, overrides)
        cached = replay_report(entry.recording, overrides, in_view=views.cells_in_view)
        assert _without_times(cached) == _without_times(afresh)
    # The second trial asks for the cells of the same frames on the same grids: all kept.
    assert views.misses > 0 and views.hits == views.misses
    frame = entry.recording.frames[3]
    from mapper import FloorObstacleMapper

    geometry = FloorObstacleMapper().geometry
    mask = views.cells_in_view(frame, geometry)
    np.testing.assert_array_equal(mask, cells_in_view(frame, geometry))
    with pytest.raises(ValueError, match="read-only"):
        mask[0, 0] = True  # shared between trials: nobody may write into it
    moved = geometry.shifted(5, 0)  # another place of the grid is another key
    np.testing.assert_array_equal(views.cells_in_view(frame, moved), cells_in_view(frame, moved))


def test_the_view_cache_keeps_masks_up_to_its_byte_cap():
    from fogsim.tune.segment_cache import ViewCache
    from mapper import FloorObstacleMapper

    (entry,) = synthetic_box_removal_suite(frames=2)
    geometry = FloorObstacleMapper().geometry
    first, second = entry.recording.frames
    one = geometry.nx * geometry.ny + first.depth_m.nbytes + 16 * 8  # mask, depth, pose
    views = ViewCache(max_bytes=one + one // 2)
    kept = views.cells_in_view(first, geometry)
    views.cells_in_view(second, geometry)
    assert views.stored_bytes == one and views.misses == 2
    assert views.cells_in_view(first, geometry) is kept
    assert views.cells_in_view(second, geometry) is not kept
    assert (views.misses, views.hits) == (3, 1)
    with pytest.raises(FogsimError, match="max_bytes must be >= 0, got -1"):
        ViewCache(max_bytes=-1)


def test_a_suite_holds_its_recordings_depth_in_memory_read_only(tmp_path, monkeypatch):
    import numpy as np

    import fogsim.tune.suite as suite_module
    from fogsim.data.frames import DepthArray, DepthMember
    from fogsim.data.recording import load_recording, save_recording
    from fogsim.tune.suite import load_suite

    (entry,) = synthetic_box_removal_suite(frames=6)
    recording = entry.recording
    path = save_recording(
        tmp_path / "boxes.npz",
        recording.frames,
        scenario=recording.scenario,
        truths=recording.truths,
    )
    from_file = load_recording(path)
    (loaded,) = load_suite(path, tmp_path / "recordings")
    assert isinstance(from_file.frames.depth, DepthMember)
    assert isinstance(loaded.recording.frames.depth, DepthArray)
    assert len(loaded.recording.frames) == 6
    for a, b in zip(from_file.frames, loaded.recording.frames, strict=True):
        assert not a.depth_m.flags.writeable and not b.depth_m.flags.writeable
        assert a.depth_m.dtype == b.depth_m.dtype == np.float32
        np.testing.assert_array_equal(a.depth_m, b.depth_m)
        np.testing.assert_array_equal(a.robot_pose_believed, b.robot_pose_believed)
    # A slice keeps its own frames; more depth than the bound is left in the file.
    assert [f.index for f in from_file.frames[2:5].in_memory()] == [2, 3, 4]
    monkeypatch.setattr(suite_module, "IN_MEMORY_DEPTH_BYTES", 6 * 88 * 72 * 4 - 1)
    (kept_in_file,) = load_suite(path, tmp_path / "recordings")
    assert isinstance(kept_in_file.recording.frames.depth, DepthMember)


def test_package_versions_are_read_once_and_handed_out_as_fresh_dicts():
    from fogsim.eval.report import package_versions

    first = package_versions()
    first["numpy"] = "changed"
    second = package_versions()
    assert second["numpy"] != "changed" and second is not first
    assert list(second)[:2] == ["python", "fogsim"]
