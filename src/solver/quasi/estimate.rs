//! The truncation and its error estimate (see the parent module): the change between two solutions, the
//! layers of each class around its centre, the size of the outermost layers, and how many layers a tone
//! grows by.

use super::{C64, TwoToneSolution};

/// Relative difference between two solutions (the second with the larger truncation): per DOF and for y
/// and y', sum |dY_kl| (times |w_kl| for y') over sum |Y_kl| of the second, the largest: a bound on the
/// time-domain change relative to the solution's size.
pub fn difference(a: &TwoToneSolution, b: &TwoToneSolution) -> f64 {
    let n = b.dof;
    // per DOF and kind (y, y'): sum |dY| w and sum |Y| w
    let (mut diff, mut size) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
    let abs = |c: C64| c.norm_sqr().sqrt();
    for bb in &b.blocks {
        let ab = a.blocks.iter().find(|x| x.same_class(bb));
        for il in 0..bb.nl {
            for ik in 0..bb.nk {
                let jb = bb.start + il * bb.nk + ik;
                let (k, l) = b.lines[jb];
                let w = b.frequency_rad_s(k, l).abs();
                let ja = ab.and_then(|ab| bb.map_to(ab, ik, il));
                for i in 0..n {
                    let yb = b.coeffs[jb * n + i];
                    let ya = ja.map_or(C64::new(0.0, 0.0), |j| a.coeffs[j * n + i]);
                    let (d, y) = (abs(yb - ya), abs(yb));
                    diff[i] += d;
                    size[i] += y;
                    diff[n + i] += d * w;
                    size[n + i] += y * w;
                }
            }
        }
    }
    // lines only the first holds (none when the second's truncation contains the first's)
    for ab in &a.blocks {
        let bb = b.blocks.iter().find(|x| x.same_class(ab));
        for il in 0..ab.nl {
            for ik in 0..ab.nk {
                if bb.is_some_and(|bb| ab.map_to(bb, ik, il).is_some()) {
                    continue;
                }
                let ja = ab.start + il * ab.nk + ik;
                let (k, l) = a.lines[ja];
                let w = a.frequency_rad_s(k, l).abs();
                for i in 0..n {
                    let d = abs(a.coeffs[ja * n + i]);
                    diff[i] += d;
                    diff[n + i] += d * w;
                }
            }
        }
    }
    diff.iter().zip(&size).filter(|(_, s)| **s > 0.0).map(|(d, s)| d / s).fold(0.0, f64::max)
}

/// Distance in strides of line index x from the centre of its residue class (the class's line nearest 0):
/// its layer, 0 for a tone that does not vary the stiffness (stride 0).
fn layer(x: isize, stride: usize) -> usize {
    if stride == 0 {
        return 0;
    }
    let g = stride as isize;
    let c = x.rem_euclid(g);
    let centre = if 2 * c > g { c - g } else { c };
    ((x - centre) / g).unsigned_abs()
}

/// Truncation of a tone holding `n` layers each side of every class centre: n g + floor(g / 2) harmonics,
/// so that every residue class has 2n + 1 lines (stride 0: the forcing's harmonics `forced`).
pub(super) fn truncation(n: usize, stride: usize, forced: usize) -> usize {
    if stride == 0 { forced } else { n * stride + stride / 2 }
}

/// Per tone, the size of the outermost layer (n and beyond) and of the one inside it (n - 1), in the measure
/// of [`difference`] (per DOF and for y and y', sum |Y_kl| (times |w| for y') over the solution's sum, the
/// largest).
pub(super) fn tails(sol: &TwoToneSolution, strides: [usize; 2], n: [usize; 2]) -> [[f64; 2]; 2] {
    let dof = sol.dof;
    // per tone, [outer, inner], per DOF and kind
    let mut part = vec![[[0.0; 2]; 2]; 2 * dof];
    let mut size = vec![0.0; 2 * dof];
    for (j, &(k, l)) in sol.lines.iter().enumerate() {
        let w = sol.frequency_rad_s(k, l).abs();
        let layers = [layer(k, strides[0]), layer(l, strides[1])];
        for i in 0..dof {
            let y = sol.coeffs[j * dof + i].norm_sqr().sqrt();
            for (kind, v) in [(i, y), (dof + i, y * w)] {
                size[kind] += v;
                for t in 0..2 {
                    if strides[t] == 0 || n[t] == 0 {
                        continue;
                    }
                    if layers[t] >= n[t] {
                        part[kind][t][0] += v;
                    } else if layers[t] + 1 == n[t] {
                        part[kind][t][1] += v;
                    }
                }
            }
        }
    }
    let mut out = [[0.0; 2]; 2];
    for (p, s) in part.iter().zip(&size) {
        if *s > 0.0 {
            for t in 0..2 {
                for e in 0..2 {
                    out[t][e] = f64::max(out[t][e], p[t][e] / s);
                }
            }
        }
    }
    out
}

/// Layers to add to a tone whose outermost layer has size `tail[0]` (`tail[1]` inside it): the fewest (at
/// least one) after which the geometric tail predicts the layers beyond below `target`; half the layers
/// again when the layers do not yet shrink; at most 3n (and 4).
pub(super) fn grow(n: usize, tail: [f64; 2], target: f64) -> usize {
    let [outer, inner] = tail;
    let most = (3 * n).max(4);
    if outer == 0.0 {
        return 1;
    }
    if outer >= inner {
        return n.div_ceil(2).max(1);
    }
    let rho = outer / inner;
    let mut d = 1;
    // outer rho^(d + 1) / (1 - rho): the layers beyond n + d
    while d < most && outer * rho.powi(d as i32 + 1) / (1.0 - rho) > target {
        d += 1;
    }
    d
}
