//! Helpers shared by the CLI integration tests: a scratch directory per test and running the
//! built `clatter` binary.
#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty directory `clatter-<suite>-<pid>-<name>` under the temp dir (tests remove it
/// again when they pass).
pub fn test_dir(suite: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clatter-{suite}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the test directory");
    dir
}

/// Runs the built `clatter` binary with `args` and collects its output.
pub fn clatter(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_clatter"));
    for a in args {
        cmd.arg(a);
    }
    cmd.output().expect("run clatter")
}

/// stdout and stderr of a run, for assertion messages.
pub fn text(o: &Output) -> String {
    format!(
        "stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Asserts that a run succeeded, showing its output if not.
pub fn assert_ok(o: &Output, what: &str) {
    assert!(o.status.success(), "{what} failed:\n{}", text(o));
}

/// Sorted file names in `dir`.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("read {}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The bytes of a file, or a panic naming it.
pub fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()))
}

/// The rows of a CSV file after its header, split at commas.
pub fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    let t = String::from_utf8(read(path)).unwrap();
    t.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// A minimal check of a `.vtu` file written by clatter: complete XML, and a Points array
/// whose decoded size matches NumberOfPoints.
pub fn check_vtu(path: &Path) {
    let t =
        String::from_utf8(read(path)).unwrap_or_else(|_| panic!("{} is not UTF-8", path.display()));
    assert!(
        t.starts_with("<?xml") && t.ends_with("</VTKFile>\n"),
        "{} is incomplete",
        path.display()
    );
    let n: usize = t
        .split("NumberOfPoints=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap()
        .parse()
        .unwrap();
    let points = t.split("<Points>").nth(1).unwrap();
    let b64 = points
        .split("format=\"binary\">")
        .nth(1)
        .unwrap()
        .split('<')
        .next()
        .unwrap();
    let bytes = base64_decode(b64);
    let len = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
    // Float64 points (positions at full precision).
    assert_eq!(len, 24 * n, "{}: Points byte count", path.display());
    assert_eq!(bytes.len(), 4 + len, "{}: Points data", path.display());
}

pub fn base64_decode(s: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    } as u32;
    let s = s.trim().as_bytes();
    assert_eq!(s.len() % 4, 0);
    let mut out = Vec::new();
    for q in s.chunks(4) {
        let pad = q.iter().filter(|&&c| c == b'=').count();
        let v = q
            .iter()
            .take(4 - pad)
            .fold(0u32, |acc, &c| (acc << 6) | val(c))
            << (6 * pad);
        out.extend_from_slice(&v.to_be_bytes()[1..4 - pad]);
    }
    out
}
