//! Checkpoints: a restart is bitwise exact (N steps, checkpoint, restore, M steps equals N + M
//! steps, contact list and tangential springs included), and damaged files give clear errors.

use clatter::World;
use clatter::checkpoint::{Checkpoint, CheckpointError, crc32};
use clatter::scene::Scene;

/// Mixed shapes tumbling in a closed box: contacts form and break, the Verlet list is rebuilt
/// many times, tangential springs carry history.
const SCENE: &str = r#"
[simulation]
steps = 400
dt = 2.0e-5
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "plastic"
density = 1200.0
stiffness = 2.0e3
restitution = 0.5
friction = 0.5

[container]
min = [0.0, 0.0, 0.0]
max = [0.06, 0.06, 0.08]
material = "plastic"

[[shape]]
name = "cube"
polyhedron = { kind = "cube", radius = 0.006 }

[[shape]]
name = "tetra"
polyhedron = { kind = "tetrahedron", radius = 0.007 }

[[shape]]
name = "ball"
sphere = { radius = 0.005 }

# A cube spinning flat on the floor: a face contact with a twisting spring.
[[body]]
shape = "cube"
material = "plastic"
position = [0.03, 0.03, 0.00345]
angular_velocity = [0.0, 0.0, 40.0]

[[group]]
shape = "cube"
material = "plastic"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 25, seed = 3 }
random_orientation = true
velocity = [0.4, -0.3, -0.5]
angular_velocity = [20.0, 5.0, -10.0]

[[group]]
shape = "tetra"
material = "plastic"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 15, seed = 4 }
random_orientation = true
velocity = [-0.4, 0.3, -0.2]
seed = 11

[[group]]
shape = "ball"
material = "plastic"
random = { min = [0.008, 0.008, 0.008], max = [0.052, 0.052, 0.07], count = 15, seed = 5 }
velocity = [0.1, 0.5, -0.6]
"#;

fn world() -> World {
    Scene::parse(SCENE, "tumble.toml")
        .expect("valid scene")
        .world()
}

fn steps(w: &mut World, n: u64) {
    for _ in 0..n {
        w.step().expect("a stable run");
    }
}

fn bits(w: &World) -> Vec<u32> {
    let mut out = Vec::new();
    for i in 0..w.len() {
        out.extend(w.state.position[i].to_array().into_iter().flat_map(|v| {
            let b = v.to_bits();
            [b as u32, (b >> 32) as u32]
        }));
        out.extend(w.state.velocity[i].to_array().map(f32::to_bits));
        out.extend(w.state.orientation[i].to_array().map(f32::to_bits));
        out.extend(w.state.angular_momentum[i].to_array().map(f32::to_bits));
        out.extend(w.state.omega[i].to_array().map(f32::to_bits));
    }
    out
}

fn bytes(w: &World) -> Vec<u8> {
    w.checkpoint_bytes("tumble.toml", SCENE, b"app data")
}

#[test]
fn restart_is_bitwise_exact() {
    const TOTAL: u64 = 400;
    let mut straight = world();
    steps(&mut straight, TOTAL);
    assert!(
        straight.rebuilds > 3,
        "the run should rebuild its pair list several times ({})",
        straight.rebuilds
    );
    assert!(
        straight.contact_count() > 0,
        "the run should end with contacts"
    );
    // Split points: before the first step, right after it, mid-list, and late.
    for split in [0, 1, 57, 233, 399] {
        let mut first = world();
        steps(&mut first, split);
        let ckpt = Checkpoint::from_bytes(&bytes(&first)).expect("a fresh checkpoint parses");
        assert_eq!(ckpt.step_count(), split);
        assert_eq!(ckpt.app, b"app data");
        assert_eq!(ckpt.scene_source, "tumble.toml");
        let (_, mut resumed) = ckpt.world().expect("restore");
        // Restored state is the written state, byte for byte.
        assert_eq!(
            bytes(&resumed),
            bytes(&first),
            "restored state differs at split {split}"
        );
        steps(&mut resumed, TOTAL - split);
        assert_eq!(resumed.step_count, TOTAL);
        assert_eq!(
            resumed.time.to_bits(),
            straight.time.to_bits(),
            "time at split {split}"
        );
        assert_eq!(
            resumed.rebuilds, straight.rebuilds,
            "rebuilds at split {split}"
        );
        assert!(
            bits(&resumed) == bits(&straight),
            "body state differs after a restart at step {split}"
        );
        // Everything, contact list and springs included (a remembered contact is written
        // as none, `restored_contact` in `io/checkpoint`: its margin's anchor is in no
        // checkpoint, and the resumed run's full test stores a margin anew).
        assert!(
            bytes(&resumed) == bytes(&straight),
            "checkpoint bytes differ after a restart at step {split}"
        );
    }
}

#[test]
fn checkpoint_file_round_trip() {
    let mut w = world();
    steps(&mut w, 30);
    let dir = std::env::temp_dir().join(format!("clatter-ckpt-lib-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("state.ckpt");
    clatter::checkpoint::write_atomic(&path, &bytes(&w)).unwrap();
    assert!(
        !dir.join("state.ckpt.tmp").exists(),
        "no temporary file left"
    );
    let (_, back) = Checkpoint::load(&path).unwrap().world().unwrap();
    assert_eq!(bytes(&back), bytes(&w));
    let err = Checkpoint::load(&dir.join("missing.ckpt")).unwrap_err();
    assert!(matches!(err, CheckpointError::Io { .. }), "{err}");
    assert!(err.to_string().contains("missing.ckpt"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn flipped_bytes_are_detected() {
    let mut w = world();
    steps(&mut w, 20);
    let good = bytes(&w);
    // Every byte position, one bit each (the CRC catches all single-bit errors).
    for k in 0..good.len() {
        let mut bad = good.clone();
        bad[k] ^= 1 << (k % 8);
        let err = Checkpoint::from_bytes(&bad).expect_err("a flipped bit must be refused");
        let msg = err.to_string();
        assert!(
            matches!(
                err,
                CheckpointError::Checksum { .. }
                    | CheckpointError::NotACheckpoint
                    | CheckpointError::UnsupportedVersion { .. }
                    | CheckpointError::Truncated { .. }
                    | CheckpointError::Malformed(_)
            ),
            "byte {k}: {msg}"
        );
        if k >= 24 && k < good.len() - 4 {
            assert!(msg.contains("checksum mismatch"), "byte {k}: {msg}");
        }
    }
    let mut bad = good.clone();
    bad[8] = 9;
    let msg = Checkpoint::from_bytes(&bad).unwrap_err().to_string();
    assert!(msg.contains("version 9 is not supported"), "{msg}");
    // Version 3 (f32 positions) is refused the same way: this build writes version 6 and
    // reads 4 to 6.
    bad[8] = 3;
    let msg = Checkpoint::from_bytes(&bad).unwrap_err().to_string();
    assert!(msg.contains("version 3 is not supported"), "{msg}");
    let mut bad = good.clone();
    bad[0] = b'X';
    let msg = Checkpoint::from_bytes(&bad).unwrap_err().to_string();
    assert!(msg.contains("not a clatter checkpoint"), "{msg}");
}

/// Versions 5 and 6 kept version 4's layout (each changed what a remembered contact's
/// stored margin means: 5 a face contact's, 6 an edge contact's; an older margin is safe
/// under the newer check), so version-4 and version-5 files are read, and resume bitwise as
/// the run they were cut from; this build writes version 6.
#[test]
fn version_4_and_5_files_are_read_and_resume_bitwise() {
    const TOTAL: u64 = 300;
    let mut straight = world();
    steps(&mut straight, TOTAL);
    let mut first = world();
    steps(&mut first, 120);
    let written = bytes(&first);
    assert_eq!(
        written[8..12],
        6u32.to_le_bytes(),
        "this build writes version 6"
    );
    for version in [4u32, 5] {
        let mut old = written.clone();
        old[8..12].copy_from_slice(&version.to_le_bytes());
        let body_end = old.len() - 4;
        let crc = crc32(&old[..body_end]);
        old[body_end..].copy_from_slice(&crc.to_le_bytes());
        let (_, mut resumed) = Checkpoint::from_bytes(&old)
            .unwrap_or_else(|e| panic!("a version-{version} file is read: {e}"))
            .world()
            .expect("restore");
        assert_eq!(bytes(&resumed), written, "the same state as written");
        steps(&mut resumed, TOTAL - 120);
        assert!(
            bits(&resumed) == bits(&straight),
            "resumed from version {version}"
        );
        assert!(bytes(&resumed) == bytes(&straight));
    }
}

#[test]
fn truncated_files_are_detected() {
    let mut w = world();
    steps(&mut w, 20);
    let good = bytes(&w);
    let n = good.len();
    let mut cuts: Vec<usize> = vec![
        0,
        1,
        7,
        8,
        11,
        12,
        23,
        24,
        27,
        100,
        n / 2,
        n - 5,
        n - 4,
        n - 1,
    ];
    cuts.extend((0..n).step_by(97));
    for cut in cuts {
        let err =
            Checkpoint::from_bytes(&good[..cut]).expect_err("a truncated file must be refused");
        let msg = err.to_string();
        if cut == 0 {
            assert!(msg.contains("not a clatter checkpoint"), "cut {cut}: {msg}");
        } else {
            assert!(msg.contains("truncated checkpoint"), "cut {cut}: {msg}");
        }
        if cut >= 20 {
            assert!(
                msg.contains(&format!("{cut} bytes, the header says {n}")),
                "cut {cut}: {msg}"
            );
        }
    }
    let mut long = good.clone();
    long.extend_from_slice(b"junk");
    let msg = Checkpoint::from_bytes(&long).unwrap_err().to_string();
    assert!(msg.contains("after the end"), "{msg}");
}

/// Re-seals a file after editing it: fixes the length field and the checksum, so the
/// structural checks behind them are exercised.
fn reseal(mut b: Vec<u8>) -> Vec<u8> {
    let n = b.len() as u64;
    b[12..20].copy_from_slice(&n.to_le_bytes());
    let end = b.len() - 4;
    let crc = crc32(&b[..end]);
    b[end..].copy_from_slice(&crc.to_le_bytes());
    b
}

#[test]
fn resealed_damage_is_a_clear_error() {
    let mut w = world();
    steps(&mut w, 20);
    let good = bytes(&w);
    // A different scene text: another body count.
    let other = SCENE.replace("count = 15, seed = 5", "count = 14, seed = 5");
    let b = w.checkpoint_bytes("tumble.toml", &other, b"");
    let msg = Checkpoint::from_bytes(&b)
        .unwrap()
        .world()
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("does not match its scene") && msg.contains("bodies"),
        "{msg}"
    );
    // A scene that builds the same count with other sizes.
    let other = SCENE.replace("radius = 0.005", "radius = 0.0051");
    let b = w.checkpoint_bytes("tumble.toml", &other, b"");
    let msg = Checkpoint::from_bytes(&b)
        .unwrap()
        .world()
        .unwrap_err()
        .to_string();
    assert!(msg.contains("other masses or sizes"), "{msg}");
    // A scene that no longer parses.
    let b = w.checkpoint_bytes("tumble.toml", "[simulation\n", b"");
    let msg = Checkpoint::from_bytes(&b)
        .unwrap()
        .world()
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("scene is invalid") && msg.contains("tumble.toml"),
        "{msg}"
    );
    // A NaN velocity, sealed with a valid checksum.
    let body_at = good.windows(4).position(|s| s == b"BODY").unwrap() + 4 + 8 + 8;
    let mut b = good.clone();
    b[body_at + 24..body_at + 28].copy_from_slice(&f32::NAN.to_bits().to_le_bytes());
    let msg = Checkpoint::from_bytes(&reseal(b)).unwrap_err().to_string();
    assert!(msg.contains("body 0 has a non-finite state"), "{msg}");
    // A cut inside a section, resealed.
    let mut b = good[..body_at + 40].to_vec();
    b.extend_from_slice(&[0; 4]);
    let msg = Checkpoint::from_bytes(&reseal(b)).unwrap_err().to_string();
    assert!(msg.contains("malformed checkpoint"), "{msg}");
}
