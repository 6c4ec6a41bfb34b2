"""Lazily exported package names: imported on first use, an unknown name named with its package."""

import importlib

import pytest

import fogsim
import fogsim.tune
from fogsim.lazy import lazy_getattr


def test_an_exported_name_comes_from_its_module():
    module_getattr = lazy_getattr("pkg", {"sqrt": "math"})
    assert module_getattr("sqrt")(9.0) == 3.0


@pytest.mark.parametrize(("package", "name"), [(fogsim, "fogsim"), (fogsim.tune, "fogsim.tune")])
def test_an_unknown_name_is_an_attribute_error_naming_the_package(package, name):
    with pytest.raises(AttributeError, match=rf"module '{name}' has no attribute 'nope'"):
        package.nope  # noqa: B018


def test_the_packages_export_what_they_list():
    assert fogsim.load_recording.__module__ == "fogsim.data.recording"
    assert fogsim.tune.TuneConfig.__module__ == "fogsim.tune.config"


@pytest.mark.parametrize("package", ["fogsim.sim", "fogsim.sim.camera", "fogsim.robot"])
def test_every_lazily_exported_name_is_its_modules(package):
    """Each name the package lists is the object of the module it names (no typo, no stale name)."""
    module = importlib.import_module(package)
    for name, source in module._EXPORTS.items():
        assert getattr(module, name) is getattr(importlib.import_module(source), name), name
    assert module.__all__ == sorted(module._EXPORTS)
