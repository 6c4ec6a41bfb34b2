"""A finished tune's result files: ``best_params.toml``, ``trials.md``, ``summary.json``.

Also the per-parameter pictures (:mod:`fogsim.tune.plots`) unless ``config.pictures`` is off.
"""

from __future__ import annotations

import json
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import optuna
import tomli_w
from optuna.trial import FrozenTrial, TrialState

from fogsim.atomic import write_text_atomic
from fogsim.config import split_override_key
from fogsim.errors import TuneError
from fogsim.tune.config import TuneConfig
from fogsim.tune.objective import TERM_NAMES
from fogsim.tune.plots import plot_parameter
from fogsim.tune.space import TUNED_TABLES, ParamSpec

TERM_COLUMNS = TERM_NAMES
"""The objective terms shown in ``trials.md`` (keys of a trial's ``terms`` user attribute)."""


@dataclass(frozen=True)
class RankedTrials:
    """The scored trials of a study.

    Attributes:
        complete: Completed trials, best first (objective, then trial number).
        failed: Trials whose scoring raised (user attribute ``error``).
    """

    complete: tuple[FrozenTrial, ...]
    failed: tuple[FrozenTrial, ...]

    @property
    def best(self) -> FrozenTrial:
        """The best trial."""
        return self.complete[0]

    @property
    def defaults(self) -> FrozenTrial | None:
        """The completed trial of the library defaults (None if it failed or is not done)."""
        return next((t for t in self.complete if t.user_attrs.get("defaults")), None)


def rank_trials(study: optuna.Study) -> RankedTrials:
    """The study's completed trials, best first, and those that failed in scoring.

    Raises:
        TuneError: no trial completed (the message quotes the first scoring error).
    """
    trials = study.get_trials(deepcopy=False)
    complete = sorted(
        (t for t in trials if t.state == TrialState.COMPLETE), key=lambda t: (t.value, t.number)
    )
    failed = [t for t in trials if t.state == TrialState.FAIL and "error" in t.user_attrs]
    if not complete:
        first_error = failed[0].user_attrs["error"] if failed else "no trial was run"
        raise TuneError(f"no trial completed; first error: {first_error}")
    return RankedTrials(complete=tuple(complete), failed=tuple(failed))


def best_params_toml(params: Mapping[str, float], specs: Sequence[ParamSpec], comment: str) -> str:
    """``[mapper]`` (and ``[segmentation]``) TOML blocks of the given values, to paste.

    Args:
        params: Values by override key (``p_occ``, ``seg.<field>``).
        specs: The tuned ranges (integer ones are written as integers).
        comment: Put first, each line as a TOML comment.
    """
    integer = {s.name: s.integer for s in specs}
    tables: dict[str, dict[str, int | float]] = {table: {} for table in TUNED_TABLES}
    for name, value in params.items():
        table, key = split_override_key(name)
        tables[table][key] = int(value) if integer.get(name) else float(value)
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    return header + tomli_w.dumps({table: values for table, values in tables.items() if values})


def _mean_terms(trial: FrozenTrial) -> dict[str, float | None]:
    """Mean of each objective term over the trial's recordings (None where no recording has it)."""
    per_recording = trial.user_attrs.get("terms", {})
    out: dict[str, float | None] = {}
    for key in TERM_COLUMNS:
        values = [t[key] for t in per_recording.values() if t.get(key) is not None]
        out[key] = float(statistics.fmean(values)) if values else None
    return out


def _format_value(value: float, integer: bool) -> str:
    return str(int(value)) if integer else f"{value:.6g}"


def _cell(value: float | None) -> str:
    return "–" if value is None else f"{value:.3f}"


def top_trials_markdown(trials: Sequence[FrozenTrial], specs: Sequence[ParamSpec]) -> str:
    """A Markdown table of trials (best first): objective, mean terms, parameters."""
    header = ["rank", "trial", "objective", "table1 mm", "wrong cells %", "unknown %"]
    header += ["obstacles missed %", "unsafe cells", "clearing s"]
    header += [s.name for s in specs]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for rank, trial in enumerate(trials, start=1):
        terms = _mean_terms(trial)
        label = (
            f"{trial.number} (defaults)" if trial.user_attrs.get("defaults") else str(trial.number)
        )
        row = [str(rank), label, f"{trial.value:.4f}"]
        row += [_cell(terms[k]) for k in TERM_COLUMNS]
        row += [_format_value(trial.params[s.name], s.integer) for s in specs]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def _median_attr(trials: Sequence[FrozenTrial], key: str) -> float | None:
    values = [t.user_attrs[key] for t in trials if key in t.user_attrs]
    return float(statistics.median(values)) if values else None


def _summary(ranked: RankedTrials, config: TuneConfig) -> dict[str, Any]:
    """The content of ``summary.json``."""
    best, defaults = ranked.best, ranked.defaults
    return {
        "study": config.study_name,
        "best": {"trial": best.number, "objective": best.value, "params": best.params},
        "defaults": None
        if defaults is None
        else {"trial": defaults.number, "objective": defaults.value, "params": defaults.params},
        "best_terms": best.user_attrs.get("terms"),
        "trials": {"complete": len(ranked.complete), "failed": len(ranked.failed)},
        "timing": {
            "median_report_s": _median_attr(ranked.complete, "report_s"),
            "median_objective_s": _median_attr(ranked.complete, "objective_s"),
        },
        "config": {
            "params": [p.to_text() for p in config.params],
            "sampler": str(config.sampler),
            "seed": config.seed,
            "workers": config.workers,
            "ray": config.ray_address,
            "weights": config.weights.to_dict(),
        },
    }


@dataclass(frozen=True)
class TuneResult:
    """The outcome of a tune.

    Attributes:
        best_params: Best parameter values by name.
        best_value: Its objective.
        defaults_value: Objective of the defaults trial (None if it failed).
        trials: Scored trials in the study (complete + failed in scoring).
        complete: Completed trials.
        out_dir: Where the results were written.
    """

    best_params: dict[str, float]
    best_value: float
    defaults_value: float | None
    trials: int
    complete: int
    out_dir: Path


def write_results(study: optuna.Study, config: TuneConfig) -> TuneResult:
    """Write best_params.toml, trials.md, summary.json and the per-parameter plots.

    Raises:
        TuneError: no trial completed (the message quotes the first scoring error).
    """
    ranked = rank_trials(study)
    best, defaults = ranked.best, ranked.defaults
    complete = ranked.complete
    out = config.out_dir
    comment = (
        f"fogsim tune: best of {len(complete)} trials (trial {best.number}), objective "
        f"{best.value:.6g}" + ("" if defaults is None else f"; defaults {defaults.value:.6g}")
    )
    specs = config.params
    write_text_atomic(out / "best_params.toml", best_params_toml(best.params, specs, comment))
    table = top_trials_markdown(complete[: config.top], specs)
    title = f"# fogsim tune: top {min(config.top, len(complete))} of {len(complete)} trials\n\n"
    write_text_atomic(out / "trials.md", title + table)
    if config.pictures:
        for spec in specs:
            plot_parameter(study, spec, out / f"objective_{spec.name}.png", best, defaults)
    write_text_atomic(out / "summary.json", json.dumps(_summary(ranked, config), indent=2) + "\n")
    return TuneResult(
        best_params=dict(best.params),
        best_value=float(best.value),
        defaults_value=None if defaults is None else float(defaults.value),
        trials=len(complete) + len(ranked.failed),
        complete=len(complete),
        out_dir=out,
    )
