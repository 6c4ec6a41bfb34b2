"""A non-editable install works on its own: scenarios and assets ship as package data.

The wheel is built from the checkout and installed into a fresh virtual environment whose only
other content is a path file pointing at this interpreter's site-packages (for the
dependencies, found after the wheel). The scenario is then run from a folder
outside the checkout, so nothing can come from the source tree.
"""

import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_installed_elsewhere_runs_a_shipped_scenario(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels), str(ROOT)],
        check=True,
        capture_output=True,
    )
    (wheel,) = wheels.glob("fogsim-*.whl")
    env_dir = tmp_path / "env"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    site = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(site), wheel],
        check=True,
        capture_output=True,
    )
    # Dependencies from this interpreter's site-packages, after the wheel on the path (so the
    # editable install's finder there, appended to sys.meta_path, is never asked for fogsim).
    deps = sysconfig.get_paths()["purelib"]
    (site / "fogsim_test_deps.pth").write_text(f"import site; site.addsitedir({deps!r})\n")

    # Only what a user's shell would have: no PYTHONPATH pointing back at the checkout.
    env = {"MUJOCO_GL": "egl", "MESA_SHADER_CACHE_DISABLE": "true", "PATH": "/usr/bin:/bin"}
    work = tmp_path / "elsewhere"
    work.mkdir()
    where = subprocess.run(
        [str(python), "-c", "import fogsim.paths as p; print(p.__file__); print(p.SCENARIOS_DIR)"],
        cwd=work,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    assert Path(where[0]).is_relative_to(site)
    assert Path(where[1]).is_relative_to(site)

    listed = subprocess.run(
        [str(python), "-m", "fogsim", "list"], cwd=work, env=env, capture_output=True, text=True
    )
    assert listed.returncode == 0, listed.stderr
    for name in ("stage", "flat_floor", "box_removal"):
        assert name in listed.stdout

    run = subprocess.run(
        [
            str(python),
            "-m",
            "fogsim",
            "run",
            "flat_floor",
            "--out",
            "out",
            "--quiet",
            "--no-pictures",
            "--set",
            "camera.mode=ideal",
        ],
        cwd=work,
        capture_output=True,
        text=True,
        env=env,
    )
    assert run.returncode == 0, run.stderr
    assert (work / "out" / "report.json").is_file()
