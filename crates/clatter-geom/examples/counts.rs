use clatter_geom::{RegularKind, Shape, ShapeKind};
fn main() {
    for k in RegularKind::ALL {
        let p = ShapeKind::Regular {
            kind: k,
            radius: 1.0,
        }
        .prepare()
        .unwrap();
        if let Shape::Polyhedron(h) = &p.shape {
            println!(
                "{:?}: v {} f {} e {} r {} frame {:?}",
                k,
                h.vertices.len(),
                h.faces.len(),
                h.edges.len(),
                h.radius,
                p.frame
            );
        }
    }
}
