//! A gear train: a chain of parallel stages whose gears are rigid discs on torsionally elastic shafts, each
//! mesh with its own periodic stiffness and tooth errors (Eqs 40-44 per mesh), as one linear system with
//! two kinds of periodic coefficients.
//!
//! ```text
//! DOF: theta_(2k) pinion of stage k, theta_(2k+1) its wheel, rad, each positive in its gear's own sense of
//!      rotation (deviation from the nominal rigid rotation); N = 2 S for S stages.
//! mesh k:  delta_k = r_p theta_p - r_w theta_w  (compression along the line of action, m),  w_k = d delta_k / d theta
//!          F_k = k_k(t) (delta_k - e_k(t)) + c_k (delta_k' - e_k'(t)),   c_k = 2 zeta_k sqrt(k0_k m_red_k) (Eq 40)
//! shafts:  input: motor (held at the nominal speed) -- k_1 -- pinion 1;  shaft j between wheel j-1 and
//!          pinion j: k_j on the twist;  output: wheel S -- k_out -- load flywheel (nominal speed);
//!          a constant load torque T_L resists on wheel S.
//! J theta'' + C theta' + (K_shafts + sum_k k_k(t) w_k w_k^T) theta = sum_k w_k (k_k(t) e_k(t) + c_k e_k'(t)) - T_L u_out
//! ```
//! Stage k's coefficients repeat with its own period T_k: one mesh cycle without errors, one pinion
//! revolution with pinion errors, one wheel revolution with wheel errors, z_w / gcd(z_p, z_w) pinion
//! revolutions with both. The stages' periods are exact rational multiples of the reference shaft's
//! revolution, so the common period is exact too; it can hold thousands of mesh cycles.

use super::kinematics::Ratio;
use crate::system::{Coefficient, FourierSeries, TwoToneForm};
use std::f64::consts::PI;

/// One gear of a train.
#[derive(Clone, Debug)]
pub struct TrainGear {
    /// Teeth.
    pub teeth: u32,
    /// Polar moment of inertia, kg m^2.
    pub inertia_kg_m2: f64,
    /// Base radius, m.
    pub base_radius_m: f64,
    /// Transmission error of this gear's origin along the line of action as a series in its rotation angle
    /// (harmonic j at j times its rotation frequency; `omega_rad_s` ignored), m.
    pub errors: FourierSeries,
}

/// One parallel stage of a train.
#[derive(Clone, Debug)]
pub struct TrainStage {
    /// Driving gear.
    pub pinion: TrainGear,
    /// Driven gear.
    pub wheel: TrainGear,
    /// Mesh stiffness over one mesh cycle (harmonic j at j times the mesh frequency), N/m.
    pub mesh: FourierSeries,
    /// Mesh damping ratio.
    pub damping_ratio: f64,
    /// Pinion speed relative to the reference shaft (exact, signed).
    pub pinion_order: Ratio,
}

/// Torsional shaft element.
#[derive(Clone, Copy, Debug)]
pub struct TrainShaft {
    /// Torsional stiffness, N m/rad.
    pub stiffness_n_m_per_rad: f64,
    /// Torsional damping, N m s/rad.
    pub damping_n_m_s_per_rad: f64,
}

/// A validated gear train (the scene checks every value).
#[derive(Clone, Debug)]
pub struct GearTrain {
    /// Stages in chain order.
    pub stages: Vec<TrainStage>,
    /// Shafts in chain order: input, the S - 1 intermediate shafts, output (S + 1).
    pub shafts: Vec<TrainShaft>,
    /// Reference shaft rotation frequency, Hz.
    pub speed_hz: f64,
    /// Load torque on the output wheel, N m.
    pub load_torque_n_m: f64,
}

/// The coefficients of one stage over its own period: base frequency, stiffness k(t), error e(t).
#[derive(Clone, Debug)]
pub struct StageSeries {
    /// Base frequency nu_k relative to the reference shaft's rotation (exact).
    pub base_order: Ratio,
    /// k_k(t), N/m, a series in nu_k.
    pub stiffness: FourierSeries,
    /// e_k(t), m, a series in nu_k.
    pub error: FourierSeries,
}

/// Series `s` of base w0 with each harmonic j moved to j * factor (the same function of time when the new
/// base is w0 / factor).
pub fn stretch(s: &FourierSeries, factor: usize) -> FourierSeries {
    if s.is_constant() || factor == 1 {
        return s.clone();
    }
    let h = s.harmonics() * factor;
    let (mut c, mut si) = (vec![0.0; h], vec![0.0; h]);
    for j in 1..=s.harmonics() {
        c[j * factor - 1] = s.cos[j - 1];
        si[j * factor - 1] = s.sin[j - 1];
    }
    FourierSeries::new(s.omega_rad_s, s.mean, c, si)
}

fn whole(r: Ratio) -> usize {
    debug_assert!(r.den() == 1 && r.num() >= 0, "expected a whole number, got {r}");
    r.num() as usize
}

impl TrainStage {
    /// Pinion revolutions in the stage's own period (see the module doc).
    pub fn revolutions(&self) -> Ratio {
        let (zp, zw) = (self.pinion.teeth as i128, self.wheel.teeth as i128);
        match (!self.pinion.errors.is_constant(), !self.wheel.errors.is_constant()) {
            (false, false) => Ratio::new(1, zp),
            (true, false) => Some(Ratio::ONE),
            (false, true) => Ratio::new(zw, zp),
            (true, true) => Some(Ratio::integer(zw / crate::system::gcd(zp as usize, zw as usize) as i128)),
        }
        .unwrap_or(Ratio::ONE)
    }

    /// Reduced mass of the mesh (Eq 40), kg.
    pub fn reduced_mass_kg(&self) -> f64 {
        let (j1, j2) = (self.pinion.inertia_kg_m2, self.wheel.inertia_kg_m2);
        let (r1, r2) = (self.pinion.base_radius_m, self.wheel.base_radius_m);
        j1 * j2 / (j1 * r2 * r2 + j2 * r1 * r1)
    }

    /// Mesh damping c = 2 zeta sqrt(k0 m_red), N s/m.
    pub fn damping_n_s_per_m(&self) -> f64 {
        2.0 * self.damping_ratio * (self.mesh.mean * self.reduced_mass_kg()).sqrt()
    }

    /// The stage's coefficients over its own period.
    pub fn series(&self) -> StageSeries {
        let revs = self.revolutions();
        let base_order = self.pinion_order.abs().checked_div(revs).unwrap_or(Ratio::ONE);
        let zp = Ratio::integer(self.pinion.teeth as i128);
        let zw = Ratio::integer(self.wheel.teeth as i128);
        let per = |r: Option<Ratio>| r.map_or(1, whole);
        let mesh = stretch(&self.mesh, per(revs.checked_mul(zp)));
        let pin = stretch(&self.pinion.errors, per(Some(revs)));
        let wheel = stretch(&self.wheel.errors, per(revs.checked_mul(zp).and_then(|x| x.checked_div(zw))));
        StageSeries { base_order, stiffness: mesh, error: pin.plus(&wheel) }
    }
}

/// Second-order form with each stage's coefficients given as series of that stage's base (the input of
/// both the common-period system and the two-frequency form).
#[derive(Clone, Debug)]
pub struct TrainMatrices {
    /// DOF N = 2 S.
    pub dof: usize,
    /// Diagonal inertias, kg m^2.
    pub mass: Vec<f64>,
    /// Constant damping (shafts and meshes), row-major.
    pub damping: Vec<f64>,
    /// Constant stiffness (shafts), row-major.
    pub stiffness: Vec<f64>,
    /// Constant forcing (the load torque), N m.
    pub forcing: Vec<f64>,
    /// Per stage: its base order and, as series of it, the stiffness entries (N x N) and forcing (N).
    pub stages: Vec<(Ratio, Vec<FourierSeries>, Vec<FourierSeries>)>,
}

impl GearTrain {
    /// Degrees of freedom (two gears per stage).
    pub fn dof(&self) -> usize {
        2 * self.stages.len()
    }

    /// Line-of-action weights of mesh k: delta_k = w . theta.
    pub fn mesh_weights(&self, k: usize) -> Vec<f64> {
        let mut w = vec![0.0; self.dof()];
        w[2 * k] = self.stages[k].pinion.base_radius_m;
        w[2 * k + 1] = -self.stages[k].wheel.base_radius_m;
        w
    }

    /// The matrices of the module doc, each stage's periodic part as series of its own base.
    pub fn matrices(&self) -> TrainMatrices {
        let n = self.dof();
        let s = self.stages.len();
        let mut mass = vec![0.0; n];
        let (mut damping, mut stiffness) = (vec![0.0; n * n], vec![0.0; n * n]);
        for (k, st) in self.stages.iter().enumerate() {
            mass[2 * k] = st.pinion.inertia_kg_m2;
            mass[2 * k + 1] = st.wheel.inertia_kg_m2;
        }
        // shafts: input to ground at pinion 0, twist between wheel j-1 and pinion j, output wheel to ground
        let mut spring = |a: usize, b: Option<usize>, sh: &TrainShaft| {
            stiffness[a * n + a] += sh.stiffness_n_m_per_rad;
            damping[a * n + a] += sh.damping_n_m_s_per_rad;
            if let Some(b) = b {
                stiffness[b * n + b] += sh.stiffness_n_m_per_rad;
                damping[b * n + b] += sh.damping_n_m_s_per_rad;
                stiffness[a * n + b] -= sh.stiffness_n_m_per_rad;
                stiffness[b * n + a] -= sh.stiffness_n_m_per_rad;
                damping[a * n + b] -= sh.damping_n_m_s_per_rad;
                damping[b * n + a] -= sh.damping_n_m_s_per_rad;
            }
        };
        spring(0, None, &self.shafts[0]);
        for j in 1..s {
            spring(2 * j - 1, Some(2 * j), &self.shafts[j]);
        }
        spring(2 * s - 1, None, &self.shafts[s]);
        let mut forcing = vec![0.0; n];
        forcing[2 * s - 1] = -self.load_torque_n_m;
        let mut stages = Vec::with_capacity(s);
        for (k, st) in self.stages.iter().enumerate() {
            let w = self.mesh_weights(k);
            let c = st.damping_n_s_per_m();
            for a in 0..n {
                for b in 0..n {
                    damping[a * n + b] += c * w[a] * w[b];
                }
            }
            let ser = st.series();
            // k e + c e' (the series' own base: the derivative needs it)
            let wk = 2.0 * PI * self.speed_hz * ser.base_order.to_f64();
            let mut e = ser.error.clone();
            e.omega_rad_s = wk;
            let mut kz = ser.stiffness.clone();
            kz.omega_rad_s = wk;
            let drive = kz.times(&e).plus(&e.derivative().scaled(c));
            let kmat = (0..n * n).map(|ab| kz.scaled(w[ab / n] * w[ab % n])).collect();
            let fvec = (0..n).map(|a| drive.scaled(w[a])).collect();
            stages.push((ser.base_order, kmat, fvec));
        }
        TrainMatrices { dof: n, mass, damping, stiffness, forcing, stages }
    }

    /// Base frequency of every stage, Hz.
    pub fn stage_base_hz(&self) -> Vec<f64> {
        self.stages.iter().map(|s| s.series().base_order.to_f64() * self.speed_hz).collect()
    }
}

/// gcd of positive rationals: gcd(a/b, c/d) = gcd(a d, c b) / (b d), reduced; `None` on overflow.
pub fn rational_gcd(values: &[Ratio]) -> Option<Ratio> {
    let mut acc: Option<Ratio> = None;
    for &v in values {
        let v = v.abs();
        acc = Some(match acc {
            None => v,
            Some(a) => {
                let num = crate::system::gcd(
                    a.num().checked_mul(v.den())?.try_into().ok()?,
                    v.num().checked_mul(a.den())?.try_into().ok()?,
                );
                Ratio::new(num as i128, a.den().checked_mul(v.den())?)?
            }
        });
    }
    acc
}

impl TrainMatrices {
    /// The whole train over the common period 1 / nu0 (nu0 = `base_order` times the reference speed
    /// `speed_hz`): each
    /// stage's series stretched by nu_k / nu0 (whole numbers). Entries as [`Coefficient`]s, row-major.
    pub fn common_period(
        &self,
        base_order: Ratio,
        speed_hz: f64,
    ) -> (Vec<Coefficient>, Vec<Coefficient>, Vec<Coefficient>, Vec<Coefficient>) {
        let w0 = 2.0 * PI * speed_hz * base_order.to_f64();
        let n = self.dof;
        let mut stiff: Vec<FourierSeries> = self.stiffness.iter().map(|&v| FourierSeries::constant(v)).collect();
        let mut force: Vec<FourierSeries> = self.forcing.iter().map(|&v| FourierSeries::constant(v)).collect();
        for (order, k, f) in &self.stages {
            let m = order.checked_div(base_order).map_or(1, whole);
            for (acc, s) in stiff.iter_mut().zip(k) {
                *acc = acc.plus(&stretch(s, m));
            }
            for (acc, s) in force.iter_mut().zip(f) {
                *acc = acc.plus(&stretch(s, m));
            }
        }
        let mass =
            (0..n * n).map(|e| Coefficient::constant(if e / n == e % n { self.mass[e / n] } else { 0.0 })).collect();
        let damping = self.damping.iter().map(|&v| Coefficient::constant(v)).collect();
        stiff.iter_mut().chain(force.iter_mut()).for_each(|s| s.omega_rad_s = w0);
        (
            mass,
            damping,
            stiff.into_iter().map(Coefficient::Fourier).collect(),
            force.into_iter().map(Coefficient::Fourier).collect(),
        )
    }

    /// The two-tone form of a two-stage train: stage 1 tone a, stage 2 tone b, the constant parts in tone a;
    /// `speed_hz` is the reference shaft's frequency.
    ///
    /// # Panics
    /// When the train does not have exactly two stages (a programmer error: the caller checks).
    pub fn two_tone(&self, speed_hz: f64) -> TwoToneForm {
        assert_eq!(self.stages.len(), 2, "two-tone form needs two stages");
        let n = self.dof;
        let omega = [0, 1].map(|t| 2.0 * PI * speed_hz * self.stages[t].0.to_f64());
        let tone = |t: usize| -> (Vec<FourierSeries>, Vec<FourierSeries>) {
            let (_, k, f) = &self.stages[t];
            if t == 0 {
                (
                    k.iter().zip(&self.stiffness).map(|(s, &c)| s.plus(&FourierSeries::constant(c))).collect(),
                    f.iter().zip(&self.forcing).map(|(s, &c)| s.plus(&FourierSeries::constant(c))).collect(),
                )
            } else {
                (k.clone(), f.clone())
            }
        };
        let (ka, fa) = tone(0);
        let (kb, fb) = tone(1);
        let mass = (0..n * n).map(|e| if e / n == e % n { self.mass[e / n] } else { 0.0 }).collect();
        TwoToneForm {
            dof: n,
            omega_rad_s: omega,
            mass,
            damping: self.damping.clone(),
            stiffness: [ka, kb],
            forcing: [fa, fb],
        }
    }
}
