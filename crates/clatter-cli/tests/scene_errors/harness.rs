//! The harness of the scene-error cases: a valid base scene, running `clatter run` on an
//! edited copy, and the checks every case shares.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A valid scene; the cases below edit it. One linear material, one sphere, one body.
pub const BASE: &str = r#"[simulation]
steps = 10
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "steel"
density = 7800.0
stiffness = 1.0e5
restitution = 0.5
friction = 0.3

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[[body]]
shape = "ball"
material = "steel"
position = [0.0, 0.0, 0.1]
"#;

/// A fresh, empty directory for one case (removed again when the case passes).
pub fn case_dir(case: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "clatter-scene-errors-{}-{case}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the case directory");
    dir
}

/// The 1-based number of the only line of `text` that contains `marker`.
pub fn line_of(text: &str, marker: &str) -> usize {
    let hits: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(marker))
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(
        hits.len(),
        1,
        "marker {marker:?} must be on exactly one line of:\n{text}"
    );
    hits[0]
}

/// Files left under `dir` (recursively), for the nothing-written check.
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(files_under(&p));
            }
            out.push(p);
        }
    }
    out
}

/// Runs `clatter run` on `text` and checks that it fails cleanly with an error at
/// `FILE:LINE:` (LINE: the line containing `marker`) that mentions every string in `needles`.
pub fn check(case: &str, text: &str, marker: &str, needles: &[&str]) {
    check_line(case, text, line_of(text, marker), needles);
}

pub fn check_line(case: &str, text: &str, line: usize, needles: &[&str]) {
    check_with_files(case, text, line, needles, &[]);
}

/// As [`check_line`], with `files` (name, contents) written beside the scene first.
pub fn check_with_files(
    case: &str,
    text: &str,
    line: usize,
    needles: &[&str],
    files: &[(&str, &[u8])],
) {
    let dir = case_dir(case);
    let scene = dir.join("bad.toml");
    std::fs::write(&scene, text).expect("write the scene");
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).expect("write a mesh file");
    }
    let out = dir.join("out");
    let output = Command::new(env!("CARGO_BIN_EXE_clatter"))
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .expect("run clatter");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success(),
        "{case}: expected failure, got success; stderr:\n{stderr}"
    );
    assert!(
        !stderr.contains("panicked"),
        "{case}: clatter panicked:\n{stderr}"
    );
    let location = format!("{}:{line}:", scene.display());
    assert!(
        stderr.contains(&location),
        "{case}: stderr does not name {location}:\n{stderr}\nscene:\n{text}"
    );
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "{case}: stderr does not mention {needle:?}:\n{stderr}"
        );
    }
    let left = files_under(&out);
    assert!(left.is_empty(), "{case}: files written to --out: {left:?}");
    assert!(
        !out.exists(),
        "{case}: --out directory created for an invalid scene"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `BASE` with `from` replaced by `to` (which must occur once).
pub fn edit(from: &str, to: &str) -> String {
    assert_eq!(
        BASE.matches(from).count(),
        1,
        "{from:?} must occur once in BASE"
    );
    BASE.replace(from, to)
}
