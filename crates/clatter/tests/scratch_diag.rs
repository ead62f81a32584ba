use clatter::geom::narrow::Plane;
use clatter::geom::{RegularKind, ShapeKind, PreparedShape};
use clatter::{BodyInit, ContactLaw, Material, Wall, World, WorldDesc};
use glam::{DQuat, DVec3, Quat, Vec3};

fn world(shape: PreparedShape, q: Quat) -> World {
    let mut w = World::new(WorldDesc {
        shapes: vec![shape],
        materials: vec![Material { name: "m".into(), density: 2500.0, law: ContactLaw::Linear { stiffness: 2e4 }, restitution: 0.5, friction: 0.5 }],
        walls: vec![Wall { plane: Plane { normal: Vec3::Z, offset: 0.0 }, material: 0 }],
        bodies: vec![BodyInit { shape: 0, material: 0, position: Vec3::ZERO, orientation: q, velocity: Vec3::ZERO, angular_velocity: Vec3::ZERO }],
        gravity: Vec3::new(0.0, 0.0, -9.81),
        dt: None,
        skin: None,
    });
    let clatter::geom::Shape::Polyhedron(p) = &w.shapes[0].shape else { panic!() };
    let low = p.vertices.iter().map(|&v| (w.orientation[0] * v).z).fold(f32::INFINITY, f32::min);
    w.position[0].z = 0.002 - low;
    w
}

#[test]
fn diag() {
    for exact in [false, true] {
        let mut w = world(ShapeKind::Box { half_extents: [0.01; 3] }.prepare().unwrap(), Quat::from_rotation_x(46f32.to_radians()));
        let mut q64: DQuat = w.orientation[0].as_dquat();
        for s in 0..(4.0 / w.dt) as usize {
            w.step().unwrap();
            if exact {
                let om: DVec3 = w.omega[0].as_dvec3();
                q64 = (DQuat::from_scaled_axis(om * w.dt as f64) * q64).normalize();
                w.orientation[0] = q64.as_quat();
            }
            if s % ((0.5 / w.dt) as usize) == 0 {
                eprintln!("exact {exact} t {:.2} x {:?} v {:?} omega {:?}", w.time, w.position[0], w.velocity[0], w.omega[0]);
            }
        }
    }
    let mut w = world(ShapeKind::Regular { kind: RegularKind::Tetrahedron, radius: 0.012 }.prepare().unwrap(), Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 1.1));
    for s in 0..(6.0 / w.dt) as usize {
        w.step().unwrap();
        if s % ((0.5 / w.dt) as usize) == 0 {
            eprintln!("tet t {:.2} x {:?} v {:?} omega {:?}", w.time, w.position[0], w.velocity[0], w.omega[0]);
        }
    }
}
