"""Layer 10 — tuning: searching mapper and segmentation thresholds over replayed recordings.

Modules, each one job: :mod:`~fogsim.tune.space` (tunable parameters and a tuned range),
:mod:`~fogsim.tune.config` (:class:`TuneConfig`), :mod:`~fogsim.tune.objective` (a report to one
number), :mod:`~fogsim.tune.suite` (the recordings and their cache),
:mod:`~fogsim.tune.executors` (inline, process pool, Ray), :mod:`~fogsim.tune.recovery`
(heartbeats, retrying a dead run's trials), :mod:`~fogsim.tune.study` (the ask/tell loop),
:mod:`~fogsim.tune.writers` and :mod:`~fogsim.tune.plots` (result files),
:mod:`~fogsim.tune.cli` (``fogsim tune``).

A tune from Python::

    from fogsim.run.runner import replay_report
    from fogsim.tune import ParamSpec, TuneConfig, load_suite, tune

    config = TuneConfig(params=(ParamSpec.parse("p_occ=0.55:0.95"),), trials=20, out_dir=out)
    suite = load_suite("scenarios", out / "recordings", quick=True)
    result = tune(config, suite, report_function=replay_report)
"""

from fogsim.tune.config import SamplerKind, TuneConfig
from fogsim.tune.objective import ObjectiveWeights, SuiteEntry
from fogsim.tune.space import (
    ParamSpec,
    check_ranges,
    parameter_defaults,
    tunable_parameter_names,
)
from fogsim.tune.study import tune
from fogsim.tune.suite import load_suite
from fogsim.tune.writers import TuneResult, best_params_toml

__all__ = [
    "ObjectiveWeights",
    "ParamSpec",
    "SamplerKind",
    "SuiteEntry",
    "TuneConfig",
    "TuneResult",
    "best_params_toml",
    "check_ranges",
    "load_suite",
    "parameter_defaults",
    "tunable_parameter_names",
    "tune",
]
