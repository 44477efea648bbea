"""The examples of examples/python run as a user runs them (a fresh process, the installed
package, no matplotlib needed): the issue's "done when" is that they work."""

import subprocess
import sys

import pytest

from conftest import ROOT


@pytest.mark.parametrize("name", ["quickstart", "sweep", "python_load", "quasi_static"])
def test_example_runs(name, tmp_path):
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "python" / f"{name}.py")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip(), "the example printed nothing"
