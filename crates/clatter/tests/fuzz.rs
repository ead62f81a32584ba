//! Fuzzing (proptest) of everything that reads untrusted input: the scene parser, the convex
//! hull builder and the checkpoint reader. Every input must give a result or a clear error:
//! no panic, and no hang (each case runs on a thread with a deadline).
//!
//! Case counts keep each test at a few seconds; raise them with `PROPTEST_CASES=N` for a
//! longer run.

use std::sync::mpsc;
use std::time::Duration;

use clatter::Checkpoint;
use clatter::checkpoint::crc32;
use clatter::geom::{ShapeKind, convex_hull};
use clatter::scene::Scene;
use glam::Vec3;
use proptest::prelude::*;

/// Runs `f` on its own thread and fails if it panics or takes longer than `secs`.
fn bounded<T: Send + 'static>(
    secs: u64,
    what: String,
    f: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::Builder::new()
        .stack_size(16 << 20)
        .spawn(move || {
            let _ = tx.send(f());
        })
        .expect("spawn a thread");
    match rx.recv_timeout(Duration::from_secs(secs)) {
        Ok(v) => {
            let _ = handle.join();
            v
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("panicked on {what}"),
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("no answer within {secs} s on {what}"),
    }
}

fn cases(n: u32) -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(n),
        // Failures are reported with their minimal input; nothing is written next to the sources.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

// ---------------------------------------------------------------------------------------
// Scene parser

const SCENES: [&str; 4] = [
    include_str!("../../../scenes/bouncing-ball.toml"),
    include_str!("../../../scenes/cube-on-floor.toml"),
    include_str!("../../../scenes/dice-box.toml"),
    include_str!("../../../scenes/hertz-spheres.toml"),
];

/// Pieces of scene files: what a mutation inserts.
const TOKENS: &[&str] = &[
    "[simulation]",
    "[[material]]",
    "[[shape]]",
    "[[wall]]",
    "[container]",
    "[[body]]",
    "[[group]]",
    "=",
    "[",
    "]",
    "{",
    "}",
    ",",
    "\"",
    "'",
    "\n",
    " ",
    "#",
    "nan",
    "inf",
    "-inf",
    "-",
    "1e308",
    "1e-308",
    "-1",
    "1",
    "2",
    "3",
    "true",
    "false",
    "name",
    "shape",
    "material",
    "position",
    "velocity",
    "sphere",
    "box",
    "convex",
    "polyhedron",
    "kind",
    "radius",
    "points",
    "lattice",
    "random",
    "count",
    "spacing",
    "min",
    "max",
    "seed",
    "dt",
    "steps",
    "duration",
    "skin",
    "gravity",
    "density",
    "stiffness",
    "model",
    "\"hertz\"",
    "youngs_modulus",
    "poisson_ratio",
    "restitution",
    "friction",
    "normal",
    "point",
    "top",
    "orientation",
    "[0.0, 0.0, 0.0]",
    "[1, 0, 0, 0]",
    "\"ball\"",
    "é",
    "\u{0}",
    "\\u0000",
    "\"\"\"",
];

#[derive(Debug, Clone)]
enum Edit {
    Delete { at: usize, len: usize },
    Insert { at: usize, token: usize },
    DuplicateLine { line: usize },
    DeleteLine { line: usize },
    SwapLines { a: usize, b: usize },
    Byte { at: usize, byte: u8 },
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1usize..8).prop_map(|(at, len)| Edit::Delete { at, len }),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(at, token)| Edit::Insert { at, token }),
        any::<usize>().prop_map(|line| Edit::DuplicateLine { line }),
        any::<usize>().prop_map(|line| Edit::DeleteLine { line }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines { a, b }),
        // Printable ASCII but no digits: a digit could legitimately multiply a body count.
        (
            any::<usize>(),
            (32u8..127).prop_filter("no digits", |b| !b.is_ascii_digit())
        )
            .prop_map(|(at, byte)| Edit::Byte { at, byte }),
    ]
}

fn apply(text: &str, edits: &[Edit]) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for e in edits {
        let n = bytes.len().max(1);
        let lines =
            |b: &[u8]| -> Vec<Vec<u8>> { b.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect() };
        match *e {
            Edit::Delete { at, len } => {
                let at = at % n;
                let end = (at + len).min(bytes.len());
                bytes.drain(at.min(bytes.len())..end);
            }
            Edit::Insert { at, token } => {
                let at = at % (bytes.len() + 1);
                bytes.splice(at..at, TOKENS[token].bytes());
            }
            Edit::DuplicateLine { line } => {
                let mut l = lines(&bytes);
                let k = line % l.len();
                l.insert(k, l[k].clone());
                bytes = l.join(&b'\n');
            }
            Edit::DeleteLine { line } => {
                let mut l = lines(&bytes);
                l.remove(line % l.len());
                bytes = l.join(&b'\n');
            }
            Edit::SwapLines { a, b } => {
                let mut l = lines(&bytes);
                let len = l.len();
                l.swap(a % len, b % len);
                bytes = l.join(&b'\n');
            }
            Edit::Byte { at, byte } => {
                if !bytes.is_empty() {
                    let at = at % bytes.len();
                    bytes[at] = byte;
                }
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Parses `text`; on error, the error names the file and a line within the text.
fn parse_ok_or_clear_error(text: String) {
    let lines = text.lines().count().max(1);
    let shown: String = text.chars().take(400).collect();
    let result = bounded(10, format!("scene {shown:?}"), move || {
        Scene::parse(&text, "fuzz.toml").map(|s| s.desc.bodies.len())
    });
    match result {
        Ok(n) => assert!(n >= 1),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with("fuzz.toml"), "{msg}");
            assert!(!e.message.is_empty(), "empty message");
            if let Some((line, col)) = e.line {
                assert!(
                    line >= 1 && line <= lines + 1 && col >= 1,
                    "line {line}:{col} of {lines}: {msg}"
                );
            }
        }
    }
}

proptest! {
    #![proptest_config(cases(1000))]

    #[test]
    fn scene_parser_on_arbitrary_text(text in any::<String>()) {
        parse_ok_or_clear_error(text);
    }

    #[test]
    fn scene_parser_on_token_soup(tokens in proptest::collection::vec(0..TOKENS.len(), 0..60)) {
        parse_ok_or_clear_error(tokens.iter().map(|&t| TOKENS[t]).collect::<Vec<_>>().join(" "));
    }

    #[test]
    fn scene_parser_on_mutated_scenes(base in 0..SCENES.len(), edits in proptest::collection::vec(edit(), 1..4)) {
        parse_ok_or_clear_error(apply(SCENES[base], &edits));
    }
}

// ---------------------------------------------------------------------------------------
// Hull builder

fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -1.0f32..1.0,
        1 => Just(0.0f32),
        1 => prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(f32::MAX), Just(f32::MIN_POSITIVE),
                         Just(1e30f32), Just(-1e30f32), Just(1e-30f32), Just(1e-7f32)],
        1 => -1e6f32..1e6,
    ]
}

fn point_set() -> impl Strategy<Value = Vec<Vec3>> {
    let base = proptest::collection::vec(
        (coordinate(), coordinate(), coordinate()).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
        0..40,
    );
    (base, any::<u8>(), 0.0f32..1e-3, 1usize..4).prop_map(|(mut pts, mode, eps, copies)| {
        match mode % 5 {
            // Duplicates: every point several times.
            0 => {
                pts = pts
                    .iter()
                    .flat_map(|p| std::iter::repeat_n(*p, copies))
                    .collect()
            }
            // Nearly coplanar: squash z.
            1 => pts.iter_mut().for_each(|p| p.z *= eps),
            // Tiny: scale everything down.
            2 => pts.iter_mut().for_each(|p| *p *= 1e-6),
            // Collinear-ish: all along one direction with noise.
            3 => pts
                .iter_mut()
                .for_each(|p| *p = Vec3::new(p.x, p.x + eps * p.y, p.x - eps * p.z)),
            _ => {}
        }
        pts
    })
}

proptest! {
    #![proptest_config(cases(2000))]

    #[test]
    fn hull_builder_on_hostile_points(points in point_set()) {
        let shown = format!("{points:?}");
        let pts = points.clone();
        bounded(10, format!("points {shown}"), move || {
            let hull = convex_hull(&pts);
            if let Ok(h) = &hull {
                let finite = pts.iter().all(|p| p.is_finite() && p.abs().max_element() < 1e15);
                // Vertices come from the input.
                for v in &h.vertices {
                    assert!(pts.contains(v), "vertex {v} is not an input point");
                }
                if finite {
                    let scale = pts.iter().map(|p| p.abs().max_element()).fold(0.0f32, f32::max).max(1e-30);
                    // Every input point is inside every face plane (within rounding).
                    for f in &h.faces {
                        assert!(f.normal.is_finite() && (f.normal.length() - 1.0).abs() < 1e-3, "face normal {}", f.normal);
                        for p in &pts {
                            let d = f.normal.dot(*p) - f.offset;
                            assert!(d <= 1e-3 * scale, "point {p} is {d} outside a face");
                        }
                    }
                }
            }
            // The whole shape pipeline (mass properties, principal frame) on the same points.
            let kind = ShapeKind::Convex { points: pts.iter().map(|p| [p.x as f64, p.y as f64, p.z as f64]).collect() };
            if let Ok(shape) = kind.prepare() {
                assert!(shape.volume >= 0.0 || shape.volume.is_nan(), "volume {}", shape.volume);
            }
            hull.is_ok()
        });
    }
}

// ---------------------------------------------------------------------------------------
// Checkpoint reader

const CKPT_SCENE: &str = r#"
[simulation]
steps = 100
dt = 2.0e-5

[[material]]
name = "m"
density = 1200.0
stiffness = 2.0e3

[container]
min = [0.0, 0.0, 0.0]
max = [0.04, 0.04, 0.06]
material = "m"

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.006 }

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

[[group]]
shape = "cube"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.032, 0.032, 0.05], count = 6, seed = 3 }
random_orientation = true
velocity = [0.3, -0.2, -0.4]

[[group]]
shape = "ball"
material = "m"
random = { min = [0.008, 0.008, 0.008], max = [0.032, 0.032, 0.05], count = 6, seed = 5 }
"#;

fn good_checkpoint() -> &'static [u8] {
    static BYTES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    BYTES.get_or_init(|| {
        let mut w = Scene::parse(CKPT_SCENE, "fuzz.toml").unwrap().world();
        for _ in 0..60 {
            w.step().unwrap();
        }
        assert!(!w.candidate_pairs().is_empty());
        w.checkpoint_bytes("fuzz.toml", CKPT_SCENE, b"{}")
    })
}

#[derive(Debug, Clone)]
enum ByteEdit {
    Flip {
        at: usize,
        bit: u8,
    },
    Set {
        at: usize,
        value: u8,
    },
    Truncate {
        len: usize,
    },
    Insert {
        at: usize,
        bytes: Vec<u8>,
    },
    Delete {
        at: usize,
        len: usize,
    },
    /// A little-endian u64 written somewhere (lengths and counts are u64).
    Word {
        at: usize,
        value: u64,
    },
}

fn byte_edit() -> impl Strategy<Value = ByteEdit> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| ByteEdit::Flip { at, bit }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, value)| ByteEdit::Set { at, value }),
        any::<usize>().prop_map(|len| ByteEdit::Truncate { len }),
        (
            any::<usize>(),
            proptest::collection::vec(any::<u8>(), 1..16)
        )
            .prop_map(|(at, bytes)| ByteEdit::Insert { at, bytes }),
        (any::<usize>(), 1usize..64).prop_map(|(at, len)| ByteEdit::Delete { at, len }),
        (
            any::<usize>(),
            prop_oneof![
                Just(0u64),
                Just(1),
                Just(u64::MAX),
                Just(1 << 40),
                any::<u64>(),
                0u64..5000
            ]
        )
            .prop_map(|(at, value)| ByteEdit::Word { at, value }),
    ]
}

fn mutate(good: &[u8], edits: &[ByteEdit]) -> Vec<u8> {
    let mut b = good.to_vec();
    for e in edits {
        let n = b.len().max(1);
        match e {
            ByteEdit::Flip { at, bit } => {
                if !b.is_empty() {
                    b[at % n] ^= 1 << bit;
                }
            }
            ByteEdit::Set { at, value } => {
                if !b.is_empty() {
                    b[at % n] = *value;
                }
            }
            ByteEdit::Truncate { len } => b.truncate(len % n),
            ByteEdit::Insert { at, bytes } => {
                let at = at % (b.len() + 1);
                b.splice(at..at, bytes.iter().copied());
            }
            ByteEdit::Delete { at, len } => {
                let at = at % n;
                let end = (at + len).min(b.len());
                b.drain(at.min(b.len())..end);
            }
            ByteEdit::Word { at, value } => {
                if b.len() >= 8 {
                    let at = at % (b.len() - 7);
                    b[at..at + 8].copy_from_slice(&value.to_le_bytes());
                }
            }
        }
    }
    b
}

/// Fixes the length field and the checksum after an edit, so the checks behind them run.
fn reseal(mut b: Vec<u8>) -> Vec<u8> {
    if b.len() >= 28 {
        let n = b.len() as u64;
        b[12..20].copy_from_slice(&n.to_le_bytes());
        let end = b.len() - 4;
        let crc = crc32(&b[..end]);
        b[end..].copy_from_slice(&crc.to_le_bytes());
    }
    b
}

/// Reads `bytes`; if they parse and restore, steps the world a little. Must not panic or hang.
fn read_and_run(bytes: Vec<u8>, what: &str) -> bool {
    bounded(
        20,
        format!("{what} of {} bytes", bytes.len()),
        move || match Checkpoint::from_bytes(&bytes) {
            Err(e) => {
                assert!(!e.to_string().is_empty());
                false
            }
            Ok(c) => {
                if let Ok((_, mut w)) = c.world() {
                    for _ in 0..3 {
                        if w.step().is_err() {
                            break;
                        }
                    }
                }
                true
            }
        },
    )
}

proptest! {
    #![proptest_config(cases(1000))]

    #[test]
    fn checkpoint_reader_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..600), magic in any::<bool>()) {
        let mut bytes = bytes;
        if magic {
            // Past the magic check, into the header logic.
            let mut b = b"CLATCKPT\x02\0\0\0".to_vec();
            b.extend_from_slice(&bytes);
            bytes = b;
        }
        read_and_run(bytes, "arbitrary bytes");
    }

    #[test]
    fn checkpoint_reader_on_mutated_files(edits in proptest::collection::vec(byte_edit(), 1..4)) {
        let bad = mutate(good_checkpoint(), &edits);
        let parsed = read_and_run(bad.clone(), "a mutated checkpoint");
        // Without resealing, every change is caught by the length or the checksum.
        prop_assert!(!parsed || bad == good_checkpoint(), "a damaged checkpoint was accepted: {edits:?}");
    }

    #[test]
    fn checkpoint_reader_on_resealed_mutations(edits in proptest::collection::vec(byte_edit(), 1..4)) {
        read_and_run(reseal(mutate(good_checkpoint(), &edits)), "a resealed mutated checkpoint");
    }
}

#[test]
fn the_good_checkpoint_round_trips() {
    assert!(read_and_run(
        good_checkpoint().to_vec(),
        "the good checkpoint"
    ));
}

/// Found by `hull_builder_on_hostile_points`: a slab 1 thick and 6e5 wide, about as thin as
/// the merging tolerance, lost an extreme vertex (it ended up 2.5e5 outside a face).
#[test]
fn hull_of_a_thin_slab_keeps_its_extreme_points() {
    let pts = [
        Vec3::new(0.0, 415320.78, -0.61275655),
        Vec3::new(566014.56, 0.0, -0.33485398),
        Vec3::new(615168.6, 457577.7, 0.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(-0.8410584, 0.0, 0.5548965),
    ];
    let h = convex_hull(&pts).expect("a solid, if a thin one");
    assert_eq!(h.vertices.len(), 5);
    for f in &h.faces {
        for p in &pts {
            assert!(f.normal.dot(*p) - f.offset <= 1.0, "{p} outside a face");
        }
    }
}
