"""Package layout that pyproject.toml cannot express: the top-level data folders as package data.

``scenarios/`` and ``assets/`` stay at the top of the repository (the project's layout) and are
installed as the packages ``fogsim.scenarios`` and ``fogsim.assets``, so a non-editable install
has them too; :mod:`fogsim.paths` finds them through :mod:`importlib.resources` either way.
"""

from setuptools import find_packages, setup

setup(
    packages=[
        *find_packages(include=["mapper", "mapper.*", "fogsim", "fogsim.*"]),
        "fogsim.scenarios",
        "fogsim.assets",
    ],
    package_dir={"fogsim.scenarios": "scenarios", "fogsim.assets": "assets"},
    package_data={
        "fogsim.scenarios": ["*.toml", "*.json", "holdout/*.toml", "holdout/*.json"],
        "fogsim.assets": ["**/*"],
    },
)
