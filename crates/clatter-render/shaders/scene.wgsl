// Bodies and walls. Prepended at build time: clatter-gpu's shaders/common.wgsl (BodyState,
// quat_rotate), so the renderer reads the simulation's body records as they are.

struct Frame {
    view_proj: mat4x4<f32>,
    // Direction towards the light (xyz).
    light_dir: vec4<f32>,
    // Colour mode: 0 material, 1 speed, 2 contact.
    mode: u32,
    // 1: draw only bodies in contact now.
    only_contacts: u32,
    // Speed shown as the top of the speed ramp, m/s.
    speed_max: f32,
    _pad: f32,
}

@group(0) @binding(0) var<uniform> frame: Frame;
// Body records: the simulation's GPU buffer, or the renderer's copy of the CPU state.
@group(0) @binding(1) var<storage, read> bodies: array<BodyState>;
// Per body: material colour (rgb) and whether it touches something now (w: 1 or 0).
@group(0) @binding(2) var<storage, read> styles: array<vec4<f32>>;
// Per instance, the body it draws (bodies grouped by shape, one draw per shape).
@group(0) @binding(3) var<storage, read> instance_body: array<u32>;

struct BodyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) color: vec3<f32>,
}

// Blue (slow) through green and yellow to red (fast).
fn speed_ramp(t: f32) -> vec3<f32> {
    let x = clamp(t, 0.0, 1.0);
    let r = clamp(1.5 - abs(4.0 * x - 3.0), 0.0, 1.0);
    let g = clamp(1.5 - abs(4.0 * x - 2.0), 0.0, 1.0);
    let b = clamp(1.5 - abs(4.0 * x - 1.0), 0.0, 1.0);
    return vec3<f32>(r, g, b) * 0.85 + vec3<f32>(0.08);
}

@vertex
fn vs_body(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @builtin(instance_index) instance: u32,
) -> BodyOut {
    var out: BodyOut;
    let b = instance_body[instance];
    let state = bodies[b];
    let style = styles[b];
    let touching = style.w > 0.5;
    // position.w != 0: removed by a sink (crates/clatter/src/sink.rs), not drawn.
    if (frame.only_contacts == 1u && !touching) || state.position.w != 0.0 {
        // Every vertex at one point outside the clip volume: the triangles vanish.
        out.clip = vec4<f32>(0.0, 0.0, -2.0, 1.0);
        out.normal = vec3<f32>(0.0, 0.0, 1.0);
        out.color = vec3<f32>(0.0);
        return out;
    }
    let q = state.orientation;
    let world = state.position.xyz + quat_rotate(q, position);
    out.clip = frame.view_proj * vec4<f32>(world, 1.0);
    out.normal = quat_rotate(q, normal);
    var color = style.rgb;
    if frame.mode == 1u {
        color = speed_ramp(length(state.velocity.xyz) / max(frame.speed_max, 1e-12));
    } else if frame.mode == 2u {
        color = select(vec3<f32>(0.30, 0.34, 0.42), vec3<f32>(1.0, 0.45, 0.08), touching);
    }
    out.color = color;
    return out;
}

@fragment
fn fs_body(in: BodyOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let diffuse = max(dot(n, frame.light_dir.xyz), 0.0);
    return vec4<f32>(in.color * (0.28 + 0.72 * diffuse), 1.0);
}

struct WallOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) alpha: f32,
    @location(2) spacing: f32,
}

@vertex
fn vs_wall(
    @location(0) position: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) alpha: f32,
    @location(3) spacing: f32,
) -> WallOut {
    var out: WallOut;
    out.clip = frame.view_proj * vec4<f32>(position, 1.0);
    out.uv = uv;
    out.alpha = alpha;
    out.spacing = spacing;
    return out;
}

@fragment
fn fs_wall(in: WallOut) -> @location(0) vec4<f32> {
    // Grid lines about one pixel wide whatever the distance: the distance to the nearest
    // line in units of the coordinate's screen-space rate of change.
    let g = in.uv / in.spacing;
    let w = fwidth(g);
    let d = abs(fract(g - 0.5) - 0.5) / max(w, vec2<f32>(1e-6));
    let line = 1.0 - clamp(min(d.x, d.y), 0.0, 1.0);
    let fill = vec3<f32>(0.55, 0.58, 0.62);
    let ink = vec3<f32>(0.18, 0.2, 0.24);
    let color = mix(fill, ink, line);
    let alpha = mix(in.alpha, min(in.alpha * 2.0 + 0.2, 1.0), line);
    return vec4<f32>(color, alpha);
}
