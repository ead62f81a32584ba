"""The Python API: array shapes and dtypes, setters, scenes built in code, outputs, errors."""

import math
import os

import numpy as np
import pytest

import clatter

from conftest import PILE, ROOT, require


@pytest.fixture
def pile():
    return clatter.Simulation(clatter.Scene.from_toml(PILE, "pile.toml"), backend="cpu")


def test_state_arrays_have_numpy_shapes_and_dtypes(pile):
    n = pile.n_bodies
    assert n == len(pile) == 16 + 9 + 4
    for name, cols in [("positions", 3), ("orientations", 4), ("velocities", 3), ("angular_velocities", 3)]:
        a = getattr(pile, name)
        # Positions are kept in double precision, the rest in single.
        dtype = np.float64 if name == "positions" else np.float32
        assert isinstance(a, np.ndarray) and a.shape == (n, cols) and a.dtype == dtype, name
        assert a.flags.c_contiguous and a.flags.writeable
    for name in ["masses", "radii"]:
        a = getattr(pile, name)
        assert a.shape == (n,) and a.dtype == np.float32
    for name in ["shape_ids", "material_ids"]:
        a = getattr(pile, name)
        assert a.shape == (n,) and a.dtype == np.int64
    assert list(np.bincount(pile.shape_ids)) == [16, 9, 4]
    np.testing.assert_allclose(np.linalg.norm(pile.orientations, axis=1), 1.0, atol=1e-6)
    assert pile.gravity.tolist() == pytest.approx([0, 0, -9.81])
    assert isinstance(pile.dt, float) and pile.dt == pytest.approx(2e-5)
    assert pile.step_count == 0 and pile.time == 0.0


def test_contacts_dict_of_arrays(pile):
    pile.step(1600)
    c = pile.contacts()
    m = len(c["body"])
    assert m > 5
    expect = {"body": (m,), "other": (m,), "wall": (m,), "boundary": (m,), "point": (m, 3),
              "point_count": (m,),
              "normal": (m, 3), "depth": (m,), "force": (m, 3), "normal_force": (m,)}
    assert {k: v.shape for k, v in c.items()} == expect
    for k in ["body", "other", "wall", "boundary", "point_count"]:
        assert c[k].dtype == np.int64
    # No mesh boundaries in this scene.
    assert np.all(c["boundary"] == -1)
    assert c["point"].dtype == np.float64
    for k in ["normal", "depth", "force", "normal_force"]:
        assert c[k].dtype == np.float32
    walls = c["wall"] >= 0
    assert walls.any() and (~walls).any()
    assert np.all(c["other"][walls] == -1) and np.all(c["wall"][~walls] == -1)
    assert np.all(c["body"][~walls] < c["other"][~walls])
    assert np.all((c["point_count"] >= 1) & (c["point_count"] <= 4))
    np.testing.assert_allclose(np.linalg.norm(c["normal"], axis=1), 1.0, atol=1e-5)
    assert np.all(c["depth"] > 0)
    # The force on `body` pushes it away from the other side, against the normal: its normal
    # part is -normal_force (positive when pushing apart; the dashpot can pull while
    # separating).
    along = np.einsum("ij,ij->i", c["force"], c["normal"])
    np.testing.assert_allclose(along, -c["normal_force"], atol=1e-3 * np.abs(c["normal_force"]).max())
    assert np.mean(c["normal_force"] > 0) > 0.8
    # The floor (the container's walls are x-min, x-max, y-min, y-max, then z-min) pushes up.
    floor = c["wall"] == 4
    assert floor.any()
    np.testing.assert_allclose(c["normal"][floor], np.tile([0, 0, -1], (floor.sum(), 1)), atol=1e-6)
    # Its force is vertical, up by the normal force (the dashpot pulls on a body leaving it),
    # and up for most of its contacts.
    np.testing.assert_allclose(c["force"][floor][:, 2], c["normal_force"][floor],
                               atol=1e-3 * np.abs(c["normal_force"]).max())
    assert np.mean(c["force"][floor][:, 2] > 0) > 0.8


def test_setters_move_bodies_and_are_checked(pile):
    n = pile.n_bodies
    pos = pile.positions
    pos[:, 2] += 0.5  # lift everything well clear of the floor
    pile.positions = pos
    np.testing.assert_array_equal(pile.positions, pos)
    pile.velocities = np.zeros((n, 3))  # float64 input is accepted
    pile.angular_velocities = np.tile([0.0, 0.0, 2.0], (n, 1))
    np.testing.assert_allclose(pile.angular_velocities, np.tile([0, 0, 2.0], (n, 1)))
    e_rot = pile.kinetic_energy()
    assert e_rot > 0
    pile.step(10)
    # Free fall for 10 steps: every body has gained the same downward speed.
    np.testing.assert_allclose(pile.velocities[:, 2], -9.81 * 10 * pile.dt, rtol=1e-4)
    with pytest.raises(ValueError, match=r"positions must have shape \(29, 3\)"):
        pile.positions = np.zeros((3, 3))
    with pytest.raises(ValueError, match=r"velocities\[2\] must be finite"):
        v = np.zeros((n, 3))
        v[2, 1] = np.nan
        pile.velocities = v
    with pytest.raises(ValueError):
        pile.positions = "not an array"
    # Finite as float64 but not as float32: refused (1e39 made the next step never end).
    for name in ("positions", "velocities", "angular_velocities"):
        v = np.zeros((n, 3))
        v[1, 0] = 1e39
        with pytest.raises(ValueError, match=rf"{name}\[1\] must be finite"):
            setattr(pile, name, v)


def test_scene_builder_writes_the_scene_format():
    scene = (
        clatter.Scene(duration=0.01, gravity=[0, 0, -1.62])
        .material("rock", density=2600, model="hertz", youngs_modulus=1e7, poisson_ratio=0.25, restitution=0.5)
        .shape("pebble", convex=np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01], [0.01, 0.01, 0.01]]))
        .shape("grain", sphere={"radius": 0.003})
        .wall([0, 0, 0], [0, 0, 1], "rock")
        .bodies("grain", "rock", np.array([[0, 0, 0.01], [0.02, 0, 0.01]]), velocities=[[0, 0, -1], [0, 0, -2]])
        .body("pebble", "rock", position=(0.05, 0, 0.02))
    )
    text = scene.to_toml()
    assert "[simulation]\nduration = 0.01\ngravity = [0, 0, -1.62]" in text
    assert 'model = "hertz"' in text and "[[body]]" in text
    assert scene.n_bodies == 3 and scene.n_walls == 1 and scene.duration == 0.01
    reparsed = clatter.Scene.from_toml(text)
    sim = clatter.Simulation(reparsed, backend="cpu")
    np.testing.assert_allclose(sim.velocities[:2], [[0, 0, -1], [0, 0, -2]])
    np.testing.assert_allclose(sim.gravity, [0, 0, -1.62], rtol=1e-6)
    assert sim.dt > 0 and scene.steps == math.ceil(0.01 / sim.dt - 1e-6)


def test_simulation_calls_add_to_one_table_and_bodies_check_shapes(tmp_path):
    # Scene(duration=...) then .simulation(periodic=...): one [simulation] table with both.
    scene = (
        clatter.Scene(duration=0.01)
        .simulation(periodic={"min": [0, 0, 0], "max": [1, 1, 1], "axes": "xy"})
        .material("m", density=1000, stiffness=1e5)
        .shape("b", sphere=0.1)
        .body("b", "m", [0.5, 0.5, 0.5])
    )
    text = scene.to_toml()
    assert text.count("[simulation]") == 1 and "duration = 0.01" in text and "periodic" in text
    scene.validate()
    assert scene.duration == 0.01
    # steps replaces duration.
    assert "duration" not in clatter.Scene(duration=1).simulation(steps=5).to_toml()
    # A file's scene keeps its own table.
    with pytest.raises(ValueError, match=r"has its own \[simulation\] table"):
        clatter.Scene.from_toml(PILE).simulation(dt=1e-5)
    base = clatter.Scene(steps=5).material("m", density=1000, stiffness=1e5).shape("b", sphere=0.01)
    with pytest.raises(ValueError, match=r"positions must have shape \(K, 3\)"):
        base.bodies("b", "m", np.arange(6.0).reshape(3, 2))
    with pytest.raises(ValueError, match="velocities must have the shape of positions"):
        base.bodies("b", "m", np.zeros((4, 3)), velocities=np.zeros((8, 3)))
    with pytest.raises(ValueError, match=r"already has a \[container\]"):
        base.container([0, 0, 0], [1, 1, 1], "m").container([0, 0, 0], [2, 2, 2], "m")
    # A duration below dt runs one step (ceil), not none.
    one = clatter.Scene(duration=1e-9, dt=1e-3).material("m", density=1000, stiffness=1e5)
    assert one.shape("b", sphere=0.01).body("b", "m", [0, 0, 0]).steps == 1


def test_scene_from_file_can_be_extended(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("[simulation]\nsteps = 5\n[[material]]\nname = 'm'\ndensity = 1000\nstiffness = 100\n[[shape]]\nname = 'b'\nsphere = { radius = 0.01 }\n")
    with pytest.raises(clatter.SceneError, match="no bodies"):
        clatter.Scene.from_file(path)
    scene = clatter.Scene.from_toml(path.read_text() + "[[body]]\nshape='b'\nmaterial='m'\nposition=[0,0,0]\n", str(path))
    scene.body("b", "m", [0.1, 0, 0]).group("b", "m", lattice={"min": [1, 1, 1], "max": [1.04, 1, 1], "spacing": 0.02})
    assert scene.n_bodies == 1 + 1 + 3
    assert scene.source == str(path)


def test_example_scenes_load_from_any_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # far from the repository's scenes/
    scene = clatter.Scene.example("dice-box")
    on_disk = clatter.Scene.from_file(ROOT / "scenes" / "dice-box.toml")
    assert scene.to_toml() == on_disk.to_toml() and scene.n_bodies == on_disk.n_bodies > 0
    assert clatter.Scene.example("dice-box.toml").n_bodies == scene.n_bodies
    sim = clatter.Simulation(scene, backend="cpu")
    sim.step(5)
    # Every scene of scenes/ that reads no mesh file is embedded, and the small ones load.
    meshless = sorted(p.stem for p in (ROOT / "scenes").glob("*.toml") if "file =" not in p.read_text())
    assert sorted(clatter.EXAMPLE_SCENES) == meshless
    for name in clatter.EXAMPLE_SCENES:
        if not name.startswith("bench-"):
            assert clatter.Scene.example(name).n_bodies > 0, name
    with pytest.raises(ValueError, match="no example scene `dice`; the examples are: .*dice-box"):
        clatter.Scene.example("dice")


def test_builder_errors_name_the_field():
    scene = clatter.Scene(steps=10).material("m", density=1000, stiffness=100).shape("s", sphere=0.01).body("s", "m", [0, 0, 0], velocity=[0, 0, float("inf")])
    with pytest.raises(clatter.SceneError) as info:
        clatter.Simulation(scene)
    assert info.value.field == "body[0].velocity"
    assert "three finite numbers" in info.value.message
    with pytest.raises(clatter.SceneError, match="missing table \\[simulation\\]"):
        clatter.Scene().material("m", density=1, stiffness=1).validate()
    with pytest.raises(clatter.SceneError, match="unknown shape `nope`"):
        clatter.Scene(steps=1).material("m", density=1, stiffness=1).body("nope", "m", [0, 0, 0]).validate()
    with pytest.raises(TypeError, match="cannot write a object"):
        clatter.Scene(steps=1).material("m", density=object())


def test_material_takes_every_coefficient_of_the_rust_table():
    names = [c["name"] for c in clatter.MATERIAL_COEFFICIENTS]
    assert names[:4] == ["restitution", "friction", "rolling_friction", "spinning_friction"]
    defaults = {c["name"]: c["default"] for c in clatter.MATERIAL_COEFFICIENTS}
    assert defaults["restitution"] == 0.5 and defaults["friction"] == 0.3 and defaults["rolling_friction"] == 0
    doc = clatter.Scene.material.__doc__
    assert all(f"``{n}``" in doc for n in names) and "{coefficients}" not in doc
    text = clatter.Scene(steps=1).material("m", density=1, stiffness=1, spinning_friction=0.2, friction=0.4).to_toml()
    # The scene file's key order, whatever the keywords' order.
    assert "stiffness = 1\nfriction = 0.4\nspinning_friction = 0.2\n" in text
    with pytest.raises(TypeError, match="unexpected keyword argument 'rolling_fricton' \\(material coefficients: restitution, friction, rolling_friction"):
        clatter.Scene(steps=1).material("m", density=1, stiffness=1, rolling_fricton=0.1)
    with pytest.raises(clatter.SceneError) as info:
        clatter.Scene(steps=1).material("m", density=1, stiffness=1, rolling_friction=-1).validate()
    assert info.value.field == "material[0].rolling_friction" and ">= 0" in info.value.message


def test_bad_arguments_raise_clear_errors(tmp_path):
    scene = clatter.Scene.from_toml(PILE)
    with pytest.raises(ValueError, match='backend must be "auto", "cpu" or "gpu"'):
        clatter.Simulation(scene, backend="tpu")
    with pytest.raises(ValueError, match="threads must be at least 1"):
        clatter.Simulation(scene, threads=0)
    with pytest.raises(ValueError, match="threads=100000 is more than"):
        clatter.Simulation(scene, threads=100000)
    with pytest.raises(TypeError, match="scene must be a clatter.Scene"):
        clatter.Simulation(42)
    with pytest.raises(OSError, match="cannot read"):
        clatter.Simulation.from_checkpoint(tmp_path / "none.ckpt")
    junk = tmp_path / "junk.ckpt"
    junk.write_bytes(b"hello, not a checkpoint")
    with pytest.raises(clatter.CheckpointError, match="not a clatter checkpoint"):
        clatter.Simulation.from_checkpoint(junk)


def test_blow_up_raises_simulation_error():
    # A time step far too large for the stiffness: the overlap explodes and the bodies gain
    # energy at every wall; the run stops with clatter run's report (energy growth or a
    # non-finite state, whichever the checks see first).
    scene = (
        clatter.Scene(steps=1, dt=0.01)
        .material("m", density=1000, stiffness=1e9)
        .shape("s", sphere=0.01)
        .container(min=[-0.05] * 3, max=[0.05] * 3, material="m")
        .body("s", "m", [0, 0, 0])
        .body("s", "m", [0.019, 0, 0])
    )
    sim = clatter.Simulation(scene, backend="cpu")
    with pytest.raises(clatter.SimulationError, match="blew up at step .*Likely cause"):
        sim.step(1000)


def test_path_is_accepted_as_a_scene(pile_file):
    sim = clatter.Simulation(pile_file, backend="cpu")
    assert sim.source == str(pile_file) and sim.n_bodies == 29
    assert "[[group]]" in sim.scene_toml


def test_checkpoint_round_trip_is_bitwise(pile, tmp_path):
    pile.step(120)
    pile.save_checkpoint(tmp_path / "a.ckpt")
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())
    pile.step(80)
    other = clatter.Simulation.from_checkpoint(tmp_path / "a.ckpt", backend="cpu", threads=1)
    other.step(80)
    for name in ["positions", "orientations", "velocities", "angular_velocities"]:
        np.testing.assert_array_equal(getattr(other, name), getattr(pile, name), err_msg=name)
    assert other.kinetic_energy() == pile.kinetic_energy()


def test_write_vtk_series(pile, tmp_path):
    out = tmp_path / "vtk"
    pile.step(1600)
    first = pile.write_vtk(out)
    assert [p.name for p in first] == ["bodies_001600.vtu", "contacts_001600.vtu"]
    pile.step(100)
    pile.write_vtk(out, contacts=False)
    pvd = (out / "bodies.pvd").read_text()
    assert 'file="bodies_001600.vtu"' in pvd and 'file="bodies_001700.vtu"' in pvd
    assert "contacts_001700" not in (out / "contacts.pvd").read_text()
    try:
        import meshio
    except ImportError:
        require(False, "meshio is not installed (pip install meshio): the VTK files are not read back")
        return
    mesh = meshio.read(out / "bodies_001700.vtu")
    np.testing.assert_array_equal(mesh.points, pile.positions)
    np.testing.assert_array_equal(mesh.point_data["velocity"], pile.velocities)
    np.testing.assert_array_equal(mesh.point_data["orientation"], pile.orientations)
    contacts = meshio.read(out / "contacts_001600.vtu")
    assert len(contacts.points) > 0


def test_energies():
    scene = (
        clatter.Scene(steps=1, dt=1e-4, gravity=[0, 0, -10])
        .material("m", density=1000, stiffness=100)
        .shape("s", sphere=0.1)
        .body("s", "m", [0, 0, 2.0], velocity=[3.0, 0, 0], angular_velocity=[0, 0, 5.0])
    )
    sim = clatter.Simulation(scene, backend="cpu")
    m = 1000 * 4 / 3 * math.pi * 0.1**3
    inertia = 0.4 * m * 0.1**2
    assert sim.kinetic_energy() == pytest.approx(0.5 * m * 9 + 0.5 * inertia * 25, rel=1e-5)
    assert sim.potential_energy() == pytest.approx(m * 10 * 2.0, rel=1e-5)
    assert sim.momentum() == pytest.approx((3 * m, 0, 0), rel=1e-5)


def test_step_releases_the_gil(pile):
    import threading
    import time

    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    start = time.perf_counter()
    pile.step(3000)
    took = time.perf_counter() - start
    stop.set()
    t.join()
    during = [x for x in ticks if start < x < start + took]
    # Without releasing the GIL the ticker would be frozen for the whole step call.
    assert took < 0.05 or len(during) >= 5, (took, len(during))


def test_removed_bodies_are_flagged():
    sim = clatter.Simulation(clatter.Scene.example("sink-floor"), backend="cpu")
    assert sim.removed.dtype == np.bool_ and sim.removed.shape == (sim.n_bodies,)
    assert not sim.removed.any()
    sim.step(4000)
    removed = sim.removed
    assert removed.any() and not removed.all()
    # The momentum is the kept bodies' alone: the arrays' sum over them.
    kept = ~removed
    p = (sim.masses[kept, None].astype(np.float64) * sim.velocities[kept]).sum(axis=0)
    np.testing.assert_allclose(sim.momentum(), p, rtol=1e-5, atol=1e-12)
