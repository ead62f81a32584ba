//! The camera: where it stands, what it looks at, and how a world point lands on a pixel.
//!
//! A [`Camera`] is a perspective look-at camera. [`Bounds::of_world`] measures what a frame
//! should show (the bodies plus the walls next to them) and [`Camera::framing`] places the
//! camera so that all of it is in view from one of the [`CameraSpec`] presets or a given eye.

use std::str::FromStr;

use clatter::World;
use glam::{Mat4, Vec3, Vec4};

/// A perspective camera looking from `eye` at `target`, `up` being up on the screen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Where the camera stands, m.
    pub eye: Vec3,
    /// The point at the centre of the picture, m; orbiting turns about it.
    pub target: Vec3,
    /// The direction that is up on the screen (need not be perpendicular to the view).
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Near clip distance, m.
    pub near: f32,
    /// Far clip distance, m.
    pub far: f32,
}

/// An axis-aligned box, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// The lowest corner.
    pub min: Vec3,
    /// The highest corner.
    pub max: Vec3,
}

impl Bounds {
    /// The centre of the box.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Half the diagonal: the radius of a sphere that holds the box.
    pub fn radius(&self) -> f32 {
        0.5 * (self.max - self.min).length()
    }

    /// What a frame of `world` should show: every body's bounding sphere, extended to each
    /// wall that lies within half the box's diagonal of it (so a floor under a falling body or
    /// the sides of a container are in the picture, a far-away wall is not), and every
    /// boundary mesh at its current pose. An empty world gives a unit box at the origin.
    pub fn of_world(world: &World) -> Bounds {
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for (x, r) in world
            .state
            .position
            .iter()
            .map(|p| p.as_vec3())
            .zip(&world.consts.radius)
        {
            if x.is_finite() && r.is_finite() {
                min = min.min(x - Vec3::splat(*r));
                max = max.max(x + Vec3::splat(*r));
            }
        }
        if !min.is_finite() || !max.is_finite() {
            min = Vec3::splat(-0.5);
            max = Vec3::splat(0.5);
        }
        let b = Bounds { min, max };
        let (c, reach) = (b.centre(), b.radius().max(1e-3));
        let (mut min, mut max) = (min, max);
        for w in &world.walls {
            let n = w.plane.normal;
            let dist = n.dot(c) - w.plane.offset;
            // The distance from the box (not its centre) to the plane.
            let half = b.max - c;
            let extent = n.x.abs() * half.x + n.y.abs() * half.y + n.z.abs() * half.z;
            if dist.is_finite() && (dist - extent) <= reach {
                let foot = c - dist * n;
                min = min.min(foot);
                max = max.max(foot);
            }
        }
        // Boundary meshes where they are now (a hopper or a drum frames the picture).
        for b in &world.boundaries {
            let pose = b.pose(world.time);
            for v in &b.vertices {
                let p = pose.apply(*v);
                if p.is_finite() {
                    min = min.min(p);
                    max = max.max(p);
                }
            }
        }
        Bounds { min, max }
    }
}

/// How the user asks for a camera (`--camera`): a preset direction, or an eye point and
/// optionally a target (the centre of the scene when omitted).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraSpec {
    /// From the front, above and to the right (the default).
    Iso,
    /// Straight down along gravity.
    Top,
    /// Horizontally, from the front.
    Front,
    /// Horizontally, from the right-hand side.
    Side,
    /// From `eye` towards `target` (the scene's centre when `None`).
    At {
        /// The eye point, m.
        eye: Vec3,
        /// The target point, m.
        target: Option<Vec3>,
    },
}

/// The `--camera` syntax, for help texts and errors.
pub const CAMERA_SYNTAX: &str = "iso, top, front, side, or EX,EY,EZ[:TX,TY,TZ] (eye point and optional target, m; the target defaults to the scene's centre)";

fn parse_point(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "'{s}' is not a point: expected three comma-separated numbers x,y,z"
        ));
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("'{p}' in '{s}' is not a finite number"))?;
    }
    Ok(Vec3::from_array(v))
}

impl FromStr for CameraSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        match t.to_ascii_lowercase().as_str() {
            "iso" => return Ok(CameraSpec::Iso),
            "top" => return Ok(CameraSpec::Top),
            "front" => return Ok(CameraSpec::Front),
            "side" => return Ok(CameraSpec::Side),
            _ => {}
        }
        let (eye, target) = match t.split_once(':') {
            Some((e, tg)) => (parse_point(e)?, Some(parse_point(tg)?)),
            None => (parse_point(t)?, None),
        };
        if target.is_some_and(|tg| (tg - eye).length() < 1e-6) {
            return Err(format!(
                "camera '{s}': the eye and the target are the same point"
            ));
        }
        Ok(CameraSpec::At { eye, target })
    }
}

/// The scene's up direction: against gravity, or `+z` without gravity.
pub fn up_of(world: &World) -> Vec3 {
    let g = world.gravity;
    if g.length_squared() > 0.0 && g.is_finite() {
        -g.normalize()
    } else {
        Vec3::Z
    }
}

/// A horizontal "forward" direction for `up` (the world's `+y` made horizontal, or `+x`).
fn forward_of(up: Vec3) -> Vec3 {
    let f = if up.dot(Vec3::Y).abs() < 0.9 {
        Vec3::Y
    } else {
        Vec3::X
    };
    (f - up * up.dot(f)).normalize()
}

impl Camera {
    /// Default vertical field of view, 40 degrees.
    pub const FOV_Y: f32 = 40.0 * std::f32::consts::PI / 180.0;

    /// A camera that shows all of `bounds` in a `aspect` (width / height) frame, placed as
    /// `spec` says; `up` is the scene's up direction (see [`up_of`]).
    pub fn framing(spec: CameraSpec, bounds: &Bounds, up: Vec3, aspect: f32) -> Camera {
        let c = bounds.centre();
        let r = bounds.radius().max(1e-4);
        let fwd = forward_of(up);
        let right = fwd.cross(up);
        let fov_y = Self::FOV_Y;
        // The narrower of the two fields of view must hold the bounding sphere.
        let half_x = ((fov_y * 0.5).tan() * aspect.max(1e-3)).atan();
        let half = (fov_y * 0.5).min(half_x);
        let dist = 1.05 * r / half.sin();
        let (eye, target, cam_up) = match spec {
            CameraSpec::Iso => {
                let dir = (-fwd * 1.0 + right * 0.55 + up * 0.75).normalize();
                (c + dir * dist, c, up)
            }
            CameraSpec::Top => (c + up * dist, c, fwd),
            CameraSpec::Front => (c - fwd * dist, c, up),
            CameraSpec::Side => (c + right * dist, c, up),
            CameraSpec::At { eye, target } => {
                let target = target.unwrap_or(c);
                let d = (target - eye).normalize_or(fwd);
                let cam_up = if d.cross(up).length() < 1e-3 { fwd } else { up };
                (eye, target, cam_up)
            }
        };
        let mut cam = Camera {
            eye,
            target,
            up: cam_up,
            fov_y,
            near: 0.01,
            far: 100.0,
        };
        cam.fit_clip(bounds);
        cam
    }

    /// Sets the near and far planes around `bounds` as seen from the eye (a tight depth range
    /// keeps the depth buffer precise).
    pub fn fit_clip(&mut self, bounds: &Bounds) {
        let d = (bounds.centre() - self.eye).length();
        let r = bounds.radius().max(1e-4) * 1.5;
        self.far = (d + r).max(1e-3);
        self.near = (d - r).max(self.far * 1e-4);
    }

    /// The view matrix (world to camera).
    pub fn view(&self) -> Mat4 {
        Mat4::look_at_rh(self.eye, self.target, self.up)
    }

    /// The projection matrix for a frame of `aspect` (width / height), depth 0..1.
    pub fn projection(&self, aspect: f32) -> Mat4 {
        Mat4::perspective_rh(self.fov_y, aspect.max(1e-3), self.near, self.far)
    }

    /// World to clip space.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// The pixel (x right, y down, pixel centres at `.5`) where the world point `p` lands in
    /// a `width` x `height` frame, or `None` when it is behind the camera.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<(f32, f32)> {
        let clip = self.view_proj(width as f32 / height as f32) * Vec4::from((p, 1.0));
        if clip.w <= 0.0 {
            return None;
        }
        let ndc = clip.truncate() / clip.w;
        Some((
            (ndc.x * 0.5 + 0.5) * width as f32,
            (0.5 - ndc.y * 0.5) * height as f32,
        ))
    }

    /// Unit vector from the eye towards the target.
    pub fn forward(&self) -> Vec3 {
        (self.target - self.eye).normalize_or(Vec3::NEG_Z)
    }

    /// A light direction (towards the light) fixed relative to the camera: from above, behind
    /// and a little to the right of the viewer, so that every view is lit from the front.
    pub fn light_dir(&self) -> Vec3 {
        let f = self.forward();
        let right = f.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(f);
        (-f * 0.6 + up * 0.7 + right * 0.35).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_presets_and_points() {
        assert_eq!("iso".parse::<CameraSpec>(), Ok(CameraSpec::Iso));
        assert_eq!(" Top ".parse::<CameraSpec>(), Ok(CameraSpec::Top));
        assert_eq!(
            "1,2,3".parse::<CameraSpec>(),
            Ok(CameraSpec::At {
                eye: Vec3::new(1.0, 2.0, 3.0),
                target: None
            })
        );
        assert_eq!(
            "1,2,3:0,0.5,-1".parse::<CameraSpec>(),
            Ok(CameraSpec::At {
                eye: Vec3::new(1.0, 2.0, 3.0),
                target: Some(Vec3::new(0.0, 0.5, -1.0))
            })
        );
        for bad in [
            "",
            "diagonal",
            "1,2",
            "1,2,x",
            "1,2,3:4",
            "1,2,nan",
            "1,1,1:1,1,1",
        ] {
            assert!(bad.parse::<CameraSpec>().is_err(), "{bad} parsed");
        }
    }

    #[test]
    fn framing_puts_the_box_in_view() {
        let b = Bounds {
            min: Vec3::new(0.0, 0.0, 0.0),
            max: Vec3::new(0.3, 0.3, 0.2),
        };
        for spec in [
            CameraSpec::Iso,
            CameraSpec::Top,
            CameraSpec::Front,
            CameraSpec::Side,
        ] {
            let cam = Camera::framing(spec, &b, Vec3::Z, 4.0 / 3.0);
            for i in 0..8 {
                let p = Vec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                );
                let (x, y) = cam.project(p, 400, 300).expect("in front");
                assert!(
                    (0.0..=400.0).contains(&x) && (0.0..=300.0).contains(&y),
                    "{spec:?}: corner {p} at {x},{y}"
                );
            }
        }
    }
}
