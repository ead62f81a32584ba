//! `clatter query FILE|-` end to end: JSON lines in, one answer line per query line, an error
//! object (with its line number) for a malformed line while the others go on, and a hard error
//! for a missing file.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};

use serde_json::Value;

const LINES: &str = concat!(
    // 1: two spheres 1.5 apart, b approaching at 1 m/s: impact at t = 1.5.
    r#"{"a": {"shape": {"sphere": {"radius": 1.0}}, "position": [0, 0, 0]}, "b": {"shape": {"sphere": {"radius": 0.5}}, "position": [3, 0, 0], "velocity": [-1, 0, 0]}, "queries": ["intersects", "distance", "toi"], "toi_horizon": 2.0}"#,
    "\n",
    // 2: malformed JSON.
    r#"{"a": {"shape": {"sphere": {"radius": 1.0}}, "position": [0, 0, 0]}, "b": "#,
    "\n",
    // 3: libccd's box-box case: depth 0.65 along +x.
    r#"{"a": {"shape": {"box": {"half_extents": [0.5, 0.5, 0.5]}}, "position": [0, 0, 0]}, "b": {"shape": {"box": {"half_extents": [0.25, 0.5, 0.75]}}, "position": [0.1, 0, 0]}, "queries": ["contact"]}"#,
    "\n",
    // 4: an unknown polyhedron kind.
    r#"{"a": {"shape": {"polyhedron": {"kind": "prism", "radius": 1.0}}, "position": [0, 0, 0]}, "b": {"shape": {"sphere": {"radius": 1.0}}, "position": [5, 0, 0]}}"#,
    "\n",
    // 5: an icosahedron and a convex hull (a unit tetrahedron-ish point set), far apart.
    r#"{"a": {"shape": {"polyhedron": {"kind": "icosahedron", "radius": 1.0}}, "position": [0, 0, 0], "orientation": [0.7071068, 0, 0, 0.7071068]}, "b": {"shape": {"convex": {"points": [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]}}, "position": [10, 0, 0]}, "queries": ["intersects", "distance", "contact", "toi"]}"#,
    "\n",
);

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_clatter"))
}

fn check(stdout: &[u8]) {
    let text = String::from_utf8(stdout.to_vec()).expect("utf-8 output");
    let v: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    assert_eq!(v.len(), 5, "{text}");
    // 1
    assert_eq!(v[0]["intersects"], false);
    assert!((v[0]["distance"].as_f64().unwrap() - 1.5).abs() < 1e-6);
    assert!((v[0]["toi"].as_f64().unwrap() - 1.5).abs() < 1e-6);
    assert_eq!(v[0]["points"][0][0].as_f64().unwrap(), 1.0);
    assert!(v[0].get("depth").is_none() && v[0].get("contacts").is_none());
    // 2
    assert_eq!(v[1]["line"], 2);
    assert!(v[1]["error"].as_str().unwrap().len() > 5);
    // 3
    assert!(
        (v[2]["depth"].as_f64().unwrap() - 0.65).abs() < 1e-6,
        "{}",
        v[2]
    );
    assert!((v[2]["normal"][0].as_f64().unwrap() - 1.0).abs() < 1e-6);
    assert_eq!(v[2]["contacts"].as_array().unwrap().len(), 4);
    assert!(v[2].get("intersects").is_none() && v[2].get("toi").is_none());
    // 4
    assert_eq!(v[3]["line"], 4);
    assert!(
        v[3]["error"].as_str().unwrap().contains("prism"),
        "{}",
        v[3]
    );
    // 5: the hull's centre of mass is at the given position; its nearest point to the
    // icosahedron is at x = 10 - 0.25 (the vertex set's centroid sits 0.25 from each face of
    // the corner).
    assert_eq!(v[4]["intersects"], false);
    let d = v[4]["distance"].as_f64().unwrap();
    assert!(d > 8.0 && d < 9.0, "{}", v[4]);
    assert!(v[4]["toi"].is_null());
    assert!(v[4]["depth"].as_f64().unwrap() < 0.0);
}

#[test]
fn query_file() {
    let dir = std::env::temp_dir().join(format!("clatter-query-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path: PathBuf = dir.join("queries.jsonl");
    std::fs::write(&path, LINES).unwrap();
    let out = bin().arg("query").arg(&path).output().expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    check(&out.stdout);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn query_stdin() {
    let mut child = bin()
        .args(["query", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(LINES.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    check(&out.stdout);
}

#[test]
fn missing_file_is_an_error() {
    let out = bin()
        .args(["query", "/nonexistent/clatter/queries.jsonl"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("queries.jsonl"), "{err}");
}

/// Runs `clatter query -` on `input`; the answer lines as JSON.
fn query_lines(input: &str) -> Vec<Value> {
    let mut child = bin()
        .args(["query", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(input.as_bytes())
        .expect("write the queries");
    let out = child.wait_with_output().expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect()
}

/// A line that is not JSON names its input line, says it is not JSON, shows what a query line
/// looks like and ends with the parser's detail; so does JSON that is not an object, and an
/// object that is not a query says so.
#[test]
fn non_json_line_says_what_a_query_line_looks_like() {
    let v = query_lines("\nhello\n[1, 2]\n{\"a\": 1}\n");
    assert_eq!(v.len(), 3);
    assert_eq!(v[0]["line"], 2);
    let e = v[0]["error"].as_str().expect("an error");
    assert!(
        e.starts_with("input line 2 is not valid JSON; a query line is one JSON object such as {\"a\": {\"shape\": "),
        "{e}"
    );
    assert!(e.contains("docs/queries.md"), "{e}");
    assert!(e.ends_with("Parser: expected value at column 1"), "{e}");
    assert_eq!(v[1]["line"], 3);
    let e = v[1]["error"].as_str().expect("an error");
    assert!(
        e.starts_with(
            "input line 3 is JSON but not an object; a query line is one JSON object such as {"
        ),
        "{e}"
    );
    assert_eq!(v[2]["line"], 4);
    let e = v[2]["error"].as_str().expect("an error");
    assert!(
        e.starts_with("input line 4 is not a valid query: `a`: invalid type: integer `1`"),
        "{e}"
    );
}

/// Every number in `v` (recursively); `-0.0` would be negative zero.
fn numbers(v: &Value, out: &mut Vec<f64>) {
    match v {
        Value::Number(n) => out.push(n.as_f64().expect("a number")),
        Value::Array(a) => a.iter().for_each(|x| numbers(x, out)),
        Value::Object(o) => o.values().for_each(|x| numbers(x, out)),
        _ => {}
    }
}

/// Answers never hold a negative zero (`-0.0`): spheres and boxes met head-on from the
/// negative side, where normals and points have zero components computed from negatives.
#[test]
fn answers_have_no_negative_zero() {
    let v = query_lines(NEGATIVE_ZERO_LINES);
    assert!(v.iter().all(|a| a.get("error").is_none()), "{v:?}");
    let mut all = Vec::new();
    v.iter().for_each(|a| numbers(a, &mut all));
    assert!(all.contains(&0.0), "the answers have zero components");
    assert!(
        all.iter().all(|&x| !(x == 0.0 && x.is_sign_negative())),
        "{v:?}"
    );
}

/// Two overlapping boxes, b on a's negative x side (the normal was `[-1.0, -0.0, -0.0]`),
/// and two spheres apart along -x.
const NEGATIVE_ZERO_LINES: &str = concat!(
    r#"{"a": {"shape": {"box": {"half_extents": [0.5, 0.5, 0.5]}}, "position": [0, 0, 0]}, "b": {"shape": {"box": {"half_extents": [0.5, 0.5, 0.5]}}, "position": [-0.9, 0, 0]}}"#,
    "\n",
    r#"{"a": {"shape": {"sphere": {"radius": 1.0}}, "position": [0, 0, 0]}, "b": {"shape": {"sphere": {"radius": 0.5}}, "position": [-3, 0, 0]}}"#,
    "\n",
);

/// A bad value is named by its path in the line (`a.position`, `b.velocity[1]`); numbers
/// beyond what the 32-bit answers can hold are refused rather than answered with `null`s; a
/// byte-order mark before the first line is skipped; and a time of impact says whether its
/// search converged.
#[test]
fn query_errors_name_the_field_and_refuse_huge_numbers() {
    let ball = r#"{"shape": {"sphere": {"radius": 1}}, "position": [0, 0, 0]}"#;
    let lines = [
        format!(
            r#"{{"a": {{"shape": {{"sphere": {{"radius": 1}}}}, "position": [0, 0]}}, "b": {ball}}}"#
        ),
        format!(
            r#"{{"a": {ball}, "b": {{"shape": {{"sphere": {{"radius": 1}}}}, "position": [3, 0, 0], "velocity": [1, "x", 0]}}}}"#
        ),
        format!(
            r#"{{"a": {ball}, "b": {{"shape": {{"sphere": {{"radius": 1}}}}, "position": [1e39, 0, 0]}}}}"#
        ),
        format!(
            r#"{{"a": {ball}, "b": {{"shape": {{"sphere": {{"radius": 1}}}}, "position": [3, 0, 0], "velocity": [-1, 0, 0]}}, "queries": ["toi"], "toi_horizon": 5}}"#
        ),
    ];
    let input = format!("\u{feff}{}\n", lines.join("\n"));
    let v = query_lines(&input);
    assert_eq!(v.len(), 4, "{v:?}");
    let err = |i: usize| v[i]["error"].as_str().unwrap_or_default().to_string();
    assert!(err(0).contains("`a.position`"), "{}", err(0));
    assert!(err(1).contains("`b.velocity[1]`"), "{}", err(1));
    assert!(
        err(2).contains("b.position") && err(2).contains("1e18"),
        "{}",
        err(2)
    );
    assert!(
        (v[3]["toi"].as_f64().unwrap() - 1.0).abs() < 1e-6,
        "{:?}",
        v[3]
    );
    assert_eq!(v[3]["toi_converged"], true);
}
