"""The Python module against the `clatter` command line on the same scenes."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

import clatter

from conftest import ROOT


def run_cli(bin_, *args, check=True):
    r = subprocess.run([bin_, *map(str, args)], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"clatter {' '.join(map(str, args))} failed ({r.returncode}):\n{r.stderr}")
    return r


def final_csv(path: Path) -> tuple:
    """final.csv as (positions float64, the rest float32): the CLI prints each value with the
    shortest text that reads back to it (positions are f64, the rest f32), so this is
    bitwise the state."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
    assert open(path).readline().strip() == "id,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz"
    return data[:, 1:4], data[:, 4:].astype(np.float32)


def state(sim) -> tuple:
    return sim.positions, np.hstack([sim.orientations, sim.velocities, sim.angular_velocities])


def assert_bitwise(a: tuple, b: tuple) -> None:
    for x, y in zip(a, b):
        assert x.shape == y.shape and x.dtype == y.dtype
        bits = np.uint64 if x.dtype == np.float64 else np.uint32
        bad = np.flatnonzero(x.view(bits) != y.view(bits))
        assert bad.size == 0, f"{bad.size} values differ, first at {np.unravel_index(bad[0], x.shape)}: {x.flat[bad[0]]!r} vs {y.flat[bad[0]]!r}"


@pytest.mark.parametrize("threads", [1, 2])
def test_run_matches_cli_bitwise(clatter_bin, pile_file, tmp_path, threads):
    out = tmp_path / "out"
    run_cli(clatter_bin, "run", pile_file, "--out", out, "--backend", "cpu", "--quiet")
    scene = clatter.Scene.from_file(pile_file)
    sim = clatter.Simulation(scene, backend="cpu", threads=threads)
    sim.step(scene.steps)
    assert sim.step_count == 400
    assert_bitwise(state(sim), final_csv(out / "final.csv"))
    # The summary's kinetic energy is the same f64 sum.
    import json

    summary = json.loads((out / "summary.json").read_text())
    assert summary["kinetic_energy"] == sim.kinetic_energy()
    assert summary["simulated_time"] == sim.time


def test_scene_built_in_code_runs_like_its_toml_in_the_cli(clatter_bin, tmp_path):
    scene = (
        clatter.Scene(steps=300, dt=2e-5)
        .material("wood", density=700.0, stiffness=3e3, restitution=0.6, friction=0.5)
        .shape("d12", polyhedron={"kind": "dodecahedron", "radius": 0.008})
        .shape("brick", box=[0.01, 0.005, 0.004])
        .container(min=[0, 0, 0], max=[0.06, 0.06, 0.1], material="wood", top=False)
        .group("d12", "wood", random=dict(min=[0.01, 0.01, 0.01], max=[0.05, 0.05, 0.05], count=12, seed=3), random_orientation=True)
        .body("brick", "wood", position=[0.03, 0.03, 0.07], velocity=[0, 0, -0.5], orientation=[0.9, 0.3, 0.1, 0.0])
    )
    path = tmp_path / "built.toml"
    scene.save(path)
    run_cli(clatter_bin, "run", path, "--out", tmp_path / "out", "--backend", "cpu", "--quiet")
    sim = clatter.Simulation(scene, backend="cpu")
    assert sim.n_bodies == 13
    sim.step(300)
    assert_bitwise(state(sim), final_csv(tmp_path / "out" / "final.csv"))


def test_python_checkpoint_resumes_in_cli_and_back(clatter_bin, pile_file, tmp_path):
    sim = clatter.Simulation(clatter.Scene.from_file(pile_file), backend="cpu")
    sim.step(150)
    ckpt = tmp_path / "py.ckpt"
    sim.save_checkpoint(ckpt)
    # Python continues...
    sim.step(100)
    # ...the CLI continues the same checkpoint...
    run_cli(clatter_bin, "resume", ckpt, "--steps", 100, "--out", tmp_path / "out", "--backend", "cpu", "--quiet")
    assert_bitwise(state(sim), final_csv(tmp_path / "out" / "final.csv"))
    # ...and so does a Simulation restored from it.
    again = clatter.Simulation.from_checkpoint(ckpt, backend="cpu")
    assert again.step_count == 150
    again.step(100)
    assert_bitwise(state(again), state(sim))
    assert again.time == sim.time


def test_cli_checkpoint_loads_in_python(clatter_bin, pile_file, tmp_path):
    out = tmp_path / "out"
    run_cli(clatter_bin, "run", pile_file, "--out", out, "--backend", "cpu", "--quiet", "--steps", 200, "--checkpoint-every", 0.002)
    sim = clatter.Simulation.from_checkpoint(out / "checkpoint.ckpt", backend="cpu")
    assert sim.step_count == 200
    assert_bitwise(state(sim), final_csv(out / "final.csv"))


BAD_SCENES = [
    ("[simulation]\nduration = 1\n[[material]]\nname = 'a'\ndensity = -1\nstiffness = 1\n", "material[0].density", 5),
    ("[simulation]\nsteps = 10\n[[material]]\nname = 'a'\ndensity = 1\nstiffness = 1\n[[shape]]\nname = 's'\nsphere = { radius = 1 }\n[[body]]\nshape = 'nope'\nmaterial = 'a'\nposition = [0, 0, 0]\n",
     "body[0].shape", 11),
    ("[simulation]\nsteps = 10\nbogus = 3\n", "simulation.bogus", 3),
]


@pytest.mark.parametrize("text,field,line", BAD_SCENES)
def test_scene_errors_match_the_cli(clatter_bin, tmp_path, text, field, line):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(clatter.SceneError) as info:
        clatter.Scene.from_file(path)
    e = info.value
    assert e.file == str(path)
    assert e.line == line and e.column >= 1
    assert e.field == field
    assert str(e).startswith(f"{path}:{line}:{e.column}: ")
    assert e.message in str(e)
    r = run_cli(clatter_bin, "run", path, "--backend", "cpu", check=False)
    assert r.returncode != 0
    assert str(e) in r.stderr, f"the CLI says:\n{r.stderr}\nPython says:\n{e}"
    # The same text through from_toml, under the same name, gives the same message.
    with pytest.raises(clatter.SceneError) as again:
        clatter.Scene.from_toml(text, str(path))
    assert str(again.value) == str(e)


def test_missing_scene_file_matches_the_cli(clatter_bin, tmp_path):
    path = tmp_path / "missing.toml"
    with pytest.raises(clatter.SceneError) as info:
        clatter.Scene.from_file(path)
    assert "cannot read the scene file" in str(info.value)
    assert info.value.line is None
    r = run_cli(clatter_bin, "run", path, check=False)
    assert str(info.value) in r.stderr


def test_every_example_scene_loads():
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        scene = clatter.Scene.from_file(path)
        assert scene.n_bodies > 0, path
    assert clatter.Scene.default().n_bodies == clatter.Scene.from_file(ROOT / "scenes" / "default.toml").n_bodies
