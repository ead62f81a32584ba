"""clatter.query against closed-form answers, and the vectorised form against single calls."""

import numpy as np
import pytest

import clatter

from conftest import require

SPHERE1 = {"sphere": {"radius": 1.0}}
SPHERE_HALF = {"sphere": {"radius": 0.5}}
CUBE = {"box": {"half_extents": [0.5, 0.5, 0.5]}}


def test_sphere_sphere_closed_form():
    r = clatter.query(SPHERE1, [0, 0, 0], SPHERE_HALF, [3, 4, 0], ["intersects", "distance", "toi"],
                      velocity_b=[-0.6, -0.8, 0], toi_horizon=10)
    assert r["intersects"] is False
    assert r["distance"] == pytest.approx(5 - 1.5, abs=1e-6)
    np.testing.assert_allclose(r["points"], [[0.6, 0.8, 0], [3 - 0.3, 4 - 0.4, 0]], atol=1e-6)
    np.testing.assert_allclose(r["normal"], [0.6, 0.8, 0], atol=1e-6)
    assert r["toi"] == pytest.approx(3.5, rel=1e-4)  # gap 3.5 closed at 1 m/s


def test_box_sphere_overlap_depth():
    r = clatter.query(CUBE, ([0, 0, 0], [1, 0, 0, 0]), SPHERE_HALF, [0.8, 0, 0], "contact")
    assert r["depth"] == pytest.approx(0.2, abs=1e-6)
    np.testing.assert_allclose(r["normal"], [1, 0, 0], atol=1e-6)
    assert r["contact_count"] == 1 and np.isnan(r["contacts"][1:]).all()
    # A rotated cube (45 degrees about z): its corner reaches sqrt(2)/2.
    q = [np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)]
    r = clatter.query(CUBE, ([0, 0, 0], q), SPHERE_HALF, [2.0, 0, 0], "distance")
    assert r["distance"] == pytest.approx(2.0 - np.sqrt(0.5) - 0.5, abs=1e-5)


def test_no_impact_is_nan():
    r = clatter.query(SPHERE1, [0, 0, 0], SPHERE1, [5, 0, 0], "toi", velocity_b=[1, 0, 0])
    assert np.isnan(r["toi"]) and np.isnan(r["toi_points"]).all()


def test_vectorised_equals_single_calls():
    rng = np.random.default_rng(1)
    m = 200
    pos_b = rng.uniform(-2, 2, (m, 3))
    quat_b = rng.normal(size=(m, 4))
    ico = {"polyhedron": {"kind": "icosahedron", "radius": 0.7}}
    many = clatter.query(CUBE, [0, 0, 0], ico, (pos_b, quat_b), ["intersects", "distance", "contact", "toi"],
                         velocity_b=-pos_b, toi_horizon=2.0)
    assert many["intersects"].shape == (m,) and many["intersects"].dtype == np.bool_
    assert many["distance"].shape == (m,) and many["distance"].dtype == np.float32
    assert many["points"].shape == (m, 2, 3) and many["contacts"].shape == (m, 4, 3)
    assert many["toi_normal"].shape == (m, 3) and many["contact_count"].dtype == np.int64
    assert 0 < many["intersects"].sum() < m
    for i in range(0, m, 17):
        one = clatter.query(CUBE, [0, 0, 0], ico, (pos_b[i], quat_b[i]), velocity_b=-pos_b[i], toi_horizon=2.0)
        for k, v in one.items():
            np.testing.assert_array_equal(np.asarray(v), many[k][i], err_msg=f"{k}[{i}]")
    # Overlapping pairs have zero distance and positive depth; separated ones the opposite.
    hit = many["intersects"]
    assert np.all(many["depth"][hit] >= 0) and np.all(many["depth"][~hit] < 0)
    np.testing.assert_allclose(many["distance"][~hit], -many["depth"][~hit], rtol=1e-4, atol=1e-5)


def test_matches_clatter_query_cli(clatter_bin):
    import json
    import subprocess

    line = {"a": {"shape": CUBE, "position": [0, 0, 0], "orientation": [0.9, 0.1, 0.2, 0.3]},
            "b": {"shape": {"polyhedron": {"kind": "tetrahedron", "radius": 0.6}}, "position": [0.9, 0.2, 0.1], "velocity": [-1, 0, 0]},
            "queries": ["distance", "contact", "toi"], "toi_horizon": 3}
    out = subprocess.run([clatter_bin, "query", "-"], input=json.dumps(line) + "\n", capture_output=True, text=True, check=True)
    cli = json.loads(out.stdout)
    r = clatter.query(line["a"]["shape"], (line["a"]["position"], line["a"]["orientation"]),
                      line["b"]["shape"], line["b"]["position"], line["queries"], velocity_b=[-1, 0, 0], toi_horizon=3)
    assert np.float32(cli["depth"]) == r["depth"]
    np.testing.assert_array_equal(np.float32(cli["points"]), r["points"])
    np.testing.assert_array_equal(np.float32(cli["normal"]), r["normal"])
    np.testing.assert_array_equal(np.float32(cli["contacts"]), r["contacts"][: r["contact_count"]])
    assert np.float32(cli["toi"]) == r["toi"]


def test_query_errors():
    with pytest.raises(clatter.QueryError, match="shape_a"):
        clatter.query({"sphere": {"radius": -1}}, [0, 0, 0], SPHERE1, [1, 0, 0])
    with pytest.raises(clatter.QueryError, match="unknown query"):
        clatter.query(SPHERE1, [0, 0, 0], SPHERE1, [1, 0, 0], ["volume"])
    with pytest.raises(clatter.QueryError, match="orientation_b\\[0\\] must be a non-zero quaternion"):
        clatter.query(SPHERE1, [0, 0, 0], SPHERE1, ([1, 0, 0], [0, 0, 0, 0]))
    with pytest.raises(clatter.QueryError, match="rows"):
        clatter.query(SPHERE1, np.zeros((3, 3)), SPHERE1, np.ones((4, 3)))
    with pytest.raises(clatter.QueryError, match="position_a\\[0\\] must be finite"):
        clatter.query(SPHERE1, [np.nan, 0, 0], SPHERE1, [1, 0, 0])
    with pytest.raises(clatter.QueryError, match="toi_horizon"):
        clatter.query(SPHERE1, [0, 0, 0], SPHERE1, [1, 0, 0], "toi", toi_horizon=-1)


def test_gpu_backend_follows_the_cpu():
    if not clatter.GPU_SUPPORT:
        require(False, "this module was built without GPU support")
    from conftest import PILE

    scene = clatter.Scene.from_toml(PILE)
    try:
        gpu = clatter.Simulation(scene, backend="gpu")
    except clatter.BackendError as e:
        require(False, f"no GPU adapter: {e}")
        return
    assert gpu.backend.startswith("gpu (")
    cpu = clatter.Simulation(scene, backend="cpu")
    gpu.step(300)
    cpu.step(300)
    assert gpu.step_count == 300 and gpu.time == pytest.approx(cpu.time)
    np.testing.assert_allclose(gpu.positions, cpu.positions, atol=2e-5)
    np.testing.assert_allclose(gpu.velocities, cpu.velocities, atol=2e-3)
    # A setter uploads the state again before the next GPU step.
    v = gpu.velocities
    v[:] = 0
    gpu.velocities = v
    cpu.velocities = v
    gpu.step(10)
    cpu.step(10)
    np.testing.assert_allclose(gpu.velocities, cpu.velocities, atol=2e-3)
    assert len(gpu.contacts()["body"]) > 0
