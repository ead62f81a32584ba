"""Physics through the Python API against closed-form answers."""

import math

import numpy as np
import pytest

import clatter

G = 9.81


def ball_scene(z0, *, restitution=0.8, stiffness=1e5, radius=0.01, dt=None, steps=1, wall=True, vz=0.0):
    scene = clatter.Scene(steps=steps, dt=dt).material(
        "steel", density=7800.0, stiffness=stiffness, restitution=restitution, friction=0.3
    ).shape("ball", sphere=radius)
    if wall:
        scene.wall(point=[0, 0, 0], normal=[0, 0, 1], material="steel")
    return scene.body("ball", "steel", position=[0.0, 0.0, z0], velocity=[0.1, -0.2, vz])


def test_free_fall_is_semi_implicit_euler():
    # No contact: v_n = v0 + n g dt and x_n = x0 + n dt v0 + g dt^2 n (n + 1) / 2 exactly
    # (up to f32 rounding), and within g dt t / 2 of the continuous parabola.
    dt, n = 1e-3, 500
    sim = clatter.Simulation(ball_scene(10.0, dt=dt, wall=False, vz=1.5), backend="cpu")
    assert sim.dt == pytest.approx(dt, rel=1e-6)
    sim.step(n)
    assert sim.step_count == n
    dtf = float(np.float32(dt))
    assert sim.time == pytest.approx(n * dtf, rel=1e-9)
    v = np.array([0.1, -0.2, 1.5]) + np.array([0, 0, -G]) * n * dtf
    x = np.array([0, 0, 10.0]) + n * dtf * np.array([0.1, -0.2, 1.5]) + np.array([0, 0, -G]) * dtf**2 * n * (n + 1) / 2
    np.testing.assert_allclose(sim.velocities[0], v, rtol=0, atol=1e-4)
    np.testing.assert_allclose(sim.positions[0], x, rtol=0, atol=1e-4)
    # The continuous parabola lies g dt t / 2 (2.5 mm here) above: semi-implicit, not explicit
    # Euler (which would be as far below).
    t = n * dtf
    parabola = 10.0 + 1.5 * t - G * t * t / 2
    assert sim.positions[0, 2] - parabola == pytest.approx(-G * dtf * t / 2, abs=1e-4)


def test_bounce_restitution_and_height():
    # Dropped from h: impact speed sqrt(2 g h); the linear spring-dashpot with damping from
    # e rebounds at e times the impact speed (gravity during the short contact aside), so the
    # next apex is e^2 h.
    e, h, r = 0.8, 0.05, 0.01
    scene = ball_scene(h + r, restitution=e, dt=1e-5, steps=1)
    sim = clatter.Simulation(scene, backend="cpu")
    v_in = math.sqrt(2 * G * h)
    # Step to just after the contact ends (the ball moves up and touches nothing).
    vz_max_down, rebound = 0.0, None
    for _ in range(4000):
        sim.step(10)
        vz = float(sim.velocities[0, 2])
        vz_max_down = min(vz_max_down, vz)
        if vz > 0 and len(sim.contacts()["body"]) == 0:
            rebound = vz
            break
    assert rebound is not None, "the ball never left the floor"
    assert -vz_max_down == pytest.approx(v_in, rel=3e-3)
    assert rebound / v_in == pytest.approx(e, rel=0.02)
    # Apex of the next flight.
    apex = 0.0
    while float(sim.velocities[0, 2]) > 0:
        sim.step(100)
        apex = max(apex, float(sim.positions[0, 2]) - r)
    assert apex == pytest.approx(e * e * h, rel=0.04)


def test_resting_contact_force_balances_weight():
    r, k = 0.01, 1e5
    scene = ball_scene(r, restitution=0.3, stiffness=k, dt=1e-5, steps=1)
    sim = clatter.Simulation(scene, backend="cpu")
    sim.velocities = np.zeros((1, 3))
    sim.step(20000)
    m = float(sim.masses[0])
    assert m == pytest.approx(7800 * 4 / 3 * math.pi * r**3, rel=1e-5)
    c = sim.contacts()
    assert list(c["body"]) == [0] and list(c["other"]) == [-1] and list(c["wall"]) == [0]
    np.testing.assert_allclose(c["normal"][0], [0, 0, -1], atol=1e-6)
    np.testing.assert_allclose(c["force"][0], [0, 0, m * G], rtol=1e-3, atol=1e-6)
    assert c["normal_force"][0] == pytest.approx(m * G, rel=1e-3)
    assert c["depth"][0] == pytest.approx(m * G / k, rel=0.02)
    np.testing.assert_allclose(c["point"][0][:2], sim.positions[0][:2], atol=1e-6)


def test_momentum_is_conserved_without_gravity_and_walls():
    scene = (
        clatter.Scene(steps=1, dt=1e-5, gravity=[0, 0, 0])
        .material("m", density=1000.0, stiffness=1e3, restitution=0.7)
        .shape("cube", polyhedron={"kind": "cube", "radius": 0.01})
        .shape("ball", sphere=0.008)
        .body("cube", "m", position=[0, 0, 0], velocity=[1.0, 0, 0], orientation=[0.9, 0.1, 0.3, 0.2])
        .body("ball", "m", position=[0.03, 0.002, 0.001], velocity=[-1.0, 0.1, 0])
    )
    sim = clatter.Simulation(scene, backend="cpu")
    p0 = np.array(sim.momentum())
    touched = 0
    for _ in range(40):
        sim.step(100)
        touched += len(sim.contacts()["body"]) > 0
    assert touched, "the bodies never met"
    assert sim.velocities[0, 0] < 1.0 and sim.velocities[1, 0] > -1.0
    # The pair's forces are equal and opposite, so what is left is the rounding of the f32
    # velocities: at most half an ulp of |v| <= 1 m/s (2^-24) per body per step in contact
    # (counted by the 100-step blocks that had a contact, one more for the block it began
    # in). A force applied to one side only, or a missed sign, is orders of magnitude more.
    m = np.array(sim.masses)
    steps = 100 * (touched + 1)
    rounding = steps * 2.0**-24 * (m * np.abs(sim.velocities).max(axis=1)).sum()
    np.testing.assert_allclose(sim.momentum(), p0, atol=rounding)
    assert rounding < 1e-3 * np.abs(p0).max()


def test_rolling_friction_stops_a_rolling_ball_over_the_analytic_distance():
    # Constant directional torque mu_r R m g: a rolling solid sphere decelerates at
    # 5/7 mu_r g and stops after u0^2 / (2 a).
    r, k, mu_r, u0, density = 0.01, 2e4, 0.1, 0.3, 2500.0
    m = density * 4.0 / 3.0 * math.pi * r**3
    scene = (
        clatter.Scene(steps=1)
        .material("m", density=density, stiffness=k, restitution=0.5, friction=0.8, rolling_friction=mu_r)
        .shape("ball", sphere=r)
        .wall(point=[0, 0, 0], normal=[0, 0, 1], material="m")
        .body("ball", "m", position=[0.0, 0.0, r - m * G / k], velocity=[u0, 0.0, 0.0],
              angular_velocity=[0.0, u0 / r, 0.0])
    )
    sim = clatter.Simulation(scene, backend="cpu")
    a = 5.0 / 7.0 * mu_r * G
    sim.step(int(1.3 * (u0 / a) / sim.dt))
    assert np.linalg.norm(sim.velocities[0]) < 1e-3 * u0
    assert sim.positions[0, 0] == pytest.approx(u0**2 / (2 * a), rel=0.02)


def test_periodic_box_wraps_positions():
    scene = (
        clatter.Scene()
        .simulation(steps=1, gravity=[0, 0, 0], periodic={"min": [0, 0, 0], "max": [0.1, 0.1, 0.1], "axes": "x"})
        .material("m", density=1000.0, stiffness=1e4)
        .shape("ball", sphere=0.005)
        .body("ball", "m", position=[0.095, 0.05, 0.05], velocity=[1.0, 0.0, 0.0])
    )
    sim = clatter.Simulation(scene, backend="cpu")
    sim.step(int(0.01 / sim.dt) + 1)
    # 1 m/s for 10 ms: 0.095 + 0.01 wraps to about 0.005.
    assert 0.0 <= sim.positions[0, 0] < 0.1
    assert sim.positions[0, 0] == pytest.approx(0.005, abs=2e-4)


def test_a_blow_up_raises_the_command_lines_message():
    # dt far above the stability bound of the contact: the run must stop with the body, the
    # step and the likely cause, as `clatter run` reports it, not return garbage.
    scene = ball_scene(0.0095, stiffness=1e5, dt=2e-3, steps=1)
    sim = clatter.Simulation(scene, backend="cpu")
    with pytest.raises(clatter.SimulationError) as err:
        sim.step(2000)
    text = str(err.value)
    assert "blew up at step" in text and "body 0" in text, text
    assert "Likely cause" in text and "time step" in text, text
    assert sim.step_count < 2000
    # The report's parts, as attributes.
    e = err.value
    assert e.body == 0 and 0 < e.step <= sim.step_count and e.time > 0, (e.body, e.step)
    assert e.kind in ("non_finite", "energy_growth", "escaped", "deep_overlap"), e.kind
    assert "time step" in e.cause, e.cause


def test_bodies_starting_deeply_overlapped_are_refused():
    scene = (
        clatter.Scene(steps=1, gravity=[0, 0, 0])
        .material("m", density=1000.0, stiffness=1e4)
        .shape("ball", sphere=0.01)
        .body("ball", "m", position=[0.0, 0.0, 0.0])
        .body("ball", "m", position=[0.005, 0.0, 0.0])
    )
    sim = clatter.Simulation(scene, backend="cpu")
    with pytest.raises(clatter.SimulationError, match="start overlapping"):
        sim.step()
