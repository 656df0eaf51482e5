"""The pytest plugin used exactly as an outside project would: from our wheel, installed into a fresh venv.

Builds the wheel offline (`pip wheel --no-deps --no-build-isolation`), installs it with `--no-deps --no-index`
into a venv that borrows this environment's third-party packages through a .pth line (so nothing is
downloaded, and this checkout's editable install is not visible there), then runs pytest on a small outside
test file in a temporary folder: once as written (it must pass), once with a wrong expectation (it must fail).
"""

from __future__ import annotations

import os
import site
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
OUTSIDE = Path(__file__).with_name("outside_project.py").read_text()


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTEST_ADDOPTS")}
    return subprocess.run(list(args), cwd=cwd, capture_output=True, text=True, timeout=300, env=env)


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("plugin")
    built = run(sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation", "-q",
                "-w", str(tmp / "dist"))
    assert built.returncode == 0, built.stderr
    wheel = next((tmp / "dist").glob("rig-*.whl"))
    env_dir = tmp / "venv"
    made = run(sys.executable, "-m", "venv", "--without-pip", str(env_dir))
    assert made.returncode == 0, made.stderr
    python = env_dir / "bin" / "python"
    purelib = Path(run(str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])",
                       cwd=tmp).stdout.strip())
    borrowed = [p for p in site.getsitepackages() + [sysconfig.get_paths()["purelib"]] if Path(p).is_dir()]
    (purelib / "borrowed_site.pth").write_text("\n".join(dict.fromkeys(borrowed)) + "\n")
    installed = run(sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
                    "-q", str(wheel))
    assert installed.returncode == 0, installed.stderr
    return env_dir


def outside_run(venv: Path, tmp_path: Path, source: str) -> subprocess.CompletedProcess:
    project = tmp_path / "their_project"
    project.mkdir()
    (project / "test_their_driver.py").write_text(source)
    return run(str(venv / "bin" / "python"), "-m", "pytest", "-q", "-p", "no:cacheprovider", str(project),
               cwd=project)


def test_the_plugin_comes_from_the_installed_wheel(venv):
    where = run(str(venv / "bin" / "python"), "-c", "import fixtures.pytest_plugin as p; print(p.__file__)",
                cwd=venv)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(venv) and not Path(where.stdout.strip()).is_relative_to(ROOT)


def test_an_outside_project_passes_with_the_plugin_fixtures(venv, tmp_path):
    done = outside_run(venv, tmp_path, OUTSIDE)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "3 passed" in done.stdout


def test_an_outside_project_with_a_wrong_expectation_fails(venv, tmp_path):
    done = outside_run(venv, tmp_path, OUTSIDE.replace("EXPECTED_DEVID = 0xE5", "EXPECTED_DEVID = 0xE6"))
    assert done.returncode == 1 and "1 failed, 2 passed" in done.stdout, done.stdout + done.stderr
