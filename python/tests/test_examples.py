"""The examples in examples/python run and write their pictures."""

import subprocess
import sys

import pytest

from conftest import ROOT

EXAMPLES = ROOT / "examples" / "python"


@pytest.mark.parametrize(
    "script,args,outputs",
    [
        ("pile.py", ["--bodies", "60", "--duration", "0.05", "--backend", "cpu"], ["energy.png", "contact_forces.png", "scene.toml"]),
        ("restitution_sweep.py", ["--points", "3"], ["restitution.png", "restitution.csv"]),
    ],
)
def test_example_runs(tmp_path, script, args, outputs):
    r = subprocess.run([sys.executable, str(EXAMPLES / script), "--out", str(tmp_path), *args],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for name in outputs:
        data = (tmp_path / name).read_bytes()
        assert len(data) > 100, name
        if name.endswith(".png"):
            assert data[:8] == b"\x89PNG\r\n\x1a\n"
    if script == "restitution_sweep.py":
        import numpy as np

        table = np.loadtxt(tmp_path / "restitution.csv", delimiter=",", skiprows=1)
        np.testing.assert_allclose(table[:, 1], table[:, 0], atol=0.02)


@pytest.mark.parametrize("script", ["pile.py", "restitution_sweep.py"])
def test_example_without_matplotlib_says_how_to_install_it(tmp_path, script):
    # `sys.modules["matplotlib"] = None` makes `import matplotlib` fail as if it were missing.
    hide = ("import runpy, sys; sys.modules['matplotlib'] = None; sys.argv = [sys.argv[1]]; "
            "runpy.run_path(sys.argv[0], run_name='__main__')")
    r = subprocess.run([sys.executable, "-c", hide, str(EXAMPLES / script)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs matplotlib" in lines[0] and "pip install './python[examples]'" in lines[0], r.stderr
