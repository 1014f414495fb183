//! Gear pair with periodic mesh stiffness and transmission errors (Eqs 36-46).
//!
//! ```text
//! q = rb1 phi1 + rb2 phi2                                   (Eq 38, dynamic transmission error, m)
//! m_red = J1 J2 / (J1 rb2^2 + J2 rb1^2)                     (Eq 40)
//! m_red q'' + c_z q' + k_z(t) q = f(t)                      (Eq 42)
//! f(t) = k0 q0 - (k_z(t) - k0) e(t) - c_z e'(t)            (Eq 42, load from Eq 41)
//! k_z(t) = k0 + sum_n k_n cos(n w_z t + gamma_n)            (Eq 43), w_z = z1 w1
//! e(t) = sum_i e_i cos(i w1 t + alpha_i)  [+ wheel orders]  (Eq 44)
//! c_z = 2 zeta sqrt(k0 m_red)
//! ```
//! State x = [q, q'] (m, m/s). The period is the shortest the scene needs: one mesh cycle for a smooth
//! healthy mesh, one pinion revolution with pinion errors, one wheel revolution with wheel errors only,
//! and the hunting period z_w / gcd(z_p, z_w) pinion revolutions with both.

use crate::system::gcd;
use crate::system::{FourierForm, FourierSeries, PeriodicSystem, PiecewiseConstant, Side};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// Periodic mesh stiffness over one mesh cycle.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshStiffness {
    /// Fourier series in the mesh angle (base w_z = z1 w1), N/m.
    Fourier(FourierSeries),
    /// Piecewise-constant values over one mesh cycle, N/m. Given over any period (for example 1 = one
    /// cycle, starts as fractions of it); [`GearPair::new`] rescales it to the mesh period 1/f_z in s.
    Piecewise(PiecewiseConstant),
}

impl MeshStiffness {
    /// Mean stiffness k0 in N/m.
    pub fn mean(&self) -> f64 {
        match self {
            Self::Fourier(s) => s.mean,
            Self::Piecewise(p) => p.mean(),
        }
    }
    fn eval(&self, t: f64, side: Side) -> f64 {
        match self {
            Self::Fourier(s) => s.eval(t),
            Self::Piecewise(p) => p.eval(t, side),
        }
    }
}

/// Which gear of the pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Gear {
    /// The driving gear (index 1 in the paper).
    Pinion,
    /// The driven gear (index 2).
    Wheel,
}

impl Gear {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pinion => "pinion",
            Self::Wheel => "wheel",
        }
    }
}

/// A stiffness drop on one cracked tooth: k_z is multiplied by `1 - loss` during that tooth's mesh cycle
/// `[ (tooth-1) T_z, tooth T_z )` of each revolution of its gear.
#[derive(Clone, Debug, PartialEq)]
pub struct Crack {
    /// Gear carrying the cracked tooth.
    pub gear: Gear,
    /// Tooth number, 1-based.
    pub tooth: usize,
    /// Fraction of stiffness lost, in (0, 1).
    pub loss: f64,
}

/// Physical parameters of the gear pair (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct GearPairParams {
    /// Pinion teeth z1.
    pub pinion_teeth: usize,
    /// Wheel teeth z2.
    pub wheel_teeth: usize,
    /// Pinion inertia J1 in kg m^2.
    pub pinion_inertia_kg_m2: f64,
    /// Wheel inertia J2 in kg m^2.
    pub wheel_inertia_kg_m2: f64,
    /// Pinion base radius rb1 in m.
    pub pinion_base_radius_m: f64,
    /// Wheel base radius rb2 in m.
    pub wheel_base_radius_m: f64,
    /// Pinion speed in rpm.
    pub speed_rpm: f64,
    /// Lehr damping ratio zeta of the mesh (c_z = 2 zeta sqrt(k0 m_red)).
    pub damping_ratio: f64,
    /// Static tooth deflection q0 in m.
    pub static_deflection_m: f64,
    /// Mesh stiffness k_z over one mesh cycle.
    pub mesh: MeshStiffness,
    /// Transmission error of pinion origin as a series in the pinion angle (w = w1), m.
    pub pinion_errors: FourierSeries,
    /// Transmission error of wheel origin as a series in the wheel angle (w = w2), m.
    pub wheel_errors: FourierSeries,
    /// Optional cracked tooth.
    pub crack: Option<Crack>,
}

/// The gear pair as a 2-state periodic system.
#[derive(Clone, Debug)]
pub struct GearPair {
    params: GearPairParams,
    m_red: f64,
    c_z: f64,
    k0: f64,
    period_s: f64,
    breakpoints: Vec<f64>,
}

impl GearPair {
    /// Builds the model; the parameters must already be validated (positive masses, radii, teeth).
    pub fn new(mut params: GearPairParams) -> Self {
        let (j1, j2) = (params.pinion_inertia_kg_m2, params.wheel_inertia_kg_m2);
        let (r1, r2) = (params.pinion_base_radius_m, params.wheel_base_radius_m);
        let m_red = j1 * j2 / (j1 * r2 * r2 + j2 * r1 * r1);
        let k0 = params.mesh.mean();
        let c_z = 2.0 * params.damping_ratio * (k0 * m_red).sqrt();
        let w1 = params.speed_rpm / 60.0 * 2.0 * PI;
        params.pinion_errors.omega_rad_s = w1;
        params.wheel_errors.omega_rad_s = w1 * params.pinion_teeth as f64 / params.wheel_teeth as f64;
        let mesh_period_s = 1.0 / (params.speed_rpm / 60.0 * params.pinion_teeth as f64);
        match &mut params.mesh {
            MeshStiffness::Fourier(s) => s.omega_rad_s = w1 * params.pinion_teeth as f64,
            MeshStiffness::Piecewise(p) => {
                let scale = mesh_period_s / p.period_s;
                p.starts.iter_mut().for_each(|s| *s *= scale);
                p.period_s = mesh_period_s;
            }
        }
        let mut g = Self { params, m_red, c_z, k0, period_s: 0.0, breakpoints: Vec::new() };
        g.period_s = g.revolutions_per_period() * g.pinion_period_s();
        g.breakpoints = g.find_breakpoints();
        g
    }

    /// Model parameters (with base frequencies filled in).
    pub fn params(&self) -> &GearPairParams {
        &self.params
    }
    /// Reduced mass m_red in kg (Eq 40).
    pub fn reduced_mass_kg(&self) -> f64 {
        self.m_red
    }
    /// Mesh damping c_z in N s/m.
    pub fn damping_n_s_per_m(&self) -> f64 {
        self.c_z
    }
    /// Mean natural angular frequency w0 = sqrt(k0 / m_red) in 1/s.
    pub fn natural_frequency_rad_s(&self) -> f64 {
        (self.k0 / self.m_red).sqrt()
    }
    /// Pinion rotation frequency f1 in Hz.
    pub fn pinion_hz(&self) -> f64 {
        self.params.speed_rpm / 60.0
    }
    /// Wheel rotation frequency f2 in Hz.
    pub fn wheel_hz(&self) -> f64 {
        self.pinion_hz() * self.params.pinion_teeth as f64 / self.params.wheel_teeth as f64
    }
    /// Mesh frequency f_z = z1 f1 in Hz.
    pub fn mesh_hz(&self) -> f64 {
        self.pinion_hz() * self.params.pinion_teeth as f64
    }
    fn pinion_period_s(&self) -> f64 {
        1.0 / self.pinion_hz()
    }
    fn needs_pinion(&self) -> bool {
        !self.params.pinion_errors.is_constant() || self.params.crack.as_ref().is_some_and(|c| c.gear == Gear::Pinion)
    }
    fn needs_wheel(&self) -> bool {
        !self.params.wheel_errors.is_constant() || self.params.crack.as_ref().is_some_and(|c| c.gear == Gear::Wheel)
    }

    /// Pinion revolutions in the period the scene needs (1/z1 for a healthy smooth mesh, 1 with pinion
    /// content, z2/z1 with wheel content only, z2/gcd(z1, z2) with both).
    pub fn revolutions_per_period(&self) -> f64 {
        let (z1, z2) = (self.params.pinion_teeth, self.params.wheel_teeth);
        match (self.needs_pinion(), self.needs_wheel()) {
            (false, false) => 1.0 / z1 as f64,
            (true, false) => 1.0,
            (false, true) => z2 as f64 / z1 as f64,
            (true, true) => (z2 / gcd(z1, z2)) as f64,
        }
    }

    /// Mesh cycles in one period.
    pub fn mesh_cycles_per_period(&self) -> usize {
        (self.revolutions_per_period() * self.params.pinion_teeth as f64).round() as usize
    }

    fn mesh_period_s(&self) -> f64 {
        1.0 / self.mesh_hz()
    }

    fn crack_window(&self) -> Option<(f64, f64, f64)> {
        // (start, end, repeat period) in s
        let c = self.params.crack.as_ref()?;
        let tz = self.mesh_period_s();
        let rev = match c.gear {
            Gear::Pinion => self.pinion_period_s(),
            Gear::Wheel => 1.0 / self.wheel_hz(),
        };
        Some(((c.tooth - 1) as f64 * tz, c.tooth as f64 * tz, rev))
    }

    fn crack_factor(&self, t: f64, side: Side) -> f64 {
        let Some((a, b, rev)) = self.crack_window() else { return 1.0 };
        let loss = self.params.crack.as_ref().map_or(0.0, |c| c.loss);
        // a time within eps of a jump counts as on it: the solver's grid puts nodes at a + r rev, whose
        // remainder modulo rev rounds to either side of a for r > 0 (a cracked wheel over the hunting
        // period), and taking the wrong side there dropped the step scheme to first order
        let eps = 1e-9 * (b - a);
        let mut tau = t.rem_euclid(rev);
        if rev - tau <= eps {
            tau -= rev; // the start of the next revolution
        }
        let inside = match side {
            Side::Right => tau >= a - eps && tau < b - eps,
            // the left limit at a revolution start is the end of the previous revolution: inside only when
            // the window is the last tooth's
            Side::Left => (tau > a + eps && tau <= b + eps) || (tau <= eps && b >= rev - eps),
        };
        if inside { 1.0 - loss } else { 1.0 }
    }

    fn find_breakpoints(&self) -> Vec<f64> {
        let mut out = Vec::new();
        let t = self.period_s;
        if let MeshStiffness::Piecewise(p) = &self.params.mesh {
            for cycle in 0..self.mesh_cycles_per_period() {
                out.extend(p.jumps().iter().map(|j| j + cycle as f64 * p.period_s));
            }
        }
        if let Some((a, b, rev)) = self.crack_window() {
            let reps = (t / rev).round() as usize;
            for r in 0..reps {
                out.push(a + r as f64 * rev);
                out.push(b + r as f64 * rev);
            }
        }
        out.retain(|&b| b > 1e-12 * t && b < t * (1.0 - 1e-12));
        out.sort_by(f64::total_cmp);
        out.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * t);
        out
    }

    /// Mesh stiffness k_z(t) in N/m including a crack.
    pub fn stiffness(&self, t: f64, side: Side) -> f64 {
        self.params.mesh.eval(t, side) * self.crack_factor(t, side)
    }

    /// Total transmission error e(t) and e'(t) in m and m/s.
    pub fn error(&self, t: f64) -> (f64, f64) {
        let p = self.params.pinion_errors.eval_derivatives(t);
        let w = self.params.wheel_errors.eval_derivatives(t);
        (p[0] + w[0], p[1] + w[1])
    }
}

impl GearPair {
    /// Eq 42 as a Fourier form over `revolutions` pinion revolutions (a whole number of mesh cycles, and of
    /// wheel revolutions when `wheel_errors` is not constant), with the forcing of the given errors alone
    /// (series in the pinion and wheel angles: only their coefficients are used) plus the static load
    /// k0 q0 when `static_load`:
    ///
    /// ```text
    /// f(t) = [k0 q0] - (k_z(t) - k0) e(t) - c_z e'(t),   e = pinion_errors(w1 t) + wheel_errors(w2 t)
    /// ```
    /// `None` when the mesh stiffness is not a Fourier series or the pair has a crack. The response is
    /// affine in e: the transfer from each error harmonic to the output is one solve of this form.
    pub fn fourier_form_with(
        &self,
        revolutions: f64,
        pinion_errors: &FourierSeries,
        wheel_errors: &FourierSeries,
        static_load: bool,
    ) -> Option<FourierForm> {
        let MeshStiffness::Fourier(mesh) = &self.params.mesh else { return None };
        if self.params.crack.is_some() {
            return None;
        }
        let period_s = revolutions * self.pinion_period_s();
        let w = 2.0 * PI / period_s;
        let per_period = |cycles: f64| cycles.round() as usize;
        let z1 = self.params.pinion_teeth as f64;
        let kz = stretch(mesh, per_period(revolutions * z1), w);
        let e = stretch(pinion_errors, per_period(revolutions), w).plus(&stretch(
            wheel_errors,
            per_period(revolutions * z1 / self.params.wheel_teeth as f64),
            w,
        ));
        let dk = kz.plus(&FourierSeries::constant(-self.k0));
        let mut forcing = dk.times(&e).scaled(-1.0).plus(&e.derivative().scaled(-self.c_z));
        forcing.omega_rad_s = w;
        if static_load {
            forcing.mean += self.k0 * self.params.static_deflection_m;
        }
        Some(FourierForm {
            dof: 1,
            period_s,
            mass: vec![FourierSeries::constant(self.m_red)],
            damping: vec![FourierSeries::constant(self.c_z)],
            stiffness: vec![kz],
            forcing: vec![forcing],
        })
    }
}

impl PeriodicSystem for GearPair {
    fn dim(&self) -> usize {
        2
    }
    fn period_s(&self) -> f64 {
        self.period_s
    }
    fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
        let kz = self.stiffness(t, side);
        let (e, ed) = self.error(t);
        let m = self.m_red;
        p[(0, 0)] = 0.0;
        p[(0, 1)] = 1.0;
        p[(1, 0)] = -kz / m;
        p[(1, 1)] = -self.c_z / m;
        f[0] = 0.0;
        f[1] = (self.k0 * self.params.static_deflection_m - (kz - self.k0) * e - self.c_z * ed) / m;
    }
    fn eval_matrix(&self, t: f64, side: Side, p: &mut DMatrix<f64>) {
        let m = self.m_red;
        p[(0, 0)] = 0.0;
        p[(0, 1)] = 1.0;
        p[(1, 0)] = -self.stiffness(t, side) / m;
        p[(1, 1)] = -self.c_z / m;
    }
    fn eval_matrix_uniform(&self, t0: f64, dt: f64, count: usize, out: &mut Vec<f64>) {
        // a Fourier mesh without a crack: the stiffness series sampled by turning phasors (the multiplier
        // companion of harmonic balance samples P at every node and midpoint of its Romberg table)
        let (MeshStiffness::Fourier(mesh), None) = (&self.params.mesh, &self.params.crack) else {
            let mut p = DMatrix::zeros(2, 2);
            for j in 0..count {
                self.eval_matrix(t0 + j as f64 * dt, Side::Right, &mut p);
                out.extend_from_slice(p.as_slice());
            }
            return;
        };
        let mut k = vec![0.0; count];
        mesh.sample_uniform(t0, dt, &mut k);
        let m = self.m_red;
        for kz in k {
            out.extend_from_slice(&[0.0, -kz / m, 1.0, -self.c_z / m]);
        }
    }
    fn piecewise_constant(&self) -> bool {
        matches!(self.params.mesh, MeshStiffness::Piecewise(_))
            && self.params.pinion_errors.is_constant()
            && self.params.wheel_errors.is_constant()
    }
    fn eval_terms(&self) -> usize {
        let mesh = match &self.params.mesh {
            MeshStiffness::Fourier(s) => s.harmonics() + 1,
            MeshStiffness::Piecewise(p) => p.starts.len(),
        };
        mesh + self.params.pinion_errors.harmonics() + self.params.wheel_errors.harmonics() + 1
    }
    fn breakpoints(&self) -> Vec<f64> {
        self.breakpoints.clone()
    }
    fn fourier_form(&self) -> Option<FourierForm> {
        if self.params.crack.is_some() {
            return None;
        }
        let p = &self.params;
        self.fourier_form_with(self.revolutions_per_period(), &p.pinion_errors, &p.wheel_errors, true)
    }
    fn homogeneous_period_s(&self) -> f64 {
        // P(t) holds only k_z(t): one mesh cycle, or the cracked gear's revolution
        match &self.params.crack {
            None => self.mesh_period_s(),
            Some(c) if c.gear == Gear::Pinion => self.pinion_period_s(),
            Some(_) => 1.0 / self.wheel_hz(),
        }
    }
    fn max_harmonic(&self) -> usize {
        let revs = self.revolutions_per_period();
        let z1 = self.params.pinion_teeth as f64;
        let mesh_h = match &self.params.mesh {
            MeshStiffness::Fourier(s) => s.harmonics(),
            MeshStiffness::Piecewise(_) => 0,
        };
        let a = (mesh_h as f64 * revs * z1).round() as usize;
        let b = (self.params.pinion_errors.harmonics() as f64 * revs).round() as usize;
        let c =
            (self.params.wheel_errors.harmonics() as f64 * revs * z1 / self.params.wheel_teeth as f64).round() as usize;
        a.max(b).max(c) + a.min(b.max(c))
    }
}

/// A lower bound of the work of a time-stepped steady state of a gear pair and of its output's orders
/// (see [`GearPair::stepped_work`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepWork {
    /// Steps of the final grid, at least.
    pub steps: usize,
    /// Orders of the period integrated on every step (the output's highest order times the pinion
    /// revolutions per period).
    pub orders: usize,
    /// Floating-point operations of the step products (the tolerance loop's attempts).
    pub solve_flops: f64,
    /// Floating-point operations of the orders: 4 Gauss points per step, one complex multiply-add per order
    /// and state component (2).
    pub orders_flops: f64,
}

impl StepWork {
    /// Both parts, floating-point operations.
    pub fn total(&self) -> f64 {
        self.solve_flops + self.orders_flops
    }
}

impl GearPair {
    /// The work of time stepping this pair (no Fourier form: a crack, or a piecewise mesh stiffness) to
    /// `tolerance` with the orders up to `max_order` of the pinion computed on the solver's grid; `None`
    /// when harmonic balance applies (its work is the solver's estimate). Steps: the larger of the step
    /// solver's final grid at the least (8 per highest coefficient harmonic) and 400 per cycle of the mesh
    /// natural frequency over the period, scaled by (1e-7 / tolerance)^(1/4) as a fourth-order method's
    /// step count is: the bundled pinion-crack and rectangular-stiffness scenes (29 natural cycles per
    /// period, tolerance 1e-7) needed 7248 and 17080 steps, against 11600 estimated for each.
    pub fn stepped_work(&self, max_order: f64, tolerance: f64) -> Option<StepWork> {
        if self.params.crack.is_none() && matches!(self.params.mesh, MeshStiffness::Fourier(_)) {
            return None;
        }
        let grid = 2 * (4 * self.max_harmonic()).max(64).max(2 * (self.breakpoints.len() + 1));
        let cycles = self.natural_frequency_rad_s() / (2.0 * PI) * self.period_s;
        let scale = (1e-7 / tolerance.max(1e-15)).powf(0.25);
        let steps = ((grid as f64).max(400.0 * cycles) * scale).min(1e15) as usize;
        let orders = (max_order * self.revolutions_per_period()).max(1.0).floor() as usize;
        // 3 passes (coarse, fine, the trajectory), 4 stage evaluations each of the coefficient terms
        // (a sine and cosine, ~20 flops) and the 2 x 3 augmented block
        let per_step = 4.0 * (20.0 * self.eval_terms() as f64 + 24.0);
        Some(StepWork {
            steps,
            orders,
            solve_flops: 3.0 * steps as f64 * per_step,
            orders_flops: 4.0 * steps as f64 * orders as f64 * 2.0 * 8.0,
        })
    }
}

/// A local profile deviation on one tooth (pit, spall): a Gaussian bump of height `depth_m`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToothFault {
    /// Tooth number, 1-based (tooth 1 meshes first after the angle origin).
    pub tooth: usize,
    /// Height of the bump in m (positive = material missing, adds to e(t)).
    pub depth_m: f64,
    /// Width: 6 sigma = `width_teeth` pitches.
    pub width_teeth: f64,
}

/// Harmonics of the gear angle that [`gaussian_tooth_faults`] computes for its narrowest fault of
/// `width_teeth` pitches on a gear of `teeth` teeth: the bump's spectrum exp(-(k sigma)^2 / 2), sigma =
/// 2 pi width / (6 teeth) rad, falls below `keep` at k = sqrt(2 ln(1 / keep)) / sigma.
pub fn gaussian_harmonics(teeth: usize, width_teeth: f64, keep: f64) -> f64 {
    let sigma = 2.0 * PI * width_teeth / teeth as f64 / 6.0;
    (2.0 * (1.0 / keep).ln()).sqrt() / sigma
}

/// Local profile deviations on single teeth as a Fourier series in the gear angle (w = 1 rad per rad):
/// each a periodised Gaussian of height d centred on the tooth's mesh cycle, c = 2 pi (tooth - 1/2) / z,
/// with 6 sigma = `width_teeth` pitches, in closed form:
///
/// ```text
/// g(theta) = d sigma / sqrt(2 pi) [1 + 2 sum_k exp(-k^2 sigma^2 / 2) cos(k (theta - c))]
/// ```
/// Its spectrum decays like exp(-(k sigma)^2 / 2): the series keeps the k with that factor above `keep`
/// (then terms below `keep` of the largest can be dropped by the caller).
pub fn gaussian_tooth_faults(teeth: usize, faults: &[ToothFault], keep: f64) -> FourierSeries {
    // (d sigma / sqrt(2 pi), sigma, centre)
    let terms: Vec<(f64, f64, f64)> = faults
        .iter()
        .map(|f| {
            let centre = 2.0 * PI * (f.tooth as f64 - 0.5) / teeth as f64;
            let sigma = 2.0 * PI * f.width_teeth / teeth as f64 / 6.0;
            (f.depth_m * sigma / (2.0 * PI).sqrt(), sigma, centre)
        })
        .collect();
    let width_min = faults.iter().map(|f| f.width_teeth).fold(f64::INFINITY, f64::min);
    let h = gaussian_harmonics(teeth, width_min, keep).ceil() as usize;
    let mut series = FourierSeries::new(1.0, terms.iter().map(|t| t.0).sum(), vec![0.0; h], vec![0.0; h]);
    for (a, sigma, c) in &terms {
        for k in 1..=h {
            let amp = 2.0 * a * (-0.5 * (k as f64 * sigma).powi(2)).exp();
            series.cos[k - 1] += amp * (k as f64 * c).cos();
            series.sin[k - 1] += amp * (k as f64 * c).sin();
        }
    }
    series
}

/// Rectangular mesh stiffness of contact ratio `eps` in [1, 3) and single-pair stiffness `kp` (N/m) over one
/// mesh cycle of period 1: ceil(eps) pairs in contact for the first frac(eps) of the cycle, floor(eps)
/// pairs for the rest (a constant floor(eps) kp when eps is whole).
pub fn rectangular_stiffness(eps: f64, kp: f64) -> PiecewiseConstant {
    let (lo, frac) = (eps.floor(), eps - eps.floor());
    if frac == 0.0 {
        PiecewiseConstant { period_s: 1.0, starts: vec![0.0], values: vec![lo * kp] }
    } else {
        PiecewiseConstant { period_s: 1.0, starts: vec![0.0, frac], values: vec![(lo + 1.0) * kp, lo * kp] }
    }
}

/// Series in an angle that turns `cycles` times per period, re-expressed in the period's base frequency.
fn stretch(s: &FourierSeries, cycles: usize, w: f64) -> FourierSeries {
    let h = s.harmonics() * cycles;
    let (mut c, mut sn) = (vec![0.0; h], vec![0.0; h]);
    if cycles > 0 {
        for k in 1..=s.harmonics() {
            c[k * cycles - 1] = s.cos[k - 1];
            sn[k * cycles - 1] = s.sin[k - 1];
        }
    }
    FourierSeries { omega_rad_s: w, mean: s.mean, cos: c, sin: sn }
}
