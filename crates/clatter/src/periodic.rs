//! Periodic boundaries: along the chosen axes the box `[min, max)` repeats, so a body
//! leaving through one face comes back through the other and bodies near opposite faces
//! touch across the seam. Positions are kept wrapped into the box; a pair interacts through
//! its nearest image (the box is at least three broad-phase cells long along every periodic
//! axis, so there is only ever one image within reach).

use glam::{DVec3, Vec3};

/// A periodic box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Periodic {
    /// Lower corner, m.
    pub min: Vec3,
    /// Upper corner, m.
    pub max: Vec3,
    /// Which axes repeat (x, y, z).
    pub axes: [bool; 3],
}

impl Periodic {
    /// Box length along each periodic axis, 0 along the others.
    pub fn length(&self) -> Vec3 {
        Vec3::select(
            glam::BVec3::from(self.axes),
            self.max - self.min,
            Vec3::ZERO,
        )
    }

    /// `x` wrapped into the box along the periodic axes (one box length at most: bodies move
    /// far less than that per step).
    #[inline]
    pub fn wrap(&self, x: Vec3) -> Vec3 {
        let mut out = x;
        for k in 0..3 {
            if self.axes[k] {
                let len = self.max[k] - self.min[k];
                // `min + len` rather than `max`: the GPU knows only `min` and `len`.
                if out[k] >= self.min[k] + len {
                    out[k] -= len;
                } else if out[k] < self.min[k] {
                    out[k] += len;
                }
            }
        }
        out
    }

    /// The shortest of the periodic images of the difference `d` (of two wrapped positions).
    #[inline]
    pub fn nearest(&self, d: Vec3) -> Vec3 {
        let mut out = d;
        for k in 0..3 {
            if self.axes[k] {
                let len = self.max[k] - self.min[k];
                if out[k] > 0.5 * len {
                    out[k] -= len;
                } else if out[k] < -0.5 * len {
                    out[k] += len;
                }
            }
        }
        out
    }

    /// [`Periodic::wrap`] in f64 (the box length `max - min` taken in f64).
    #[inline]
    pub fn wrap_f64(&self, x: DVec3) -> DVec3 {
        let mut out = x;
        for k in 0..3 {
            if self.axes[k] {
                let (min, max) = (self.min[k] as f64, self.max[k] as f64);
                let len = max - min;
                if out[k] >= max {
                    out[k] -= len;
                } else if out[k] < min {
                    out[k] += len;
                }
            }
        }
        out
    }

    /// [`Periodic::nearest`] in f64.
    #[inline]
    pub fn nearest_f64(&self, d: DVec3) -> DVec3 {
        let mut out = d;
        for k in 0..3 {
            if self.axes[k] {
                let len = self.max[k] as f64 - self.min[k] as f64;
                if out[k] > 0.5 * len {
                    out[k] -= len;
                } else if out[k] < -0.5 * len {
                    out[k] += len;
                }
            }
        }
        out
    }

    /// The images of `x` (`x` itself first) that lie within `margin` of the box on the far
    /// side of a periodic face: where bodies across the seam can be within `margin` of it.
    pub fn images_near(&self, x: Vec3, margin: f32) -> ([Vec3; 8], usize) {
        let mut out = [x; 8];
        let mut count = 1;
        for k in 0..3 {
            if !self.axes[k] {
                continue;
            }
            let len = self.max[k] - self.min[k];
            let shift = if x[k] - self.min[k] < margin {
                len
            } else if (self.min[k] + len) - x[k] <= margin {
                -len
            } else {
                continue;
            };
            for m in 0..count {
                let mut y = out[m];
                y[k] += shift;
                out[count + m] = y;
            }
            count *= 2;
        }
        (out, count)
    }
}
