//! Measurements on runs of the example equipment (docs/equipment.md): the discharge rate of a
//! silo and the Beverloo fit over several orifices, and the dynamic angle of repose of a
//! rotating drum's bed. Plain least squares in f64, no I/O, so the same code serves the
//! `--ignored` validation tests and scripts, and is tested on synthetic data with known
//! answers.

/// A straight line `y = intercept + slope x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// Value at `x = 0`.
    pub intercept: f64,
    /// dy/dx.
    pub slope: f64,
}

/// The least-squares line through `(x, y)` points, or `None` with fewer than two distinct `x`.
pub fn fit_line(points: &[(f64, f64)]) -> Option<Line> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 || sxx.is_nan() {
        return None;
    }
    let slope = sxy / sxx;
    Some(Line {
        intercept: my - slope * mx,
        slope,
    })
}

/// The steady discharge rate, kg/s: the slope of the cumulative discharged mass against time
/// (the `time` and `mass` columns of `discharge.csv`) over the window `[t0, t1]`. Choose a
/// window after the start-up transient (the flow takes a few orifice transit times to settle)
/// and before the silo runs low (the rate drops once the fill height falls below about the
/// silo's width, Janssen screening no longer holding).
pub fn discharge_rate(rows: &[(f64, f64)], t0: f64, t1: f64) -> Option<f64> {
    let window: Vec<(f64, f64)> = rows
        .iter()
        .copied()
        .filter(|&(t, _)| t >= t0 && t <= t1)
        .collect();
    fit_line(&window).map(|l| l.slope)
}

/// The fitted constants of Beverloo's law `W = C rho_b sqrt(g) (D - k d)^(5/2)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beverloo {
    /// The discharge coefficient `C` (literature: about 0.58 for a flat-bottomed silo).
    pub c: f64,
    /// The empty-annulus coefficient `k` (literature: about 1.5 for spheres).
    pub k: f64,
}

/// Fits Beverloo's law to measured discharge rates `(D, W)` (orifice size in m, rate in
/// kg/s) of a material of bulk density `rho_b` (kg/m^3) and particle diameter `d` (m) under
/// gravity `g`: `W^(2/5)` is linear in `D`, `W^(2/5) = a (D - k d)` with
/// `a = (C rho_b sqrt(g))^(2/5)`, so a least-squares line `W^(2/5) = p + a D` gives
/// `C = a^(5/2) / (rho_b sqrt(g))` and `k = -p / (a d)`. For a square orifice of side `D`
/// the same law holds with `C` about 20-30% larger than for a circle of diameter `D`
/// (the area ratio `4/pi`); the caller says which it measured. `None` with fewer than two
/// distinct sizes or a non-increasing rate.
pub fn fit_beverloo(points: &[(f64, f64)], rho_b: f64, g: f64, d: f64) -> Option<Beverloo> {
    let lin: Vec<(f64, f64)> = points.iter().map(|&(dd, w)| (dd, w.powf(0.4))).collect();
    let l = fit_line(&lin)?;
    if l.slope <= 0.0 || l.slope.is_nan() {
        return None;
    }
    Some(Beverloo {
        c: l.slope.powf(2.5) / (rho_b * g.sqrt()),
        k: -l.intercept / (l.slope * d),
    })
}

/// The free surface of a bed seen in a drum's cross-section, and the angle it makes with the
/// horizontal.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// The surface points used: per column, the highest body centre.
    pub points: Vec<(f64, f64)>,
    /// The least-squares line through them, `v = intercept + slope u`.
    pub line: Line,
    /// `atan(|slope|)`, degrees: the dynamic angle of repose.
    pub angle_deg: f64,
}

/// The dynamic angle of repose of a drum's bed: `points` are body centres in the drum's
/// cross-section, `(u, v)` with `v` up and `u` horizontal across the axis, relative to the
/// axis. The cross-section is cut into `columns` columns of equal width across
/// `[-reach, reach]` (take `reach` about 0.6 of the drum's radius: the middle of the surface,
/// away from the curved wall where the surface bends); in each column the highest centre is
/// a surface point, and the surface is the least-squares line through them. `None` with fewer
/// than two non-empty columns.
pub fn drum_surface(points: &[(f64, f64)], reach: f64, columns: usize) -> Option<Surface> {
    let width = 2.0 * reach / columns as f64;
    let mut top: Vec<Option<(f64, f64)>> = vec![None; columns];
    for &(u, v) in points {
        if !(u >= -reach && u < reach) {
            continue;
        }
        let c = (((u + reach) / width) as usize).min(columns - 1);
        if top[c].is_none_or(|(_, tv)| v > tv) {
            top[c] = Some((u, v));
        }
    }
    let surface: Vec<(f64, f64)> = top.into_iter().flatten().collect();
    let line = fit_line(&surface)?;
    Some(Surface {
        angle_deg: line.slope.abs().atan().to_degrees(),
        points: surface,
        line,
    })
}

/// The inclination of a drum's bed from its centre of mass, degrees: the angle of the flat
/// free surface that has the bed's centroid. `points` are body centres in the cross-section,
/// `(u, v)` relative to the drum's axis with `v` up (as for [`drum_surface`]). The region the
/// centres fill, bounded by the drum's circle and a flat free surface, is a circular segment,
/// and a segment's centroid lies on the radius perpendicular to its chord: so the surface is
/// inclined by `atan(|u_c| / -v_c)` from the horizontal, whatever the fill. Unlike the
/// highest-centre fit of [`drum_surface`] it uses every body, so frames fluctuate less and a
/// grain thrown above the surface barely moves it; a surface that is not flat (the S shape of
/// fast drums) gives the inclination of its chord. (A bed more than half full is the circle
/// less a segment, whose centroid lies on the same radius, so the formula holds there too.)
/// `None` for no points or a centroid that is not below the axis.
pub fn drum_bed_angle(points: &[(f64, f64)]) -> Option<f64> {
    if points.is_empty() {
        return None;
    }
    let n = points.len() as f64;
    let uc = points.iter().map(|p| p.0).sum::<f64>() / n;
    let vc = points.iter().map(|p| p.1).sum::<f64>() / n;
    if vc.is_nan() || vc >= 0.0 {
        return None;
    }
    Some(uc.abs().atan2(-vc).to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for noise in [-1, 1).
    fn noise(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn line_through_exact_points() {
        let l = fit_line(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]).unwrap();
        assert!((l.slope - 2.0).abs() < 1e-12 && (l.intercept - 1.0).abs() < 1e-12);
        assert!(fit_line(&[(1.0, 1.0)]).is_none());
        assert!(fit_line(&[(1.0, 1.0), (1.0, 2.0)]).is_none());
    }

    #[test]
    fn discharge_rate_is_the_slope_in_the_window() {
        // 2 kg/s between t = 0.2 and 1.0, a slow start before and a tail after.
        let rows: Vec<(f64, f64)> = (0..=150)
            .map(|i| {
                let t = i as f64 * 0.01;
                let m = if t < 0.2 {
                    5.0 * t * t
                } else if t <= 1.0 {
                    0.2 + 2.0 * (t - 0.2)
                } else {
                    1.8 + 0.5 * (t - 1.0)
                };
                (t, m)
            })
            .collect();
        let w = discharge_rate(&rows, 0.25, 0.95).unwrap();
        assert!((w - 2.0).abs() < 1e-9, "{w}");
    }

    #[test]
    fn beverloo_constants_are_recovered() {
        let (c, k, rho, g, d): (f64, f64, f64, f64, f64) = (0.58, 1.5, 1500.0, 9.81, 0.002);
        // Four orifices, D/d from 5 to 15, rates with 1% noise.
        let mut seed = 7;
        let points: Vec<(f64, f64)> = [5.0, 8.0, 11.0, 15.0]
            .iter()
            .map(|r| {
                let dd = r * d;
                let w = c * rho * g.sqrt() * (dd - k * d).powf(2.5);
                (dd, w * (1.0 + 0.01 * noise(&mut seed)))
            })
            .collect();
        let exact: Vec<(f64, f64)> = points
            .iter()
            .map(|&(dd, _)| (dd, c * rho * g.sqrt() * (dd - k * d).powf(2.5)))
            .collect();
        let b = fit_beverloo(&exact, rho, g, d).unwrap();
        assert!((b.c - c).abs() < 1e-9 && (b.k - k).abs() < 1e-9, "{b:?}");
        let b = fit_beverloo(&points, rho, g, d).unwrap();
        assert!((b.c - c).abs() < 0.02 && (b.k - k).abs() < 0.15, "{b:?}");
        assert!(fit_beverloo(&[(0.01, 1.0)], rho, g, d).is_none());
    }

    #[test]
    fn drum_surface_angle_is_recovered() {
        // A bed of disks packed below a surface through the axis at 27 degrees, radius 0.1,
        // particle spacing 4 mm, centres jittered by 0.5 mm.
        for angle in [12.0f64, 27.0, 38.0] {
            let slope = angle.to_radians().tan();
            let (r, s) = (0.1, 0.004);
            let mut seed = 3;
            let mut pts = Vec::new();
            let n = (r / s) as i64;
            for i in -n..=n {
                for j in -n..=n {
                    let (u, v) = (i as f64 * s, j as f64 * s);
                    if u * u + v * v < (r - s) * (r - s) && v <= slope * u {
                        pts.push((u + 0.0005 * noise(&mut seed), v + 0.0005 * noise(&mut seed)));
                    }
                }
            }
            let surf = drum_surface(&pts, 0.06, 12).unwrap();
            assert!(
                (surf.angle_deg - angle).abs() < 1.5,
                "{angle}: fitted {}",
                surf.angle_deg
            );
            assert!(surf.points.len() >= 10);
        }
        assert!(drum_surface(&[(0.0, 0.0)], 0.06, 12).is_none());
    }

    #[test]
    fn drum_bed_angle_is_the_chord_of_a_segment() {
        // Beds filling circular segments (fills from a third to a half) under chords at known
        // angles, on a jittered lattice: the centroid direction recovers the chord's angle, and
        // the highest-centre fit agrees with it on these flat surfaces.
        for (angle, offset) in [(12.0f64, 0.0), (27.0, 0.01), (38.0, 0.02), (27.0, 0.0)] {
            let (r, s) = (0.1f64, 0.002);
            let (sn, cs) = angle.to_radians().sin_cos();
            let mut seed = 5;
            let mut pts = Vec::new();
            let n = (r / s) as i64;
            for i in -n..=n {
                for j in -n..=n {
                    let (u, v) = (i as f64 * s, j as f64 * s);
                    // Below the chord whose normal is (-sin, cos), `offset` below the axis.
                    if u * u + v * v < r * r && -sn * u + cs * v <= -offset {
                        pts.push((u + 0.0003 * noise(&mut seed), v + 0.0003 * noise(&mut seed)));
                    }
                }
            }
            let a = drum_bed_angle(&pts).unwrap();
            assert!((a - angle).abs() < 0.2, "{angle}: centroid gives {a}");
            let mirrored: Vec<(f64, f64)> = pts.iter().map(|&(u, v)| (-u, v)).collect();
            assert!((drum_bed_angle(&mirrored).unwrap() - a).abs() < 1e-9);
            let surf = drum_surface(&pts, 0.05, 10).unwrap();
            assert!(
                (surf.angle_deg - a).abs() < 1.0,
                "{angle}: {} vs {a}",
                surf.angle_deg
            );
        }
        assert!(drum_bed_angle(&[]).is_none());
        assert!(drum_bed_angle(&[(0.0, 0.01)]).is_none());
    }
}
