//! The labelled spectral lines of a machine: every stage's mesh harmonics and the sideband families of
//! its shafts and of the planet pass, at exact orders of the reference shaft.

use super::{Machine, Member, Ratio, Stage};

/// What a labelled spectral line is.
#[derive(Clone, Debug, PartialEq)]
pub enum LineKind {
    /// Harmonic h of a stage's mesh frequency.
    Mesh {
        /// Harmonic, 1-based.
        harmonic: u32,
    },
    /// Sideband n (signed) of mesh harmonic h, spaced by a shaft's rotation.
    ShaftSideband {
        /// Mesh harmonic.
        harmonic: u32,
        /// Sideband index, non-zero.
        n: i32,
        /// Index of the shaft whose rotation spaces the family.
        shaft: usize,
    },
    /// Sideband n (signed) of mesh harmonic h of a planetary stage, spaced by the planet-pass frequency.
    PlanetPassSideband {
        /// Mesh harmonic.
        harmonic: u32,
        /// Sideband index, non-zero.
        n: i32,
    },
}

/// A spectral line a report or a diagnosis marks: its exact order (relative to the reference shaft), the
/// stage (0-based) and what it is, with a label naming the shaft.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Order (frequency over the reference shaft's rotation frequency), exact, > 0.
    pub order: Ratio,
    /// Stage index, 0-based.
    pub stage: usize,
    /// What the line is.
    pub kind: LineKind,
    /// "stage 2 mesh x3", "stage 1 mesh x1 - 2 x intermediate", "stage 1 mesh x1 + 1 x planet pass".
    pub label: String,
}

impl Machine {
    /// The lines of every stage: mesh harmonics 1..=`harmonics` and, around each, the sideband families
    /// n = +-1..=`sidebands` of every shaft carrying one of the stage's gears (both shafts of a parallel
    /// stage: an intermediate shaft's family appears around both of its meshes; the turning members of a
    /// planetary stage) and, for a planetary stage, of the planet pass. Lines at orders <= 0 are left out;
    /// lines of different families may share an order (both are listed).
    pub fn labelled_lines(&self, harmonics: u32, sidebands: u32) -> Vec<Line> {
        let mut out = Vec::new();
        for (k, stage) in self.stages.iter().enumerate() {
            let Some(mesh) = self.mesh_order(k) else { continue };
            let (shafts, pass): (Vec<usize>, Option<Ratio>) = match stage {
                Stage::Parallel(p) => (vec![p.driving, p.driven], None),
                Stage::Planetary(p) => (
                    [p.sun, p.carrier, p.ring]
                        .iter()
                        .filter_map(|m| if let Member::Shaft(i) = m { Some(*i) } else { None })
                        .collect(),
                    self.planetary_orders(k).map(|o| o.planet_pass).filter(|r| !r.is_zero()),
                ),
            };
            for h in 1..=harmonics {
                let Some(centre) = mesh.checked_mul(Ratio::integer(h as i128)) else { continue };
                out.push(Line {
                    order: centre,
                    stage: k,
                    kind: LineKind::Mesh { harmonic: h },
                    label: format!("stage {} mesh x{h}", k + 1),
                });
                let mut family = |spacing: Ratio, kind: &dyn Fn(i32) -> LineKind, name: &str| {
                    for n in 1..=sidebands as i32 {
                        for sign in [-1i32, 1] {
                            let step = spacing.checked_mul(Ratio::integer((sign * n) as i128));
                            let Some(order) = step.and_then(|s| centre.checked_add(s)) else { continue };
                            if order.num() <= 0 {
                                continue;
                            }
                            let op = if sign < 0 { '-' } else { '+' };
                            out.push(Line {
                                order,
                                stage: k,
                                kind: kind(sign * n),
                                label: format!("stage {} mesh x{h} {op} {n} x {name}", k + 1),
                            });
                        }
                    }
                };
                for &i in &shafts {
                    family(
                        self.orders[i].abs(),
                        &|n| LineKind::ShaftSideband { harmonic: h, n, shaft: i },
                        &self.shafts[i],
                    );
                }
                if let Some(pp) = pass {
                    family(pp, &|n| LineKind::PlanetPassSideband { harmonic: h, n }, "planet pass");
                }
            }
        }
        out
    }
}
