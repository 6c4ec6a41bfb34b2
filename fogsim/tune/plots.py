"""One picture per tuned parameter: the objective of every trial against its value.

Optuna's slice plot (:func:`optuna.visualization.matplotlib.plot_slice`: every completed trial,
coloured by trial number, log axis for log ranges) with the defaults' trial (red square) and the
best trial (star) marked on it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import optuna
from matplotlib.axes import Axes
from matplotlib.collections import PathCollection
from optuna.trial import FrozenTrial, TrialState
from optuna.visualization.matplotlib import plot_slice

from fogsim.atomic import write_atomic
from fogsim.tune.space import ParamSpec

OUTLIER_IQR = 3.0
"""Trials worse than the third quartile plus this many interquartile ranges are left off the
top, so that a few very bad trials do not flatten the interesting range (Tukey's far out)."""


DEFAULTS_MARKER = {
    "label": "defaults", "marker": "s", "s": 120, "facecolors": "none",
    "edgecolors": "tab:red", "linewidths": 1.5,
}  # fmt: skip
"""The defaults' trial: a red square around its dot."""
BEST_MARKER = {
    "label": "best", "marker": "*", "s": 160, "c": "tab:orange", "edgecolors": "black",
}  # fmt: skip
"""The best trial: a star over its dot."""


def plot_parameter(
    study: optuna.Study,
    spec: ParamSpec,
    path: Path,
    best: FrozenTrial,
    defaults: FrozenTrial | None,
) -> Path:
    """Write the slice plot of one parameter as a PNG, defaults and best marked.

    Args:
        study: The study (its completed trials are plotted).
        spec: The parameter.
        path: The PNG to write.
        best: The best trial (a star).
        defaults: The defaults' trial (a red square), None if it did not complete.

    Returns:
        ``path``.
    """
    values = [t.value for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))]
    # plot_slice switches pyplot to the ggplot style; rc_context keeps that to this picture.
    with matplotlib.rc_context():
        axes = plot_slice(study, params=[spec.name], target_name="objective (lower is better)")
        figure = axes.figure
        try:
            marks = [] if defaults is None else [_mark(axes, spec, defaults, DEFAULTS_MARKER)]
            marks.append(_mark(axes, spec, best, BEST_MARKER))
            axes.legend(handles=marks, fontsize=8, loc="best")
            off_top = _clip_outliers(axes, values)
            title = f"objective vs {spec.name} ({len(values)} trials"
            title += f", {off_top} above the plot)" if off_top else ")"
            axes.set_title(title, fontsize=10)
            figure.tight_layout()
            return write_atomic(path, lambda handle: figure.savefig(handle, format="png"))
        finally:
            plt.close(figure)


def _mark(
    axes: Axes, spec: ParamSpec, trial: FrozenTrial, style: Mapping[str, Any]
) -> PathCollection:
    """Draw one trial's point (value of ``spec``, objective) over the slice plot's dots."""
    return axes.scatter([trial.params[spec.name]], [trial.value], zorder=3, **style)


def _clip_outliers(axes: Axes, values: Sequence[float]) -> int:
    """Leave trials far worse than most off the top; returns how many were left off."""
    q1, q3 = np.quantile(values, [0.25, 0.75])
    top = q3 + OUTLIER_IQR * max(q3 - q1, 1e-9 * max(abs(q3), 1.0))
    off_top = sum(value > top for value in values)
    if off_top:
        low = min(values)
        axes.set_ylim(low - 0.05 * (top - low), top + 0.05 * (top - low))
    return off_top
