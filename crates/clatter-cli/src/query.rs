//! `clatter query FILE|-`: collision queries as JSON lines in, JSON lines out.
//!
//! Each input line is one query object (see `docs/queries.md`):
//! `{"a": BODY, "b": BODY, "queries": ["intersects","distance","contact","toi"], "toi_horizon": 1.0}`
//! with `BODY = {"shape": SHAPE, "position": [x,y,z], "orientation": [w,x,y,z], "velocity": [..],
//! "angular_velocity": [..]}` and `SHAPE` in the scene file's shape syntax. Body keys mean what
//! they mean in a scene file: `position` is where the centre of mass goes, `orientation` rotates
//! the shape as authored, `velocity` is that of the centre of mass and `angular_velocity` is in
//! the world frame.
//!
//! Each output line holds only the requested fields, in input order; a line that cannot be
//! answered gives `{"line": N, "error": "..."}` (1-based line number) and the run goes on.
//! Blank lines are skipped. Lines are answered in parallel in blocks, and prepared shapes are
//! cached by their JSON text, so large batches of few distinct shapes run at the speed of the
//! queries themselves.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufRead, BufReader, BufWriter, Read, Write};
use std::sync::{Arc, RwLock};

use anyhow::Context;
use clatter::shape_spec::ShapeSpec;
use clatter_geom::query::{self, Motion};
use clatter_geom::{Pose, PreparedShape};
use glam::{DQuat, Quat, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Lines answered per parallel block (bounds memory on endless streams).
const BLOCK: usize = 8192;
/// Prepared shapes kept before the cache is emptied (bounds memory on all-distinct inputs).
const CACHE_LIMIT: usize = 65_536;

/// One input line.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Line {
    a: BodySpec,
    b: BodySpec,
    /// The queries to answer; all four when omitted.
    #[serde(default = "all_queries")]
    queries: Vec<QueryKind>,
    /// End of the time interval `[0, toi_horizon]` searched by `toi`.
    #[serde(default = "default_horizon")]
    toi_horizon: f64,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum QueryKind {
    Intersects,
    Distance,
    Contact,
    Toi,
}

fn all_queries() -> Vec<QueryKind> {
    vec![
        QueryKind::Intersects,
        QueryKind::Distance,
        QueryKind::Contact,
        QueryKind::Toi,
    ]
}

fn default_horizon() -> f64 {
    1.0
}

fn identity() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// One body: the scene file's `[[body]]` keys, with the shape inline.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BodySpec {
    /// Kept as raw JSON: parsed (and cached) by its text.
    shape: Value,
    position: [f64; 3],
    #[serde(default = "identity")]
    orientation: [f64; 4],
    #[serde(default)]
    velocity: [f64; 3],
    #[serde(default)]
    angular_velocity: [f64; 3],
}

/// One output line; absent fields are not written.
#[derive(Serialize, Default)]
struct Answer {
    #[serde(skip_serializing_if = "Option::is_none")]
    intersects: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    distance: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    points: Option<[[f32; 3]; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    normal: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    depth: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    contacts: Option<Vec<[f32; 3]>>,
    /// `Some(None)` is written as `null` (no impact within the horizon).
    #[serde(skip_serializing_if = "Option::is_none")]
    toi: Option<Option<f32>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    toi_points: Option<Option<[[f32; 3]; 2]>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    toi_normal: Option<Option<[f32; 3]>>,
    /// `false` when the search stopped at its iteration cap: `toi` is then the time reached
    /// without contact, not an impact (see `query::Toi::converged`).
    #[serde(skip_serializing_if = "Option::is_none")]
    toi_converged: Option<bool>,
}

#[derive(Serialize)]
struct LineError<'a> {
    line: usize,
    error: &'a str,
}

/// Prepared shapes by the JSON text of their description.
type Cache = RwLock<HashMap<String, Arc<PreparedShape>>>;

/// Runs the JSON-lines query loop on `input` (a path or `-` for standard input), writing one
/// answer line per non-blank input line to standard output. A missing or unreadable input file
/// is an error; a malformed line only gives an error line.
pub fn run(input: &str) -> anyhow::Result<()> {
    let reader: Box<dyn Read> = if input == "-" {
        Box::new(io::stdin().lock())
    } else {
        Box::new(File::open(input).with_context(|| format!("cannot open query file `{input}`"))?)
    };
    let stdout = io::stdout().lock();
    answer_stream(
        BufReader::with_capacity(1 << 16, reader),
        BufWriter::with_capacity(1 << 16, stdout),
    )
}

/// Answers every line of `reader` into `out`, block by block.
fn answer_stream(mut reader: impl BufRead, mut out: impl Write) -> anyhow::Result<()> {
    let cache: Cache = RwLock::new(HashMap::new());
    let mut line_no = 0usize;
    let mut block: Vec<(usize, Result<String, String>)> = Vec::with_capacity(BLOCK);
    let mut buf = Vec::new();
    loop {
        block.clear();
        while block.len() < BLOCK {
            buf.clear();
            if reader
                .read_until(b'\n', &mut buf)
                .context("cannot read the query input")?
                == 0
            {
                break;
            }
            line_no += 1;
            // A UTF-8 byte-order mark (Windows editors write one) before the first line.
            if line_no == 1 && buf.starts_with(b"\xEF\xBB\xBF") {
                buf.drain(..3);
            }
            match String::from_utf8(std::mem::take(&mut buf)) {
                Ok(s) if s.trim().is_empty() => {}
                Ok(s) => block.push((line_no, Ok(s))),
                Err(_) => block.push((line_no, Err("the line is not valid UTF-8".into()))),
            }
        }
        if block.is_empty() {
            break;
        }
        let answers: Vec<String> = block
            .par_iter()
            .map(|(n, text)| {
                let result = match text {
                    Ok(t) => answer_line(*n, t, &cache),
                    Err(e) => Err(e.clone()),
                };
                result.unwrap_or_else(|error| {
                    serde_json::to_string(&LineError {
                        line: *n,
                        error: &error,
                    })
                    .expect("an error object serialises")
                })
            })
            .collect();
        for a in &answers {
            out.write_all(a.as_bytes())?;
            out.write_all(b"\n")?;
        }
        if cache.read().map(|c| c.len() > CACHE_LIMIT).unwrap_or(false)
            && let Ok(mut c) = cache.write()
        {
            c.clear();
        }
    }
    out.flush().context("cannot write the answers")?;
    Ok(())
}

/// The prepared shape for a shape description, from the cache when seen before.
fn shape_of(v: &Value, cache: &Cache) -> Result<Arc<PreparedShape>, String> {
    let key = v.to_string();
    if let Some(p) = cache.read().ok().and_then(|c| c.get(&key).cloned()) {
        return Ok(p);
    }
    let spec = ShapeSpec::deserialize(v).map_err(|e| e.to_string())?;
    let prepared = Arc::new(spec.to_kind()?.prepare().map_err(|e| e.to_string())?);
    if let Ok(mut c) = cache.write() {
        c.insert(key, prepared.clone());
    }
    Ok(prepared)
}

/// The largest coordinate or speed a query takes: the answers are 32-bit floats, and
/// squared distances of bodies beyond ~1e19 m overflow them (`null`s in the answer).
const MAX_QUERY_NUMBER: f64 = 1e18;

fn finite<const N: usize>(what: &str, v: &[f64; N]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite"))
    }
}

/// [`finite`], and every component at most [`MAX_QUERY_NUMBER`] in size.
fn in_range<const N: usize>(what: &str, v: &[f64; N]) -> Result<(), String> {
    finite(what, v)?;
    if v.iter().all(|x| x.abs() <= MAX_QUERY_NUMBER) {
        Ok(())
    } else {
        Err(format!(
            "{what} must be at most {MAX_QUERY_NUMBER:e} in size, got {v:?}"
        ))
    }
}

/// A body ready for the queries: shape, principal-frame pose and motion.
struct Body {
    prepared: Arc<PreparedShape>,
    pose: Pose,
    motion: Motion,
}

fn body(name: &str, b: &BodySpec, cache: &Cache) -> Result<Body, String> {
    let prepared = shape_of(&b.shape, cache).map_err(|e| format!("{name}.shape: {e}"))?;
    in_range(&format!("{name}.position"), &b.position)?;
    finite(&format!("{name}.orientation"), &b.orientation)?;
    in_range(&format!("{name}.velocity"), &b.velocity)?;
    in_range(&format!("{name}.angular_velocity"), &b.angular_velocity)?;
    let [w, x, y, z] = b.orientation;
    let q = DQuat::from_xyzw(x, y, z, w);
    let len = q.length();
    if !(len > 0.0 && len.is_finite()) {
        return Err(format!(
            "{name}.orientation must be a non-zero quaternion [w, x, y, z]"
        ));
    }
    let q: Quat = (q / len).as_quat();
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    // As in a scene file: `position` is the centre of mass, `orientation` rotates the shape as
    // authored; the prepared shape lives in its principal frame (`frame` from the authored one).
    let pose = Pose::new(v(b.position), (q * prepared.frame).normalize());
    let motion = Motion {
        linear: v(b.velocity),
        angular: v(b.angular_velocity),
    };
    Ok(Body {
        prepared,
        pose,
        motion,
    })
}

/// `x` with a negative zero made positive: answers never print `-0.0`.
fn num(x: f32) -> f32 {
    if x == 0.0 { 0.0 } else { x }
}

fn arr(v: Vec3) -> [f32; 3] {
    v.to_array().map(num)
}

/// What a query line looks like, for the message on a line that is not JSON.
const LINE_SHAPE: &str = r#"{"a": {"shape": {"sphere": {"radius": 1.0}}, "position": [0, 0, 0]}, "b": {"shape": {"box": {"half_extents": [0.5, 0.5, 0.5]}}, "position": [3, 0, 0]}, "queries": ["distance"]}"#;

/// The query on input line `n`, or why it is not one: not JSON at all or not an object (with
/// an example of a query line), or an object with wrong keys or values; serde's detail comes
/// last.
fn parse_line(n: usize, text: &str) -> Result<Line, String> {
    let mut de = serde_json::Deserializer::from_str(text);
    let parsed = match serde_path_to_error::deserialize::<_, Line>(&mut de) {
        Ok(line) => de.end().map(|()| line).map_err(|e| (e, None)),
        Err(e) => {
            // Where in the line the bad value is (`a.position`), before serde's detail.
            let path = e.path().to_string();
            Err((e.into_inner(), (path != ".").then_some(path)))
        }
    };
    parsed.map_err(|(e, path)| line_error(n, text, &e, path))
}

/// [`parse_line`]'s message for serde's error `e` at `path` (if known) in line `n`.
fn line_error(n: usize, text: &str, e: &serde_json::Error, path: Option<String>) -> String {
    let at = path.map_or(String::new(), |p| format!("`{p}`: "));
    // Each query is one line, so serde's "line 1" says nothing: the column does.
    let detail = e.to_string();
    let detail = match detail.strip_suffix(&format!(" at line 1 column {}", e.column())) {
        Some(d) if e.line() == 1 => format!("{d} at column {}", e.column()),
        _ => detail,
    };
    let what = match e.classify() {
        serde_json::error::Category::Syntax | serde_json::error::Category::Eof => {
            "is not valid JSON"
        }
        _ if !text.trim_start().starts_with('{') => "is JSON but not an object",
        _ => return format!("input line {n} is not a valid query: {at}{detail}"),
    };
    format!(
        "input line {n} {what}; a query line is one JSON object such as {LINE_SHAPE} (see docs/queries.md). Parser: {detail}"
    )
}

/// Answers input line `n` (the JSON text of the answer) or says why it cannot.
fn answer_line(n: usize, text: &str, cache: &Cache) -> Result<String, String> {
    let line = parse_line(n, text)?;
    if !(line.toi_horizon.is_finite() && line.toi_horizon >= 0.0) {
        return Err("toi_horizon must be a finite number >= 0".into());
    }
    let a = body("a", &line.a, cache)?;
    let b = body("b", &line.b, cache)?;
    let (sa, sb) = (&a.prepared.shape, &b.prepared.shape);
    let wants = |k: QueryKind| line.queries.contains(&k);
    let mut out = Answer::default();
    if wants(QueryKind::Intersects) {
        out.intersects = Some(query::intersects(sa, &a.pose, sb, &b.pose));
    }
    if wants(QueryKind::Distance) {
        let d = query::distance(sa, &a.pose, sb, &b.pose);
        out.distance = Some(num(d.distance));
        out.points = Some([arr(d.points[0]), arr(d.points[1])]);
        out.normal = Some(arr(d.normal));
    }
    if wants(QueryKind::Contact) {
        // With both queries, `points` and `normal` are the contact's: the same as the
        // distance's for separated shapes, the witness points and the penetration normal
        // (instead of a common point and a zero normal) for overlapping ones.
        let c = query::contact(sa, &a.pose, sb, &b.pose);
        out.depth = Some(num(c.depth));
        out.points = Some([arr(c.points[0]), arr(c.points[1])]);
        out.normal = Some(arr(c.normal));
        out.contacts = Some(c.manifold.points().iter().map(|&p| arr(p)).collect());
    }
    if wants(QueryKind::Toi) {
        let t = query::time_of_impact(
            sa,
            &a.pose,
            &a.motion,
            sb,
            &b.pose,
            &b.motion,
            line.toi_horizon as f32,
        );
        out.toi = Some(t.map(|t| num(t.time)));
        out.toi_points = Some(t.map(|t| [arr(t.points[0]), arr(t.points[1])]));
        out.toi_normal = Some(t.map(|t| arr(t.normal)));
        out.toi_converged = Some(t.is_none_or(|t| t.converged));
    }
    serde_json::to_string(&out).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_str(input: &str) -> Vec<Value> {
        let mut out = Vec::new();
        answer_stream(input.as_bytes(), &mut out).unwrap();
        String::from_utf8(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    #[test]
    fn answers_requested_fields_and_errors_per_line() {
        let input = concat!(
            r#"{"a": {"shape": {"sphere": {"radius": 1}}, "position": [0,0,0]}, "b": {"shape": {"sphere": {"radius": 0.5}}, "position": [3,0,0], "velocity": [-1,0,0]}, "queries": ["distance", "toi"], "toi_horizon": 5}"#,
            "\n",
            "{not json\n",
            "\n",
            r#"{"a": {"shape": {"box": {"half_extents": [0.5,0.5,0.5]}}, "position": [0,0,0]}, "b": {"shape": {"box": {"half_extents": [0.25,0.5,0.75]}}, "position": [0.1,0,0]}, "queries": ["intersects", "contact"]}"#,
            "\n",
            r#"{"a": {"shape": {"sphere": {"radius": -1}}, "position": [0,0,0]}, "b": {"shape": {"sphere": {"radius": 1}}, "position": [0,0,0]}}"#,
            "\n",
        );
        let v = run_str(input);
        assert_eq!(v.len(), 4);
        assert!((v[0]["distance"].as_f64().unwrap() - 1.5).abs() < 1e-6);
        assert!((v[0]["toi"].as_f64().unwrap() - 1.5).abs() < 1e-6);
        assert!(v[0].get("intersects").is_none() && v[0].get("depth").is_none());
        assert_eq!(v[1]["line"], 2);
        assert!(v[1]["error"].is_string());
        assert_eq!(v[2]["intersects"], true);
        assert!((v[2]["depth"].as_f64().unwrap() - 0.65).abs() < 1e-6);
        assert_eq!(v[2]["contacts"].as_array().unwrap().len(), 4);
        assert_eq!(v[3]["line"], 5);
        assert!(
            v[3]["error"].as_str().unwrap().contains("a.shape"),
            "{}",
            v[3]
        );
    }
}
