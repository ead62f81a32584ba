//! Headless rendering of a known scene, checked pixel by pixel where the camera must see the
//! bodies. Runs on any adapter, lavapipe/llvmpipe included; without one the tests skip loudly
//! (and fail when `CI` is set).

use clatter::World;
use clatter::scene::Scene;
use clatter_gpu::BodyState;
use clatter_render::renderer::{BACKGROUND, PALETTE};
use clatter_render::{Camera, CameraSpec, ColorMode, Offscreen, Poses, Style};
use glam::Vec3;
use image::RgbaImage;
use wgpu::util::DeviceExt;

const W: u32 = 160;
const H: u32 = 120;

/// A box resting on the floor (it touches it after one step) and a ball in the air above and
/// to the side of it (it touches nothing), of two materials.
const SCENE: &str = r#"
[simulation]
steps = 1
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "red"
density = 1000.0
stiffness = 1.0e4
restitution = 0.5
friction = 0.4

[[material]]
name = "blue"
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
material = "red"

[[body]]
shape = "box"
material = "red"
position = [0.0, 0.0, 0.0495]

[[body]]
shape = "ball"
material = "blue"
position = [0.25, 0.0, 0.4]
"#;

fn world() -> World {
    let scene = Scene::parse(SCENE, "test scene").expect("scene parses");
    let mut w = scene.world();
    w.step().expect("one step");
    w
}

fn to_linear(c: u8) -> f32 {
    let x = c as f32 / 255.0;
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

fn to_srgb8(x: f64) -> u8 {
    let s = if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// The pixel where world point `p` lands.
fn pixel(img: &RgbaImage, cam: &Camera, p: Vec3) -> [u8; 4] {
    let (x, y) = cam
        .project(p, img.width(), img.height())
        .expect("the point is in front of the camera");
    assert!(
        x >= 0.0 && y >= 0.0 && (x as u32) < img.width() && (y as u32) < img.height(),
        "{p} projects outside the frame ({x}, {y})"
    );
    img.get_pixel(x as u32, y as u32).0
}

/// Cosine between a pixel's linear colour and `rgb`: 1 when the hue and saturation match
/// (lighting only scales the colour).
fn same_hue(px: [u8; 4], rgb: [f32; 3]) -> f32 {
    let a = Vec3::new(to_linear(px[0]), to_linear(px[1]), to_linear(px[2]));
    let b = Vec3::from_array(rgb);
    a.normalize_or_zero().dot(b.normalize())
}

fn is_background(px: [u8; 4]) -> bool {
    (0..3).all(|c| (px[c] as i32 - to_srgb8(BACKGROUND[c]) as i32).abs() <= 2)
}

fn render(off: &mut Offscreen, cam: &Camera, style: Style) -> RgbaImage {
    off.render(cam, &style, Poses::Uploaded).expect("render")
}

#[test]
fn bodies_appear_where_the_camera_sees_them() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let w = world();
    let mut off = Offscreen::new(&ctx, &w, W, H).expect("offscreen");
    let cam = off.camera(CameraSpec::Front);
    let img = render(&mut off, &cam, Style::default());
    ctx.wait().expect("no GPU error");
    assert_eq!((img.width(), img.height()), (W, H));
    let drawn = img.pixels().filter(|p| !is_background(p.0)).count();
    assert!(
        drawn > (W * H) as usize / 50,
        "the image is nearly blank: {drawn} non-background pixels"
    );
    assert!(
        is_background(img.get_pixel(0, 0).0),
        "corner is not background"
    );
    let boxed = pixel(&img, &cam, w.state.position_f32(0));
    let ball = pixel(&img, &cam, w.state.position_f32(1));
    assert!(!is_background(boxed) && !is_background(ball));
    assert!(same_hue(boxed, PALETTE[0]) > 0.97, "box pixel {boxed:?}");
    assert!(same_hue(ball, PALETTE[1]) > 0.97, "ball pixel {ball:?}");
    // Other presets see the bodies too.
    for spec in [CameraSpec::Iso, CameraSpec::Top, CameraSpec::Side] {
        let cam = off.camera(spec);
        let img = render(&mut off, &cam, Style::default());
        let px = pixel(&img, &cam, w.state.position_f32(1));
        assert!(
            same_hue(px, PALETTE[1]) > 0.97,
            "{spec:?}: ball pixel {px:?}"
        );
    }
}

#[test]
fn only_contacts_hides_the_body_that_touches_nothing() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let w = world();
    let counts = w.contacts.counts(w.len());
    assert!(counts[0] > 0 && counts[1] == 0, "contacts {counts:?}");
    let mut off = Offscreen::new(&ctx, &w, W, H).expect("offscreen");
    let cam = off.camera(CameraSpec::Front);
    let contact = Style {
        color: ColorMode::Contact,
        ..Style::default()
    };
    let img = render(&mut off, &cam, contact);
    let (boxed, ball) = (
        pixel(&img, &cam, w.state.position_f32(0)),
        pixel(&img, &cam, w.state.position_f32(1)),
    );
    assert!(
        boxed[0] > boxed[2] + 40,
        "touching box is not orange: {boxed:?}"
    );
    assert!(ball[2] > ball[0], "free ball is not grey-blue: {ball:?}");
    let only = Style {
        only_contacts: true,
        ..Style::default()
    };
    let img = render(&mut off, &cam, only);
    let (boxed, ball) = (
        pixel(&img, &cam, w.state.position_f32(0)),
        pixel(&img, &cam, w.state.position_f32(1)),
    );
    assert!(
        is_background(ball),
        "the free ball is still drawn: {ball:?}"
    );
    assert!(
        same_hue(boxed, PALETTE[0]) > 0.97,
        "the touching box is gone: {boxed:?}"
    );
}

#[test]
fn speed_colours_the_fast_body_red() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let mut w = world();
    w.state.velocity[1] = Vec3::new(2.0, 0.0, 0.0);
    let mut off = Offscreen::new(&ctx, &w, W, H).expect("offscreen");
    let cam = off.camera(CameraSpec::Front);
    let style = Style {
        color: ColorMode::Speed,
        ..Style::default()
    };
    let img = render(&mut off, &cam, style);
    let (boxed, ball) = (
        pixel(&img, &cam, w.state.position_f32(0)),
        pixel(&img, &cam, w.state.position_f32(1)),
    );
    assert!(ball[0] > ball[2] + 40, "fast ball is not red: {ball:?}");
    assert!(
        boxed[2] > boxed[0] + 40,
        "resting box is not blue: {boxed:?}"
    );
}

#[test]
fn gpu_body_buffer_draws_like_the_cpu_upload() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let w = world();
    let mut off = Offscreen::new(&ctx, &w, W, H).expect("offscreen");
    let cam = off.camera(CameraSpec::Iso);
    let before = render(&mut off, &cam, Style::default());
    // The same world moved and turned, once as a GPU buffer of BodyState records (what the
    // GPU simulation holds) and once uploaded from the CPU.
    let mut moved = w.clone();
    moved.state.position[1] += glam::DVec3::new(-0.1, 0.05, -0.08);
    moved.state.orientation[0] = glam::Quat::from_rotation_z(0.6) * moved.state.orientation[0];
    let records: Vec<BodyState> = (0..moved.len())
        .map(|i| BodyState {
            position: moved.state.position_f32(i).extend(0.0).to_array(),
            velocity: moved.state.velocity[i].extend(0.0).to_array(),
            orientation: moved.state.orientation[i].to_array(),
            ..Default::default()
        })
        .collect();
    let buffer = ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test bodies"),
            contents: bytemuck::cast_slice(&records),
            usage: wgpu::BufferUsages::STORAGE,
        });
    let from_gpu = off
        .render(&cam, &Style::default(), Poses::Gpu(&buffer))
        .expect("render from the GPU buffer");
    off.update(&moved);
    let from_cpu = render(&mut off, &cam, Style::default());
    ctx.wait().expect("no GPU error");
    let diff = |a: &RgbaImage, b: &RgbaImage| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| (0..3).any(|c| (p.0[c] as i32 - q.0[c] as i32).abs() > 2))
            .count()
    };
    assert_eq!(
        diff(&from_gpu, &from_cpu),
        0,
        "GPU-buffer and CPU paths differ"
    );
    assert!(
        diff(&before, &from_gpu) > 20,
        "moving the bodies changed nothing: the GPU buffer was not used"
    );
    // A buffer too small for the bodies is an error, not a crash.
    let small = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("too small"),
        size: 96,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    assert!(
        off.render(&cam, &Style::default(), Poses::Gpu(&small))
            .is_err()
    );
}

#[test]
fn bad_sizes_are_errors() {
    let Some(ctx) = clatter_gpu::test_context() else {
        return;
    };
    let w = world();
    assert!(Offscreen::new(&ctx, &w, 0, 10).is_err());
    assert!(Offscreen::new(&ctx, &w, 10, 1 << 20).is_err());
}
