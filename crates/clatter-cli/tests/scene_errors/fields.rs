//! Scene fields and values: TOML syntax, unknown or missing keys, out-of-range numbers,
//! unknown names, placement and periodic settings.

use crate::harness::*;

#[test]
fn base_scene_is_valid() {
    clatter::scene::Scene::parse(BASE, "base.toml")
        .expect("the base scene of these tests is valid");
}

#[test]
fn toml_syntax_error() {
    let text = edit("density = 7800.0\n", "density = 7800.0.0\n");
    check("syntax", &text, "7800.0.0", &["invalid float"]);
}

#[test]
fn toml_unclosed_array() {
    // Arrays may span lines, so the parser only sees the problem at the next token: the
    // `[[material]]` header after the blank line.
    let text = edit(
        "gravity = [0.0, 0.0, -9.81]\n",
        "gravity = [0.0, 0.0, -9.81\n",
    );
    check("unclosed", &text, "[[material]]", &["expected `,`"]);
}

#[test]
fn wrong_value_type() {
    let text = edit("density = 7800.0\n", "density = \"heavy\"\n");
    check(
        "wrong-type",
        &text,
        "heavy",
        &["invalid type", "expected f64"],
    );
}

#[test]
fn unknown_top_level_key() {
    let text = format!("frobnicate = 1\n{BASE}");
    check("unknown-top", &text, "frobnicate", &["frobnicate"]);
}

#[test]
fn unknown_top_level_table() {
    let text = format!("{BASE}\n[[particle]]\nshape = \"ball\"\n");
    check("unknown-table", &text, "[[particle]]", &["particle"]);
}

#[test]
fn unknown_key_in_simulation() {
    let text = edit("steps = 10\n", "steps = 10\ntimestep = 1.0e-4\n");
    check("unknown-sim", &text, "timestep", &["timestep", "dt"]);
}

#[test]
fn unknown_key_in_body() {
    let text = format!("{BASE}colour = \"red\"\n");
    check("unknown-body", &text, "colour", &["colour", "position"]);
}

#[test]
fn unknown_key_in_shape_inline_table() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "sphere = { radius = 0.01, mass = 2.0 }",
    );
    check("unknown-inline", &text, "mass = 2.0", &["mass", "radius"]);
}

#[test]
fn missing_simulation_table() {
    let text = BASE.replace(
        "[simulation]\nsteps = 10\ngravity = [0.0, 0.0, -9.81]\n",
        "",
    );
    check_line("no-simulation", &text, 1, &["simulation"]);
}

#[test]
fn missing_run_length() {
    let text = edit("steps = 10\n", "");
    check(
        "no-length",
        &text,
        "[simulation]",
        &["simulation", "duration", "steps"],
    );
}

#[test]
fn missing_material_density() {
    let text = edit("density = 7800.0\n", "");
    check(
        "no-density",
        &text,
        "[[material]]",
        &["missing field", "density"],
    );
}

#[test]
fn missing_material_stiffness() {
    let text = edit("stiffness = 1.0e5\n", "");
    check(
        "no-stiffness",
        &text,
        "[[material]]",
        &["material[0].stiffness"],
    );
}

#[test]
fn missing_body_position() {
    let text = edit("position = [0.0, 0.0, 0.1]\n", "");
    check(
        "no-position",
        &text,
        "[[body]]",
        &["missing field", "position"],
    );
}

#[test]
fn negative_radius() {
    let text = edit("radius = 0.01", "radius = -0.01");
    check(
        "neg-radius",
        &text,
        "radius = -0.01",
        &["shape[0].sphere.radius", "-0.01"],
    );
}

#[test]
fn zero_radius() {
    let text = edit("radius = 0.01", "radius = 0.0");
    check(
        "zero-radius",
        &text,
        "radius = 0.0",
        &["shape[0].sphere.radius"],
    );
}

#[test]
fn zero_box_half_extent() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "box = { half_extents = [0.01, 0.0, 0.01] }",
    );
    check(
        "zero-box",
        &text,
        "half_extents",
        &["shape[0].box.half_extents[1]"],
    );
}

#[test]
fn negative_polyhedron_radius() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "polyhedron = { kind = \"cube\", radius = -1.0 }",
    );
    check(
        "neg-poly",
        &text,
        "polyhedron",
        &["shape[0].polyhedron.radius"],
    );
}

#[test]
fn negative_density() {
    let text = edit("density = 7800.0", "density = -7800.0");
    check(
        "neg-density",
        &text,
        "density",
        &["material[0].density", "positive"],
    );
}

#[test]
fn zero_density() {
    let text = edit("density = 7800.0", "density = 0.0");
    check(
        "zero-density",
        &text,
        "density",
        &["material[0].density", "positive"],
    );
}

#[test]
fn negative_stiffness() {
    let text = edit("stiffness = 1.0e5", "stiffness = -1.0e5");
    check(
        "neg-stiffness",
        &text,
        "stiffness",
        &["material[0].stiffness", "positive"],
    );
}

#[test]
fn zero_stiffness() {
    let text = edit("stiffness = 1.0e5", "stiffness = 0.0");
    check(
        "zero-stiffness",
        &text,
        "stiffness",
        &["material[0].stiffness", "positive"],
    );
}

#[test]
fn negative_friction() {
    let text = edit("friction = 0.3", "friction = -0.3");
    check("neg-friction", &text, "friction", &["material[0].friction"]);
}

#[test]
fn negative_rolling_friction() {
    let text = edit("friction = 0.3", "friction = 0.3\nrolling_friction = -0.1");
    check(
        "neg-rolling-friction",
        &text,
        "rolling_friction",
        &["material[0].rolling_friction", ">= 0"],
    );
}

#[test]
fn unknown_cohesion_model() {
    let text = edit(
        "friction = 0.3",
        "friction = 0.3\ncohesion = { model = \"jkr\", surface_energy = 0.1 }",
    );
    check(
        "cohesion-model",
        &text,
        "cohesion",
        &[
            "material[0].cohesion.model",
            "unknown cohesion model `jkr`",
            "dmt",
        ],
    );
}

#[test]
fn missing_surface_energy() {
    let text = edit(
        "friction = 0.3",
        "friction = 0.3\ncohesion = { model = \"dmt\" }",
    );
    check(
        "cohesion-energy",
        &text,
        "cohesion",
        &["material[0].cohesion.surface_energy", "missing"],
    );
}

#[test]
fn nan_position() {
    let text = edit("position = [0.0, 0.0, 0.1]", "position = [0.0, nan, 0.1]");
    check(
        "nan-position",
        &text,
        "position",
        &["body[0].position", "finite"],
    );
}

#[test]
fn inf_position() {
    let text = edit("position = [0.0, 0.0, 0.1]", "position = [0.0, 0.0, inf]");
    check(
        "inf-position",
        &text,
        "position",
        &["body[0].position", "finite"],
    );
}

#[test]
fn negative_inf_velocity() {
    let text = format!("{BASE}velocity = [-inf, 0.0, 0.0]\n");
    check(
        "inf-velocity",
        &text,
        "velocity",
        &["body[0].velocity", "finite"],
    );
}

#[test]
fn nan_gravity() {
    let text = edit("gravity = [0.0, 0.0, -9.81]", "gravity = [0.0, 0.0, nan]");
    check("nan-gravity", &text, "gravity", &["simulation.gravity"]);
}

#[test]
fn nan_convex_point() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "convex = { points = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, nan, 0.0], [0.0, 0.0, 0.01]] }",
    );
    check("nan-point", &text, "convex", &["shape[0].convex.points[2]"]);
}

#[test]
fn zero_quaternion() {
    let text = format!("{BASE}orientation = [0.0, 0.0, 0.0, 0.0]\n");
    check("zero-quat", &text, "orientation", &["body[0].orientation"]);
}

#[test]
fn unknown_shape_name() {
    let text = edit("shape = \"ball\"", "shape = \"bal\"");
    check(
        "unknown-shape",
        &text,
        "shape = \"bal\"",
        &["body[0].shape", "unknown shape `bal`", "ball"],
    );
}

#[test]
fn unknown_material_name() {
    let text = edit("material = \"steel\"", "material = \"stel\"");
    check(
        "unknown-material",
        &text,
        "material = \"stel\"",
        &["body[0].material", "unknown material `stel`", "steel"],
    );
}

#[test]
fn unknown_wall_material() {
    let text = format!(
        "{BASE}\n[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nmaterial = \"rubber\"\n"
    );
    check(
        "unknown-wall-material",
        &text,
        "rubber",
        &["wall[0].material", "rubber"],
    );
}

#[test]
fn zero_wall_normal() {
    let text = format!(
        "{BASE}\n[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 0.0]\nmaterial = \"steel\"\n"
    );
    check("zero-normal", &text, "normal", &["wall[0].normal"]);
}

#[test]
fn unknown_polyhedron_kind() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "polyhedron = { kind = \"cubeoid\", radius = 0.01 }",
    );
    check(
        "unknown-kind",
        &text,
        "cubeoid",
        &["shape[0].polyhedron.kind", "cubeoid", "icosahedron"],
    );
}

#[test]
fn two_shape_variants() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "sphere = { radius = 0.01 }\nbox = { half_extents = [0.01, 0.01, 0.01] }",
    );
    check(
        "two-variants",
        &text,
        "[[shape]]",
        &["shape[0]", "exactly one"],
    );
}

#[test]
fn degenerate_hull_coplanar() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "convex = { points = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.01, 0.01, 0.0], [0.005, 0.005, 0.0]] }",
    );
    check(
        "coplanar",
        &text,
        "convex",
        &["shape[0].convex.points", "degenerate hull", "coplanar"],
    );
}

#[test]
fn degenerate_hull_three_points() {
    let text = edit(
        "sphere = { radius = 0.01 }",
        "convex = { points = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]] }",
    );
    check(
        "three-points",
        &text,
        "convex",
        &[
            "shape[0].convex.points",
            "degenerate hull",
            "fewer than four",
        ],
    );
}

#[test]
fn empty_scene() {
    let text = "[simulation]\nsteps = 10\n\n[[material]]\nname = \"steel\"\ndensity = 7800.0\nstiffness = 1.0e5\n";
    check_line("empty", text, 1, &["`body`", "no bodies"]);
}

#[test]
fn duration_and_steps() {
    let text = edit("steps = 10\n", "duration = 0.1\nsteps = 10\n");
    check(
        "duration-and-steps",
        &text,
        "steps = 10",
        &["simulation.steps", "duration"],
    );
}

#[test]
fn zero_steps() {
    let text = edit("steps = 10\n", "steps = 0\n");
    check("zero-steps", &text, "steps = 0", &["simulation.steps"]);
}

#[test]
fn negative_duration() {
    let text = edit("steps = 10\n", "duration = -1.0\n");
    check("neg-duration", &text, "duration", &["simulation.duration"]);
}

#[test]
fn negative_dt() {
    let text = edit("steps = 10\n", "steps = 10\ndt = -1.0e-5\n");
    check("neg-dt", &text, "dt =", &["simulation.dt"]);
}

#[test]
fn restitution_zero() {
    let text = edit("restitution = 0.5", "restitution = 0.0");
    check(
        "restitution-0",
        &text,
        "restitution",
        &["material[0].restitution", "(0, 1]"],
    );
}

#[test]
fn restitution_above_one() {
    let text = edit("restitution = 0.5", "restitution = 1.5");
    check(
        "restitution-1.5",
        &text,
        "restitution",
        &["material[0].restitution", "1.5"],
    );
}

#[test]
fn duplicate_material_name() {
    let text = edit(
        "\n[[shape]]",
        "\n[[material]]\nname = \"steel\" # again\ndensity = 1000.0\nstiffness = 1.0e4\n\n[[shape]]",
    );
    check(
        "dup-material",
        &text,
        "# again",
        &["material[1].name", "duplicate", "steel"],
    );
}

#[test]
fn duplicate_shape_name() {
    let text = edit(
        "\n[[body]]",
        "\n[[shape]]\nname = \"ball\" # again\nsphere = { radius = 0.02 }\n\n[[body]]",
    );
    check(
        "dup-shape",
        &text,
        "# again",
        &["shape[1].name", "duplicate", "ball"],
    );
}

#[test]
fn linear_and_hertz_mixed() {
    let text = edit(
        "\n[[shape]]",
        "\n[[material]]\nname = \"rubber\"\ndensity = 1100.0\nmodel = \"hertz\"\nyoungs_modulus = 1.0e7\npoisson_ratio = 0.45\n\n[[shape]]",
    );
    check(
        "mixed-models",
        &text,
        "model = \"hertz\"",
        &["material[1].model", "linear", "hertz"],
    );
}

#[test]
fn hertz_with_stiffness() {
    let text = edit(
        "stiffness = 1.0e5\n",
        "model = \"hertz\"\nyoungs_modulus = 2.0e11\npoisson_ratio = 0.3\nstiffness = 1.0e5\n",
    );
    check(
        "hertz-stiffness",
        &text,
        "stiffness",
        &["material[0].stiffness", "hertz"],
    );
}

#[test]
fn hertz_poisson_out_of_range() {
    let text = edit(
        "stiffness = 1.0e5\n",
        "model = \"hertz\"\nyoungs_modulus = 2.0e11\npoisson_ratio = -1.0\n",
    );
    check(
        "poisson",
        &text,
        "poisson_ratio",
        &["material[0].poisson_ratio"],
    );
}

#[test]
fn unknown_model() {
    let text = edit(
        "stiffness = 1.0e5\n",
        "model = \"hooke\"\nstiffness = 1.0e5\n",
    );
    check(
        "unknown-model",
        &text,
        "hooke",
        &["material[0].model", "hooke"],
    );
}

#[test]
fn container_max_below_min() {
    let text = format!(
        "{BASE}\n[container]\nmin = [0.0, 0.0, 0.0]\nmax = [1.0, -1.0, 1.0]\nmaterial = \"steel\"\n"
    );
    check(
        "container",
        &text,
        "max = [1.0, -1.0, 1.0]",
        &["container.max"],
    );
}

#[test]
fn group_without_placement() {
    let text = format!("{BASE}\n[[group]]\nshape = \"ball\"\nmaterial = \"steel\"\n");
    check(
        "group-no-placement",
        &text,
        "[[group]]",
        &["group[0]", "lattice", "random"],
    );
}

#[test]
fn group_lattice_and_random() {
    let text = format!(
        "{BASE}\n[[group]]\nshape = \"ball\"\nmaterial = \"steel\"\nlattice = {{ min = [0.0, 0.0, 1.0], max = [0.1, 0.1, 1.0], spacing = 0.05 }}\nrandom = {{ min = [0.0, 0.0, 2.0], max = [1.0, 1.0, 3.0], count = 3 }}\n"
    );
    check(
        "lattice-and-random",
        &text,
        "lattice =",
        &["group[0].lattice"],
    );
}

#[test]
fn group_lattice_too_many_bodies() {
    let text = format!(
        "{BASE}\n[[group]]\nshape = \"ball\"\nmaterial = \"steel\"\nlattice = {{ min = [0.0, 0.0, 1.0], max = [100.0, 100.0, 100.0], spacing = 0.01 }}\n"
    );
    check(
        "lattice-huge",
        &text,
        "lattice =",
        &["group[0].lattice.spacing", "limit"],
    );
}

#[test]
fn random_placement_impossible() {
    // 1000 balls of diameter 0.02 cannot fit without overlap with centres in a 0.05 m cube.
    let text = format!(
        "{BASE}\n[[group]]\nshape = \"ball\"\nmaterial = \"steel\"\nrandom = {{ min = [1.0, 1.0, 1.0], max = [1.05, 1.05, 1.05], count = 1000, seed = 3 }}\n"
    );
    check(
        "random-impossible",
        &text,
        "count = 1000",
        &["group[0].random.count", "could place only"],
    );
}

#[test]
fn random_count_zero() {
    let text = format!(
        "{BASE}\n[[group]]\nshape = \"ball\"\nmaterial = \"steel\"\nrandom = {{ min = [1.0, 1.0, 1.0], max = [2.0, 2.0, 2.0], count = 0 }}\n"
    );
    check(
        "random-zero",
        &text,
        "count = 0",
        &["group[0].random.count"],
    );
}

#[test]
fn periodic_axes_must_be_letters_of_xyz() {
    let text = edit(
        "gravity = [0.0, 0.0, -9.81]",
        "gravity = [0.0, 0.0, -9.81]\nperiodic = { min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0], axes = \"xw\" }",
    );
    check(
        "periodic-axes",
        &text,
        "periodic",
        &["simulation.periodic.axes", "xyz"],
    );
}

#[test]
fn periodic_box_too_short() {
    let text = edit(
        "gravity = [0.0, 0.0, -9.81]",
        "gravity = [0.0, 0.0, -9.81]\nperiodic = { min = [0.0, 0.0, 0.0], max = [0.05, 1.0, 1.0], axes = \"x\" }",
    );
    check(
        "periodic-short",
        &text,
        "periodic",
        &[
            "simulation.periodic",
            "0.05 m long along x",
            "make it longer",
        ],
    );
}

#[test]
fn wall_across_a_periodic_axis() {
    let text = edit(
        "gravity = [0.0, 0.0, -9.81]",
        "gravity = [0.0, 0.0, -9.81]\nperiodic = { min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0], axes = \"z\" }",
    ) + "\n[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nmaterial = \"steel\"\n";
    check(
        "periodic-wall",
        &text,
        "periodic",
        &["wall 0", "parallel to the periodic axes"],
    );
}

/// Numbers finite as f64 but not as the 32-bit floats the simulation keeps are refused,
/// naming the field: 1e300 was infinite there, 1e-300 zero (a NaN at the first step, or a
/// dt of 0 s that ran without moving).
#[test]
fn numbers_outside_the_f32_range_are_refused() {
    let cases = [
        (
            "f32-density-big",
            "density = 7800.0\n",
            "density = 1e300\n",
            "1e300",
        ),
        (
            "f32-density-small",
            "density = 7800.0\n",
            "density = 1e-300\n",
            "1e-300",
        ),
        (
            "f32-stiffness",
            "stiffness = 1.0e5\n",
            "stiffness = 1e300\n",
            "1e300",
        ),
        (
            "f32-dt",
            "steps = 10\n",
            "steps = 10\ndt = 1e-300\n",
            "1e-300",
        ),
        (
            "f32-gravity",
            "gravity = [0.0, 0.0, -9.81]",
            "gravity = [0.0, 0.0, -1e300]",
            "-1e300",
        ),
        (
            "f32-position",
            "position = [0.0, 0.0, 0.1]",
            "position = [0.0, 0.0, 1e300]",
            "1e300",
        ),
    ];
    // A position that fits an f32 but is far past any domain (the broad phase's f32 cells
    // lose meaning there: a lone body at 1e28 m went NaN at its first step).
    let text = edit("position = [0.0, 0.0, 0.1]", "position = [1e28, 0.0, 0.1]");
    check("far-position", &text, "1e28", &["within 1e15 m"]);
    for (case, from, to, marker) in cases {
        let text = edit(from, to);
        check(case, &text, marker, &["32-bit float"]);
    }
    // A shape's lengths have their own range: the mass and inertia (r^3, r^5) must be
    // normal 32-bit floats.
    for (case, r) in [("radius-tiny", "1e-300"), ("radius-huge", "1e30")] {
        let text = edit("radius = 0.01", &format!("radius = {r}"));
        check(case, &text, r, &["1e-7 to 1e7"]);
    }
    // So do convex hulls, by half their largest extent.
    for (case, c) in [("hull-tiny", "1e-9"), ("hull-huge", "1e9")] {
        let text = edit(
            "sphere = { radius = 0.01 }",
            &format!("convex = {{ points = [[0,0,0],[{c},0,0],[0,{c},0],[0,0,{c}]] }}"),
        );
        check(case, &text, "convex", &["size", "1e-7 to 1e7"]);
    }
}

/// A direction is taken in double precision: a wall normal of length 1e39 or 1e-13 is the
/// direction it points in (it was infinite, then NaN, or refused as zero in f32), and a
/// quaternion of 1e20s is a rotation. The scene parses with those directions.
#[test]
fn directions_of_any_finite_length_are_normalised() {
    for normal in [
        "[0.0, 0.0, 1e39]",
        "[0.0, 0.0, 1e-13]",
        "[0.0, 0.0, 3.5e38]",
    ] {
        let text = format!(
            "{BASE}\n[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = {normal}\nmaterial = \"steel\"\n"
        );
        let scene = clatter::scene::Scene::parse(&text, "walls.toml")
            .unwrap_or_else(|e| panic!("normal {normal}: {e}"));
        let n = scene.world().walls[0].plane.normal;
        assert_eq!(n, glam::Vec3::Z, "normal {normal}");
    }
    let text = edit(
        "position = [0.0, 0.0, 0.1]",
        "position = [0.0, 0.0, 0.1]\norientation = [1e20, 0.0, 0.0, 1e20]",
    );
    let scene = clatter::scene::Scene::parse(&text, "quat.toml").expect("a big quaternion");
    let q = scene.world().user_orientation(0);
    let want = glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    assert!(q.angle_between(want) < 1e-5, "{q:?}");
}

/// A duration shorter than dt runs one step (`ceil(duration / dt)`), not zero.
#[test]
fn a_duration_below_dt_runs_one_step() {
    let text = edit("steps = 10\n", "duration = 1e-12\ndt = 1e-5\n");
    let scene = clatter::scene::Scene::parse(&text, "short.toml").expect("valid");
    assert_eq!(scene.steps(1e-5), 1);
}
