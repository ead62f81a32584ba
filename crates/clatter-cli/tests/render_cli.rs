//! `clatter render` and `clatter view`: frames written and decodable at the asked size, the
//! viewer's screenshot under Xvfb, and clear errors for bad arguments. The GPU tests skip
//! loudly without an adapter and fail when `CI` is set (as `clatter_gpu::test_context`).

mod common;

use std::path::Path;
use std::process::Command;

use common::{assert_ok, clatter, names, test_dir, text};

/// A cube resting on a floor and a ball falling beside it.
const SCENE: &str = r#"
[simulation]
steps = 20

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
restitution = 0.5
friction = 0.4

[[shape]]
name = "box"
box = { half_extents = [0.05, 0.05, 0.05] }

[[shape]]
name = "ball"
sphere = { radius = 0.05 }

[[wall]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
material = "m"

[[body]]
shape = "box"
material = "m"
position = [0.0, 0.0, 0.0499]

[[body]]
shape = "ball"
material = "m"
position = [0.2, 0.0, 0.3]
"#;

fn write_scene(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, SCENE).expect("write the scene");
    p
}

/// Decodes a PNG and checks its size and that it shows something besides the background
/// (the top-left pixel).
fn check_png(path: &Path, w: u32, h: u32) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display()))
        .to_rgba8();
    assert_eq!((img.width(), img.height()), (w, h), "{}", path.display());
    let bg = img.get_pixel(w - 1, 0).0;
    let other = img
        .pixels()
        .filter(|p| (0..3).any(|c| (p.0[c] as i32 - bg[c] as i32).abs() > 8))
        .count();
    assert!(
        other > (w * h) as usize / 100,
        "{} is nearly blank ({other} pixels differ from the background)",
        path.display()
    );
}

#[test]
fn render_writes_frames_of_the_asked_size() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let dir = test_dir("render", "frames");
    let scene = write_scene(&dir);
    let out = dir.join("frames");
    let o = clatter(&[
        &"render",
        &scene,
        &"--out",
        &out,
        &"--every",
        &"8",
        &"--size",
        &"96x64",
        &"--camera",
        &"front",
        &"--color",
        &"contact",
    ]);
    assert_ok(&o, "clatter render");
    let stdout = String::from_utf8_lossy(&o.stdout);
    // Steps 0, 8, 16 and the last step, 20.
    let pngs: Vec<String> = names(&out)
        .into_iter()
        .filter(|n| n.ends_with(".png"))
        .collect();
    assert_eq!(
        pngs,
        [
            "frame_000000.png",
            "frame_000001.png",
            "frame_000002.png",
            "frame_000003.png"
        ]
    );
    for p in &pngs {
        check_png(&out.join(p), 96, 64);
    }
    // Either ffmpeg made the video or the output says it was skipped.
    let mp4 = out.join("frames.mp4");
    assert!(
        mp4.is_file() || stdout.contains("ffmpeg was not found"),
        "neither frames.mp4 nor a skip message:\n{}",
        text(&o)
    );
    // A shorter render into the same directory leaves only its own frames (ffmpeg's
    // `frame_%06d.png` would read the old ones after them).
    let o = clatter(&[
        &"render", &scene, &"--out", &out, &"--steps", &"1", &"--size", &"96x64", &"--quiet",
    ]);
    assert_ok(&o, "clatter render again");
    let pngs: Vec<String> = names(&out)
        .into_iter()
        .filter(|n| n.ends_with(".png"))
        .collect();
    assert_eq!(pngs, ["frame_000000.png", "frame_000001.png"]);
    // --only-contacts and an explicit eye point work too.
    let out2 = dir.join("only");
    let o = clatter(&[
        &"render",
        &scene,
        &"--out",
        &out2,
        &"--steps",
        &"1",
        &"--size",
        &"80x60",
        &"--camera",
        &"0.6,-0.8,0.4:0.1,0,0.1",
        &"--only-contacts",
        &"--quiet",
    ]);
    assert_ok(&o, "clatter render --only-contacts");
    check_png(&out2.join("frame_000001.png"), 80, 60);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--backend gpu` steps the scene on the GPU and draws from its body buffer: its frames
/// show what the CPU run's frames show (the same poses, to within float differences).
#[test]
fn render_on_the_gpu_backend_matches_the_cpu_frames() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let dir = test_dir("render", "backends");
    let scene = write_scene(&dir);
    let mut frames = Vec::new();
    for backend in ["cpu", "gpu"] {
        let out = dir.join(backend);
        let o = clatter(&[
            &"render",
            &scene,
            &"--out",
            &out,
            &"--every",
            &"10",
            &"--size",
            &"120x80",
            &"--camera",
            &"front",
            &"--color",
            &"speed",
            &"--backend",
            &backend,
        ]);
        assert_ok(&o, &format!("clatter render --backend {backend}"));
        if backend == "gpu" {
            assert!(text(&o).contains("backend: gpu"), "{}", text(&o));
        }
        let last = out.join("frame_000002.png");
        check_png(&last, 120, 80);
        frames.push(image::open(&last).expect("decodes").to_rgba8());
    }
    let differing = frames[0]
        .pixels()
        .zip(frames[1].pixels())
        .filter(|(a, b)| (0..3).any(|c| (a.0[c] as i32 - b.0[c] as i32).abs() > 8))
        .count();
    assert!(
        differing <= 120 * 80 / 200,
        "{differing} of {} pixels differ between the CPU and GPU frames",
        120 * 80
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_rejects_bad_arguments() {
    let dir = test_dir("render", "bad");
    let scene = write_scene(&dir);
    let out = dir.join("out");
    let cases: &[(&[&str], &str)] = &[
        (&["--size", "0x10"], "size"),
        (&["--size", "wide"], "WIDTHxHEIGHT"),
        (&["--size", "100000x10"], "size"),
        (&["--camera", "1,2"], "three comma-separated numbers"),
        (&["--camera", "sideways"], "expected iso"),
        (&["--camera", "1,1,1:1,1,1"], "same point"),
        (&["--every", "0"], "--every"),
        (&["--color", "rainbow"], "rainbow"),
        (&["--fps", "0"], "--fps"),
    ];
    for (extra, needle) in cases {
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"render", &scene, &"--out", &out];
        for e in *extra {
            args.push(e);
        }
        let o = clatter(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?} succeeded:\n{}", text(&o));
        assert!(err.contains(needle), "{extra:?}: no '{needle}' in:\n{err}");
        assert!(!err.contains("panicked"), "{extra:?} panicked:\n{err}");
    }
    // No --out, a missing scene file.
    let o = clatter(&[&"render", &scene]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--out"));
    let o = clatter(&[&"render", &dir.join("nope.toml"), &"--out", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("cannot read the scene file"),
        "{err}"
    );
    assert!(!err.contains("panicked"));
    let o = clatter(&[&"view", &scene, &"--frames", &"0"]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--frames"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Whether `xvfb-run` exists; with `CI` set its absence is a failure.
/// A scene that blows up in `clatter run` stops `clatter render` too: the same report, exit
/// status 3 (`run::BLOW_UP_EXIT`), no frames after the blow-up.
#[test]
fn render_stops_at_a_blow_up_with_the_run_report() {
    let dir = test_dir("render", "blowup");
    let scene = dir.join("escape.toml");
    // 500 m/s with dt = 1e-4: five radii per step, through the wall at x = 0.2.
    std::fs::write(
        &scene,
        r#"[simulation]
steps = 100
dt = 1.0e-4

[[material]]
name = "m"
density = 1000.0
stiffness = 1.0e4
restitution = 0.5

[[shape]]
name = "ball"
sphere = { radius = 0.01 }

[container]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.2]
material = "m"

[[body]]
shape = "ball"
material = "m"
position = [0.1, 0.1, 0.1]
velocity = [500.0, 0.0, 0.0]
"#,
    )
    .expect("write the scene");
    let mut backends = vec!["cpu"];
    if clatter_gpu::test_context().is_some() {
        backends.push("gpu");
    }
    for backend in backends {
        let out = dir.join(format!("out-{backend}"));
        let r = clatter(&[
            &"render",
            &scene,
            &"--out",
            &out,
            &"--every",
            &"5",
            &"--size",
            &"64x48",
            &"--quiet",
            &"--backend",
            &backend,
        ]);
        let run = clatter(&[&"run", &scene, &"--quiet", &"--backend", &backend]);
        let (rerr, runerr) = (
            String::from_utf8_lossy(&r.stderr),
            String::from_utf8_lossy(&run.stderr),
        );
        assert_eq!(
            r.status.code(),
            Some(3),
            "{backend}: render exit\n{}",
            text(&r)
        );
        assert_eq!(
            run.status.code(),
            Some(3),
            "{backend}: run exit\n{}",
            text(&run)
        );
        let report = |e: &str| {
            e.lines()
                .find(|l| l.contains("the simulation blew up"))
                .map(|l| l.trim_start_matches("error: ").to_string())
        };
        let report_r = report(&rerr).unwrap_or_else(|| panic!("{backend}: no report in {rerr}"));
        assert!(
            report_r.contains("step 10 ") && report_r.contains("body 0 escaped through wall 1"),
            "{backend}: {report_r}"
        );
        assert_eq!(
            Some(report_r),
            report(&runerr),
            "{backend}: the same report as run"
        );
        // Frames at steps 0 and 5 only: none after the blow-up at step 10.
        let frames = names(&out)
            .into_iter()
            .filter(|f| f.starts_with("frame_"))
            .count();
        assert_eq!(frames, 2, "{backend}: frames before the blow-up");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn have_xvfb() -> bool {
    let found = Command::new("xvfb-run").arg("--help").output().is_ok();
    if !found {
        if std::env::var_os("CI").is_some() {
            panic!("CI is set but xvfb-run is missing (apt-get install xvfb xauth)");
        }
        eprintln!(
            "\n*** SKIPPED VIEWER TEST: xvfb-run not found (apt-get install xvfb xauth) ***\n*** (set CI=1 to make this a failure) ***\n"
        );
    }
    found
}

#[test]
fn view_saves_a_screenshot_under_xvfb() {
    if !have_xvfb() || clatter_gpu::test_context().is_none() {
        return;
    }
    let dir = test_dir("render", "view");
    let scene = write_scene(&dir);
    // The CPU simulation uploaded per frame, and the GPU simulation on the window's device
    // drawn from its own buffer.
    for backend in ["cpu", "gpu"] {
        let shot = dir.join(format!("shot-{backend}.png"));
        let o = Command::new("xvfb-run")
            .args(["-a", "-s", "-screen 0 640x480x24"])
            .arg(env!("CARGO_BIN_EXE_clatter"))
            .arg("view")
            .arg(&scene)
            .args(["--frames", "4", "--size", "320x200", "--backend", backend])
            .arg("--screenshot")
            .arg(&shot)
            .output()
            .expect("run xvfb-run");
        assert_ok(
            &o,
            &format!("clatter view --backend {backend} --screenshot under xvfb-run"),
        );
        if backend == "gpu" {
            assert!(text(&o).contains("backend: gpu"), "{}", text(&o));
        }
        check_png(&shot, 320, 200);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_render_adds_frames_per_second() {
    if clatter_gpu::test_context().is_none() {
        return;
    }
    let args: &[&dyn AsRef<std::ffi::OsStr>] = &[
        &"bench",
        &"--pile",
        &"lattice",
        &"--render",
        &"--render-frames",
        &"2",
        &"--bodies",
        &"27,64",
        &"--steps",
        &"5",
        &"--settle",
        &"5",
    ];
    let o = clatter(args);
    assert_ok(&o, "clatter bench --render");
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("frames/s"), "{table}");
    let rows: Vec<&str> = table.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows.len(), 3, "{table}");
    for row in &rows[1..] {
        let cols: Vec<&str> = row.split_whitespace().collect();
        // bodies, steps/s, body-steps/s, contacts/body, pairs/body, ms/step, rebuilds,
        // frames/s, backend
        assert_eq!(cols.len(), 9, "{row}");
        let fps: f64 = cols[7].parse().expect("frames/s is a number");
        assert_eq!(cols[8], "cpu", "{row}");
        assert!(fps > 0.0 && fps.is_finite(), "{row}");
    }
    let mut json_args = args.to_vec();
    json_args.push(&"--json");
    let o = clatter(&json_args);
    assert_ok(&o, "clatter bench --render --json");
    let v: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!(v.len(), 2);
    for r in &v {
        let fps = r["frames_per_s"].as_f64().expect("frames_per_s");
        assert!(fps > 0.0, "{r}");
    }
    // Without --render there is no such column.
    let o = clatter(&[
        &"bench",
        &"--pile",
        &"lattice",
        &"--bodies",
        &"27",
        &"--steps",
        &"2",
        &"--settle",
        &"0",
        &"--json",
    ]);
    assert_ok(&o, "clatter bench --json");
    let v: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).expect("JSON");
    assert!(v[0].get("frames_per_s").is_none());
    let o = clatter(&[
        &"bench",
        &"--render",
        &"--render-frames",
        &"0",
        &"--bodies",
        &"27",
    ]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--render-frames"));
}

/// `view --frames N` without `--screenshot` is refused (the window would stay open and the
/// command never end), and without a display the error says why in a user's words, not with
/// the windowing library's source path.
#[test]
fn view_refuses_frames_alone_and_says_why_there_is_no_window() {
    let o = clatter(&[&"view", &"--frames", &"4"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--screenshot"), "{}", text(&o));
    let o = Command::new(env!("CARGO_BIN_EXE_clatter"))
        .arg("view")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .expect("run clatter view");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let all = text(&o);
    assert!(
        all.contains("cannot open a window") && all.contains("xvfb-run"),
        "{all}"
    );
    assert!(
        !all.contains("os error at") && !all.contains(".cargo"),
        "{all}"
    );
}
