"""Layer 10 — tuning: searching mapper and segmentation thresholds over replayed recordings.

Modules, each one job: :mod:`~fogsim.tune.space` (tunable parameters and a tuned range),
:mod:`~fogsim.tune.config` (:class:`TuneConfig`), :mod:`~fogsim.tune.objective` (a report to one
number), :mod:`~fogsim.tune.suite` (the recordings and their cache),
:mod:`~fogsim.tune.executors` (inline, process pool, Ray), :mod:`~fogsim.tune.segment_cache`
(one segmentation per recorded frame across a process's trials), :mod:`~fogsim.tune.recovery`
(heartbeats, retrying a dead run's trials), :mod:`~fogsim.tune.study` (the ask/tell loop),
:mod:`~fogsim.tune.writers` and :mod:`~fogsim.tune.plots` (result files),
:mod:`~fogsim.tune.cli` (``fogsim tune``).

A tune from Python::

    from fogsim.tune import ParamSpec, TuneConfig, load_suite, tune
    from fogsim.tune.segment_cache import cached_replay_report

    config = TuneConfig(params=(ParamSpec.parse("p_occ=0.55:0.95"),), trials=20, out_dir=out)
    suite = load_suite("scenarios", out / "recordings", quick=True)
    result = tune(config, suite, report_function=cached_replay_report)
"""

from fogsim.lazy import lazy_getattr

_EXPORTS = {
    "ObjectiveWeights": "fogsim.tune.objective",
    "ParamSpec": "fogsim.tune.space",
    "SamplerKind": "fogsim.tune.config",
    "SuiteEntry": "fogsim.tune.objective",
    "TuneConfig": "fogsim.tune.config",
    "TuneResult": "fogsim.tune.writers",
    "best_params_toml": "fogsim.tune.writers",
    "check_ranges": "fogsim.tune.space",
    "load_suite": "fogsim.tune.suite",
    "parameter_defaults": "fogsim.tune.space",
    "tunable_parameter_names": "fogsim.tune.space",
    "tune": "fogsim.tune.study",
}
"""The package's names and their modules, imported on first use: ``fogsim tune``'s argument
parser (:mod:`~fogsim.tune.cli`, built by every ``fogsim`` command) would otherwise import
Optuna (~0.1 s CPU) into every run."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_getattr(__name__, _EXPORTS)
