//! An independent gearbox recording generator for tests: a physics gearvib's engine does not simulate.
//!
//! Nothing here calls gearvib library code. The model is a lumped multi-DOF gear train in the time domain:
//! - every shaft has a torsional DOF (deviation from its nominal angle), every mesh a translational bearing DOF on
//!   each side along the line of action; the input shaft is tied to a speed-controlled motor by a torsional
//!   coupling, the output shaft carries a fluctuating load torque;
//! - the mesh force is summed over the tooth pairs in contact at that instant (contact ratio 1.4-1.8 from the
//!   angle), each pair with its own stiffness along the path of contact, its own profile errors, tip relief, and
//!   loss of contact when its deflection goes negative;
//! - the nominal input angle is integrated from a fluctuating speed (0.5-2 %, plus a 100 ppm drift over the
//!   recording); the load torque fluctuates by 3-8 %;
//! - fixed-step RK4 at 2-4x the output rate (at least 60 kHz), then a windowed-sinc low-pass and decimation;
//!   contact entry and loss are kinks the fixed step does not locate, so the signal is converged to a few % of
//!   its RMS only (the `convergence` report in tests/unseen_machines.rs);
//! - the bearing forces reach the accelerometer through three housing resonances (2.2, 3.7, 6.1 kHz at 20 kHz,
//!   scaled with the sample rate; 2-5 % damping; bilinear second-order sections);
//!   measurement noise at 0.35-0.7 of the signal RMS, random shocks, a fan tone (blades x input shaft), mains hum;
//! - an optional once-per-revolution tachometer (high for the first 5 % of each true input-shaft revolution).
//!
//! Tooth numbering follows the convention of gearvib's scenes: tooth n (1-based) of a gear is centred on the
//! angle (n - 1/2) / z of a revolution after that gear's angle origin; all angles start at 0 together, the
//! tachometer's rising edge is the input shaft's angle 0.
//!
//! Also: a two-stage parallel box ([`two_stage`]) and a planetary stage ([`planetary`]) for issue 30.
#![allow(dead_code)]

use std::f64::consts::PI;
use std::path::Path;

/// Bumped whenever the generated samples change (cache keys include it).
pub const GENERATOR_VERSION: u32 = 3;

// ---------------------------------------------------------------------------------------------------------
// random numbers

/// splitmix64: small, seeded, reproducible on every platform.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
}

// ---------------------------------------------------------------------------------------------------------
// faults and teeth

/// Which gear of a pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gear {
    Pinion,
    Wheel,
}

impl Gear {
    pub fn name(self) -> &'static str {
        match self {
            Gear::Pinion => "pinion",
            Gear::Wheel => "wheel",
        }
    }
}

/// A fault seeded on one gear.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// Root crack: that tooth's mesh stiffness reduced by this fraction (0.10, 0.25, 0.50).
    Crack(f64),
    /// Spall: 20 um of profile removed over 25 % of one tooth's path of contact (tapered edges).
    Spall,
    /// Broken tooth: 85 % of one tooth's stiffness gone.
    Broken,
    /// Wear: a distributed profile error (deepest at the tip and root, 6 um times 0.6-1.4 per tooth) on all teeth.
    Wear,
    /// Eccentricity: 50 um runout (a healthy gear runs out by 1-2 um): a once-per-revolution transmission error
    /// and a once-per-revolution change of the centre distance, hence of the contact ratio.
    Eccentricity,
}

impl FaultKind {
    /// A local fault has a tooth.
    pub fn is_local(self) -> bool {
        matches!(self, FaultKind::Crack(_) | FaultKind::Spall | FaultKind::Broken)
    }
    pub fn label(self) -> String {
        match self {
            FaultKind::Crack(f) => format!("crack{:.0}", f * 100.0),
            FaultKind::Spall => "spall".into(),
            FaultKind::Broken => "broken".into(),
            FaultKind::Wear => "wear".into(),
            FaultKind::Eccentricity => "eccentricity".into(),
        }
    }
    /// The seven faults of the test set.
    pub fn all() -> [FaultKind; 7] {
        [
            FaultKind::Crack(0.10),
            FaultKind::Crack(0.25),
            FaultKind::Crack(0.50),
            FaultKind::Spall,
            FaultKind::Broken,
            FaultKind::Wear,
            FaultKind::Eccentricity,
        ]
    }
}

/// A fault: its kind, the gear that carries it, and the tooth (1-based; for wear and eccentricity unused).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    pub kind: FaultKind,
    pub gear: Gear,
    pub tooth: usize,
}

/// One tooth's deviations: profile error (m) as offset + slope (s - 1/2) + wear (2 s - 1)^2 + spall(s) along the
/// path of contact s in [0, 1), and its stiffness factor.
#[derive(Clone, Debug)]
struct Tooth {
    offset: f64,
    slope: f64,
    wear: f64,
    spall: Option<(f64, f64, f64)>, // start, width (fractions of the path), depth m
    stiffness: f64,
}

impl Tooth {
    fn error(&self, s: f64) -> f64 {
        let d = 2.0 * s - 1.0;
        let mut e = self.offset + self.slope * (s - 0.5) + self.wear * d * d;
        if let Some((s0, w, depth)) = self.spall {
            let x = (s - s0) / w;
            if (0.0..1.0).contains(&x) {
                // raised-cosine edges over 20 % of the width each side
                let edge = 0.2;
                let taper = if x < edge {
                    0.5 - 0.5 * (PI * x / edge).cos()
                } else if x > 1.0 - edge {
                    0.5 - 0.5 * (PI * (1.0 - x) / edge).cos()
                } else {
                    1.0
                };
                e += depth * taper;
            }
        }
        e
    }
}

/// A gear: its teeth and its runout (amplitude m, phase rad).
#[derive(Clone, Debug)]
struct GearBody {
    teeth: Vec<Tooth>,
    runout: (f64, f64),
}

impl GearBody {
    /// Manufacturing errors: 0.8 um offset and 1 um slope spread per tooth, 1-2 um runout.
    fn made(z: usize, rng: &mut Rng) -> Self {
        let teeth = (0..z)
            .map(|_| Tooth {
                offset: 0.8e-6 * rng.normal(),
                slope: 1.0e-6 * rng.normal(),
                wear: 0.0,
                spall: None,
                stiffness: 1.0,
            })
            .collect();
        GearBody { teeth, runout: (rng.range(1e-6, 2e-6), rng.range(0.0, 2.0 * PI)) }
    }

    fn apply(&mut self, kind: FaultKind, tooth: usize, rng: &mut Rng) {
        let z = self.teeth.len();
        let t = &mut self.teeth[(tooth + z - 1) % z];
        match kind {
            FaultKind::Crack(f) => t.stiffness *= 1.0 - f,
            FaultKind::Spall => t.spall = Some((0.30, 0.25, 20e-6)),
            FaultKind::Broken => t.stiffness *= 0.15,
            FaultKind::Wear => {
                for t in &mut self.teeth {
                    t.wear += 6e-6 * rng.range(0.6, 1.4);
                }
            }
            FaultKind::Eccentricity => self.runout.0 = 50e-6,
        }
    }
}

// ---------------------------------------------------------------------------------------------------------
// the mesh: per-tooth-pair contact

/// A mesh between a driving and a driven gear.
#[derive(Clone, Debug)]
struct Mesh {
    drv: GearBody,
    drn: GearBody,
    contact_ratio: f64,
    /// Peak single-pair stiffness, N/m.
    k_max: f64,
    /// Tip relief: depth m (the single-pair deflection under the mean load, so a pair takes its load
    /// gradually) and length (fraction of the path: half the double-contact zone) at each end.
    relief: (f64, f64),
    /// Mesh damping N s/m.
    damping: f64,
    /// Change of the contact ratio per metre of centre-distance increase: -1 / (sin(alpha_w) p_b), alpha_w the
    /// working pressure angle and p_b the base pitch (the path of contact shortens by da / sin(alpha_w)).
    contact_per_m: f64,
    rb_drv: f64,
    rb_drn: f64,
}

impl Mesh {
    /// Single-pair stiffness along the path of contact (stiffest in the middle).
    fn pair_stiffness(&self, s: f64) -> f64 {
        self.k_max * (0.7 + 1.2 * s * (1.0 - s))
    }

    fn relief(&self, s: f64) -> f64 {
        let (depth, len) = self.relief;
        let a = ((len - s) / len).max(0.0);
        let b = ((s - (1.0 - len)) / len).max(0.0);
        depth * (a * a + b * b)
    }

    /// The tooth pairs in contact at mesh position `u` (driving-gear mesh cycles since its angle 0) for contact
    /// ratio `eps`: pair j
    /// (driving tooth j mod z1, driven tooth j mod z2) is in contact for u in [j + (1-eps)/2, j + (1+eps)/2).
    /// Calls `f(j, s)` with s in [0, 1) the position along the path.
    fn pairs(&self, u: f64, eps: f64, mut f: impl FnMut(i64, f64)) {
        let lo = floor_i64(u - 0.5 * (1.0 + eps));
        let hi = floor_i64(u - 0.5 * (1.0 - eps));
        for j in lo..=hi {
            let s = (u - j as f64 - 0.5 * (1.0 - eps)) / eps;
            if (0.0..1.0).contains(&s) {
                f(j, s);
            }
        }
    }

    /// Runout of both gears at nominal angles `a_drv`, `a_drn` (rad): the transmission error along the line of
    /// action (m) and the contact ratio of the moment (the eccentric centre moves along the line of centres).
    fn runout(&self, a_drv: f64, a_drn: f64) -> (f64, f64) {
        let (e1, p1) = self.drv.runout;
        let (e2, p2) = self.drn.runout;
        let te = e1 * (a_drv + p1).cos() + e2 * (a_drn + p2).cos();
        // the runout's component along the line of centres, 70 deg (90 - pressure angle) from the line of action
        let da = e1 * (a_drv + p1 + 70f64.to_radians()).cos() + e2 * (a_drn + p2 + 70f64.to_radians()).cos();
        (te, self.contact_ratio + self.contact_per_m * da)
    }

    /// Mesh force (N) for compression `delta` (m) and its rate at driving-gear absolute angle `a_drv` (rad), with
    /// the gears' runout `(error m, contact ratio)` of the moment.
    fn force(&self, a_drv: f64, runout: (f64, f64), delta: f64, rate: f64) -> f64 {
        let u = a_drv * self.drv.teeth.len() as f64 / (2.0 * PI);
        self.force_at(u, runout, delta, rate)
    }

    /// Mesh force (N) at mesh position `u` (mesh cycles); see [`Mesh::force`].
    fn force_at(&self, u: f64, runout: (f64, f64), delta: f64, rate: f64) -> f64 {
        let (runout, eps) = runout;
        let (z1, z2) = (self.drv.teeth.len(), self.drn.teeth.len());
        // the tooth indices of the first pair that may touch, then counted on (one division each per call, not
        // per pair: the generator spends most of its time here)
        let first = floor_i64(u - 0.5 * (1.0 + eps));
        let (mut i1, mut i2) = (first.rem_euclid(z1 as i64) as usize, first.rem_euclid(z2 as i64) as usize);
        let mut next = first;
        let mut force = 0.0;
        let mut touching = false;
        self.pairs(u, eps, |j, s| {
            while next < j {
                i1 = if i1 + 1 == z1 { 0 } else { i1 + 1 };
                i2 = if i2 + 1 == z2 { 0 } else { i2 + 1 };
                next += 1;
            }
            let t1 = &self.drv.teeth[i1];
            let t2 = &self.drn.teeth[i2];
            let k = self.pair_stiffness(s) * t1.stiffness * t2.stiffness;
            let e = t1.error(s) + t2.error(s) + self.relief(s) + runout;
            let d = delta - e;
            if d > 0.0 {
                force += k * d;
                touching = true;
            }
        });
        if touching { force + self.damping * rate } else { 0.0 }
    }

    /// Mean mesh stiffness over a mesh cycle (N/m), healthy profile, all pairs loaded.
    fn mean_stiffness(&self) -> f64 {
        let n = 1000;
        let mut sum = 0.0;
        for i in 0..n {
            self.pairs(i as f64 / n as f64, self.contact_ratio, |_, s| sum += self.pair_stiffness(s));
        }
        sum / n as f64
    }
}

/// `x.floor() as i64` without the library call (the tests are built for the baseline x86-64, which has no
/// rounding instruction): the same integer for every finite `x` within the range of i64.
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t - 1 } else { t }
}

/// Number of tooth pairs in contact at mesh position `u` for contact ratio `eps` (for the tests' invariants).
pub fn pairs_in_contact(eps: f64, u: f64) -> usize {
    let m = Mesh {
        drv: GearBody { teeth: vec![], runout: (0.0, 0.0) },
        drn: GearBody { teeth: vec![], runout: (0.0, 0.0) },
        contact_ratio: eps,
        k_max: 1.0,
        relief: (0.0, 0.1),
        damping: 0.0,
        contact_per_m: 0.0,
        rb_drv: 1.0,
        rb_drn: 1.0,
    };
    let mut n = 0;
    m.pairs(u, eps, |_, _| n += 1);
    n
}

// ---------------------------------------------------------------------------------------------------------
// operating point: speed and load

/// Fluctuating input speed and load torque, as sums of slow sinusoids (closed-form angle).
#[derive(Clone, Debug)]
struct Operating {
    omega0: f64,
    /// relative speed drift per second
    drift: f64,
    /// (relative amplitude, frequency Hz, phase) of the speed fluctuation
    speed: Vec<(f64, f64, f64)>,
    torque0: f64,
    load: Vec<(f64, f64, f64)>,
}

impl Operating {
    fn new(shaft_hz: f64, duration: f64, torque0: f64, rng: &mut Rng) -> Self {
        let speed_level = rng.range(0.005, 0.02);
        let load_level = rng.range(0.03, 0.08);
        let parts = |level: f64, lo: f64, hi: f64, rng: &mut Rng| -> Vec<(f64, f64, f64)> {
            let w: Vec<f64> = (0..3).map(|_| rng.range(0.2, 1.0)).collect();
            let total: f64 = w.iter().sum();
            w.iter().map(|wi| (level * wi / total, rng.range(lo, hi), rng.range(0.0, 2.0 * PI))).collect()
        };
        let speed = parts(speed_level, 0.1, 1.5, rng);
        let load = parts(load_level, 0.3, 8.0, rng);
        let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        Operating { omega0: 2.0 * PI * shaft_hz, drift: sign * 1e-4 / duration, speed, torque0, load }
    }

    /// Nominal input angle (rad), zero at t = 0.
    fn angle(&self, t: f64) -> f64 {
        let mut a = t + 0.5 * self.drift * t * t;
        for &(amp, f, p) in &self.speed {
            let w = 2.0 * PI * f;
            a += amp / w * (p.cos() - (w * t + p).cos());
        }
        self.omega0 * a
    }

    /// Nominal input angular acceleration (rad/s^2).
    fn acceleration(&self, t: f64) -> f64 {
        let mut a = self.drift;
        for &(amp, f, p) in &self.speed {
            let w = 2.0 * PI * f;
            a += amp * w * (w * t + p).cos();
        }
        self.omega0 * a
    }

    fn torque(&self, t: f64) -> f64 {
        let mut l = 1.0;
        for &(amp, f, p) in &self.load {
            l += amp * (2.0 * PI * f * t + p).sin();
        }
        self.torque0 * l
    }
}

// ---------------------------------------------------------------------------------------------------------
// the train: shafts in series, one mesh between consecutive shafts

/// cos and sin of w t + p for every slow sinusoid of an [`Operating`] (speed ones first, then load ones),
/// advanced by a fixed time step by rotation and re-computed exactly every 4096 steps.
struct Clock {
    params: Vec<(f64, f64)>,
    rot: Vec<(f64, f64)>,
    z: Vec<(f64, f64)>,
    t: f64,
    dt: f64,
    count: usize,
}

impl Clock {
    fn new(op: &Operating, t: f64, dt: f64) -> Self {
        let params: Vec<(f64, f64)> = op.speed.iter().chain(&op.load).map(|&(_, f, p)| (2.0 * PI * f, p)).collect();
        let rot = params.iter().map(|(w, _)| ((w * dt).cos(), (w * dt).sin())).collect();
        let mut c = Clock { params, rot, z: vec![], t, dt, count: 0 };
        c.exact();
        c
    }
    fn exact(&mut self) {
        self.z = self.params.iter().map(|(w, p)| ((w * self.t + p).cos(), (w * self.t + p).sin())).collect();
    }
    fn advance(&mut self) {
        self.count += 1;
        self.t += self.dt;
        if self.count.is_multiple_of(4096) {
            self.exact();
            return;
        }
        for (z, r) in self.z.iter_mut().zip(&self.rot) {
            *z = (z.0 * r.0 - z.1 * r.1, z.0 * r.1 + z.1 * r.0);
        }
    }
}

/// The drive at one instant (see [`Train::drive`]); at most four meshes.
struct Drive {
    angle: f64,
    acc: f64,
    torque: f64,
    runout: [(f64, f64); 4],
}

/// A serial gear train: shaft i drives shaft i+1 through mesh i.
struct Train {
    inertia: Vec<f64>,
    /// nominal angle of shaft i per radian of the input shaft
    ratio: Vec<f64>,
    meshes: Vec<Mesh>,
    coupling: (f64, f64),     // motor coupling stiffness N m/rad, damping N m s/rad
    bearing: (f64, f64, f64), // stiffness N/m, damping N s/m, mass kg
    op: Operating,
}

impl Train {
    fn shafts(&self) -> usize {
        self.inertia.len()
    }
    fn dofs(&self) -> usize {
        self.shafts() + 2 * self.meshes.len()
    }

    /// Compression (m) and its rate of mesh m from the state.
    fn compression(&self, m: usize, y: &[f64]) -> (f64, f64) {
        let n = self.dofs();
        let s = self.shafts();
        let (xa, xb) = (s + 2 * m, s + 2 * m + 1);
        let me = &self.meshes[m];
        let d = me.rb_drv * y[m] + y[xa] - me.rb_drn * y[m + 1] - y[xb];
        let r = me.rb_drv * y[n + m] + y[n + xa] - me.rb_drn * y[n + m + 1] - y[n + xb];
        (d, r)
    }

    /// What the drive imposes at time t: nominal input angle, its acceleration, the load torque, and each
    /// mesh's runout error (evaluated once per instant, shared by the RK4 stages). The slow sinusoids come from
    /// `clock` (phasors advanced in step with t: the same values as [`Operating`]'s closed forms).
    fn drive(&self, t: f64, clock: &Clock) -> Drive {
        let op = &self.op;
        let (mut angle, mut acc, mut load) = (t + 0.5 * op.drift * t * t, op.drift, 1.0);
        for (k, &(amp, f, p)) in op.speed.iter().enumerate() {
            let w = 2.0 * PI * f;
            angle += amp / w * (p.cos() - clock.z[k].0);
            acc += amp * w * clock.z[k].0;
        }
        for (k, &(amp, _, _)) in op.load.iter().enumerate() {
            load += amp * clock.z[op.speed.len() + k].1;
        }
        let angle = op.omega0 * angle;
        let mut runout = [(0.0, 0.0); 4];
        for (m, me) in self.meshes.iter().enumerate() {
            runout[m] = me.runout(angle * self.ratio[m], angle * self.ratio[m + 1]);
        }
        Drive { angle, acc: op.omega0 * acc, torque: op.torque0 * load, runout }
    }

    fn mesh_forces(&self, d: &Drive, y: &[f64], out: &mut [f64]) {
        for m in 0..self.meshes.len() {
            let (c, r) = self.compression(m, y);
            let a1 = d.angle * self.ratio[m] + y[m];
            out[m] = self.meshes[m].force(a1, d.runout[m], c, r);
        }
    }

    /// State derivative; y = [positions; velocities].
    fn deriv(&self, d: &Drive, y: &[f64], dy: &mut [f64], forces: &mut [f64]) {
        let n = self.dofs();
        let s = self.shafts();
        dy[..n].copy_from_slice(&y[n..]);
        self.mesh_forces(d, y, forces);
        let acc = d.acc;
        for i in 0..s {
            let mut torque = -self.inertia[i] * acc * self.ratio[i];
            if i == 0 {
                torque -= self.coupling.0 * y[0] + self.coupling.1 * y[n];
            }
            if i == s - 1 {
                torque -= d.torque;
            }
            if i < self.meshes.len() {
                torque -= self.meshes[i].rb_drv * forces[i];
            }
            if i > 0 {
                torque += self.meshes[i - 1].rb_drn * forces[i - 1];
            }
            dy[n + i] = torque / self.inertia[i];
        }
        let (kb, cb, mb) = self.bearing;
        for m in 0..self.meshes.len() {
            for (side, sign) in [(0, -1.0), (1, 1.0)] {
                let k = s + 2 * m + side;
                dy[n + k] = (sign * forces[m] - kb * y[k] - cb * y[n + k]) / mb;
            }
        }
    }

    /// Static equilibrium under the mean load (start of the integration).
    fn equilibrium(&self) -> Vec<f64> {
        let n = self.dofs();
        let s = self.shafts();
        let mut y = vec![0.0; 2 * n];
        let mut f = vec![0.0; self.meshes.len()];
        let mut torque = self.op.torque0;
        for m in (0..self.meshes.len()).rev() {
            f[m] = torque / self.meshes[m].rb_drn;
            torque = f[m] * self.meshes[m].rb_drv;
        }
        let kb = self.bearing.0;
        y[0] = -torque / self.coupling.0;
        for m in 0..self.meshes.len() {
            let me = &self.meshes[m];
            y[s + 2 * m] = -f[m] / kb;
            y[s + 2 * m + 1] = f[m] / kb;
            let delta = f[m] / me.mean_stiffness();
            y[m + 1] = (me.rb_drv * y[m] + y[s + 2 * m] - y[s + 2 * m + 1] - delta) / me.rb_drn;
        }
        y
    }
}

// ---------------------------------------------------------------------------------------------------------
// housing, decimation, extras

/// A bilinear second-order section for the acceleration response of one housing mode to a force:
/// H(s) = g s^2 / (s^2 + 2 zeta w s + w^2), pre-warped at w.
struct Mode {
    b: [f64; 3],
    a: [f64; 2],
    z: [f64; 2],
}

impl Mode {
    fn new(freq: f64, zeta: f64, gain: f64, rate: f64) -> Self {
        let w = 2.0 * PI * freq;
        let c = w / (PI * freq / rate).tan(); // pre-warp
        let a0 = c * c + 2.0 * zeta * w * c + w * w;
        let b = [gain * c * c / a0, -2.0 * gain * c * c / a0, gain * c * c / a0];
        let a = [(2.0 * w * w - 2.0 * c * c) / a0, (c * c - 2.0 * zeta * w * c + w * w) / a0];
        Mode { b, a, z: [0.0; 2] }
    }
    /// Transposed direct form II.
    fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.z[0];
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
        self.z[1] = self.b[2] * x - self.a[1] * y;
        y
    }
}

/// Windowed-sinc (Blackman) low-pass at 0.42 of the output rate, `64 r + 1` taps, unit DC gain.
fn decimation_filter(r: usize) -> Vec<f64> {
    let len = 64 * r + 1;
    let mid = (len / 2) as f64;
    let fc = 0.42 / r as f64; // cycles per internal sample
    let mut h: Vec<f64> = (0..len)
        .map(|k| {
            let x = k as f64 - mid;
            let sinc = if x == 0.0 { 2.0 * fc } else { (2.0 * PI * fc * x).sin() / (PI * x) };
            let w = 0.42 - 0.5 * (2.0 * PI * k as f64 / (len - 1) as f64).cos()
                + 0.08 * (4.0 * PI * k as f64 / (len - 1) as f64).cos();
            sinc * w
        })
        .collect();
    let sum: f64 = h.iter().sum();
    h.iter_mut().for_each(|v| *v /= sum);
    h
}

/// What surrounds the gear signal in a recording.
#[derive(Clone, Debug)]
pub struct Environment {
    /// measurement noise RMS relative to the gear signal's RMS
    pub noise: f64,
    /// shocks per second
    pub shock_rate: f64,
    /// fan blades (tone at blades x input shaft)
    pub fan_blades: usize,
    /// mains frequency Hz
    pub mains_hz: f64,
}

impl Environment {
    /// The surroundings: noise 0.35-0.7 of the RMS, 0.3 shocks/s, fan, 50 Hz hum.
    pub fn plant(blades: usize, rng: &mut Rng) -> Self {
        Environment { noise: rng.range(0.35, 0.7), shock_rate: 0.3, fan_blades: blades, mains_hz: 50.0 }
    }
    /// Nothing but the gears (for the generator's own invariants).
    pub fn quiet() -> Self {
        Environment { noise: 0.0, shock_rate: 0.0, fan_blades: 0, mains_hz: 0.0 }
    }
}

/// A generated recording: accelerometer (m/s^2) and tachometer channel, and its truth.
pub struct Recording {
    pub fs: f64,
    pub accel: Vec<f64>,
    pub tacho: Vec<f64>,
    /// Mean mesh force of each mesh over the recording (N) and its static value from the mean load.
    pub mean_force: Vec<(f64, f64)>,
    /// Signal RMS before noise, shocks and tones.
    pub gear_rms: f64,
    /// True angle (rad) at each sample of the tachometer's shaft: the input shaft, the carrier for a planetary
    /// stage.
    pub angle: Vec<f64>,
}

/// Housing modes: (frequency Hz, damping ratio, gain per bearing force for each bearing), drawn for a machine.
fn housing(fs: f64, bearings: usize, rng: &mut Rng) -> Vec<(f64, f64, Vec<f64>)> {
    [2200.0, 3700.0, 6100.0]
        .iter()
        .map(|f| {
            let freq = f * fs / 20_000.0;
            let zeta = rng.range(0.02, 0.05);
            // modal mass about 20 kg: gain 1/20 m/s^2 per N, times a path factor
            let gains = (0..bearings).map(|_| rng.range(0.3, 1.0) / 20.0).collect();
            (freq, zeta, gains)
        })
        .collect()
}

/// Integrates the train, passes the bearing forces through the housing and decimates.
/// Returns (accel at fs, input-shaft true angle at fs, mean mesh forces).
fn run_train(
    train: &Train,
    modes: &[(f64, f64, Vec<f64>)],
    fs: f64,
    r: usize,
    samples: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let rate = fs * r as f64;
    let h = 1.0 / rate;
    let fir = decimation_filter(r);
    let half = fir.len() / 2;
    let warm = ((0.3 * rate) as usize).div_ceil(r) * r;
    let total = warm + samples * r + half + 1;
    let n2 = 2 * train.dofs();
    let nb = 2 * train.meshes.len();
    let s = train.shafts();
    let mut sections: Vec<(Mode, &Vec<f64>)> =
        modes.iter().map(|(f, z, g)| (Mode::new(*f, *z, 1.0, rate), g)).collect();
    let mut y = train.equilibrium();
    let (mut k1, mut k2, mut k3, mut k4, mut tmp) =
        (vec![0.0; n2], vec![0.0; n2], vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]);
    let mut forces = vec![0.0; train.meshes.len()];
    let mut sensor = vec![0.0; total];
    let mut angle = vec![0.0; samples];
    let mut force_sum = vec![0.0; train.meshes.len()];
    let (kb, cb, _) = train.bearing;
    let t0 = -(warm as f64) * h;
    let mut clock = Clock::new(&train.op, t0, 0.5 * h);
    let mut now = train.drive(t0, &clock);
    for i in 0..total {
        let t = t0 + i as f64 * h;
        clock.advance();
        let mid = train.drive(t + 0.5 * h, &clock);
        clock.advance();
        let next = train.drive(t + h, &clock);
        // output of this instant
        let mut bf = [0.0; 8];
        for b in 0..nb {
            bf[b] = kb * y[s + b] + cb * y[n2 / 2 + s + b];
        }
        let mut a = 0.0;
        for (sec, gains) in sections.iter_mut() {
            let input: f64 = gains.iter().zip(&bf).map(|(g, f)| g * f).sum();
            a += sec.step(input);
        }
        sensor[i] = a;
        if i >= warm && (i - warm).is_multiple_of(r) && (i - warm) / r < samples {
            angle[(i - warm) / r] = now.angle + y[0];
            train.mesh_forces(&now, &y, &mut forces);
            for (acc, f) in force_sum.iter_mut().zip(&forces) {
                *acc += f;
            }
        }
        // RK4 step
        train.deriv(&now, &y, &mut k1, &mut forces);
        for j in 0..n2 {
            tmp[j] = y[j] + 0.5 * h * k1[j];
        }
        train.deriv(&mid, &tmp, &mut k2, &mut forces);
        for j in 0..n2 {
            tmp[j] = y[j] + 0.5 * h * k2[j];
        }
        train.deriv(&mid, &tmp, &mut k3, &mut forces);
        for j in 0..n2 {
            tmp[j] = y[j] + h * k3[j];
        }
        train.deriv(&next, &tmp, &mut k4, &mut forces);
        for j in 0..n2 {
            y[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
        now = next;
    }
    let out: Vec<f64> = (0..samples)
        .map(|k| {
            let c = warm + k * r;
            fir.iter().enumerate().map(|(j, w)| w * sensor[c + j - half]).sum()
        })
        .collect();
    let means = force_sum.iter().map(|f| f / samples as f64).collect();
    (out, angle, means)
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Adds noise, shocks, the fan tone and mains hum (levels relative to the gear signal's RMS).
fn surround(x: &mut [f64], angle: &[f64], fs: f64, env: &Environment, modes: &[f64], rng: &mut Rng) {
    let level = rms(x);
    let n = x.len();
    // shocks: decaying oscillations at a housing mode, 2-5x the RMS, Poisson arrivals
    if env.shock_rate > 0.0 {
        let mut t = 0.0;
        loop {
            t += -rng.uniform().max(1e-12).ln() / env.shock_rate;
            let start = (t * fs) as usize;
            if start >= n {
                break;
            }
            let f = modes[(rng.next_u64() % modes.len() as u64) as usize];
            let amp = level * rng.range(2.0, 5.0);
            let decay = 0.03 * 2.0 * PI * f;
            let phase = rng.range(0.0, 2.0 * PI);
            let len = ((6.0 / decay) * fs) as usize;
            for k in 0..len.min(n - start) {
                let tk = k as f64 / fs;
                x[start + k] += amp * (-decay * tk).exp() * (2.0 * PI * f * tk + phase).sin();
            }
        }
    }
    let fan_phase = rng.range(0.0, 2.0 * PI);
    let hum: Vec<(f64, f64)> = (0..3).map(|_| (rng.range(0.0, 2.0 * PI), rng.range(0.5, 1.0))).collect();
    for (k, v) in x.iter_mut().enumerate() {
        let t = k as f64 / fs;
        if env.fan_blades > 0 {
            let b = env.fan_blades as f64 * angle[k] + fan_phase;
            *v += level * (0.15 * b.sin() + 0.05 * (2.0 * b).sin());
        }
        if env.mains_hz > 0.0 {
            for (h, (p, a)) in hum.iter().enumerate() {
                *v += level * 0.1 * a / (h + 1) as f64 * (2.0 * PI * env.mains_hz * (h + 1) as f64 * t + p).sin();
            }
        }
        if env.noise > 0.0 {
            *v += level * env.noise * rng.normal();
        }
    }
}

/// Once-per-revolution tachometer from the true angle: 1 for the first 5 % of each revolution, else 0.
fn tacho(angle: &[f64]) -> Vec<f64> {
    angle.iter().map(|a| if (a / (2.0 * PI)).rem_euclid(1.0) < 0.05 { 1.0 } else { 0.0 }).collect()
}

// ---------------------------------------------------------------------------------------------------------
// the single pair

/// A machine: one gear pair, its speed, its sample rate, its gears' manufacturing seed.
#[derive(Clone, Debug)]
pub struct Machine {
    pub name: &'static str,
    pub zp: usize,
    pub zw: usize,
    pub shaft_hz: f64,
    pub fs: f64,
    pub duration_s: f64,
    pub contact_ratio: f64,
    pub fan_blades: usize,
    /// seeds the gears' manufacturing errors and the housing: the same for every recording of the machine
    pub seed: u64,
}

impl Machine {
    pub fn rpm(&self) -> f64 {
        self.shaft_hz * 60.0
    }
    /// Oversampling factor of the integration (internal rate at least 60 kHz: the stiffest mode, about 5 kHz, then has omega h below 0.55).
    fn oversampling(&self) -> usize {
        ((60_000.0 / self.fs).ceil() as usize).max(2)
    }
}

/// The machines of the unseen-machine test set (none is 14/39).
pub fn machines() -> Vec<Machine> {
    vec![
        Machine {
            name: "z17z29-25Hz-fs20k",
            zp: 17,
            zw: 29,
            shaft_hz: 25.0,
            fs: 20_000.0,
            duration_s: 10.0,
            contact_ratio: 1.55,
            fan_blades: 7,
            seed: 1729,
        },
        Machine {
            name: "z23z41-18Hz-fs25k6",
            zp: 23,
            zw: 41,
            shaft_hz: 18.0,
            fs: 25_600.0,
            duration_s: 10.0,
            contact_ratio: 1.65,
            fan_blades: 9,
            seed: 2341,
        },
        Machine {
            name: "z31z47-12Hz-fs51k2",
            zp: 31,
            zw: 47,
            shaft_hz: 12.0,
            fs: 51_200.0,
            duration_s: 10.0,
            contact_ratio: 1.75,
            fan_blades: 11,
            seed: 3147,
        },
        Machine {
            // exactly 1024 samples per nominal revolution
            name: "z19z37-25Hz-fs25k6",
            zp: 19,
            zw: 37,
            shaft_hz: 25.0,
            fs: 25_600.0,
            duration_s: 8.0,
            contact_ratio: 1.45,
            fan_blades: 8,
            seed: 1937,
        },
    ]
}

/// Three more machines, kept out of every test and every threshold: the scorecard reads them with
/// `GEARVIB_MORE_MACHINES=1` to see how the diagnosis does on pairs, speeds and sample rates it was not
/// tuned on (40 Hz, 44.1 kHz, 32 kHz; contact ratios 1.4-1.7).
pub fn more_machines() -> Vec<Machine> {
    vec![
        Machine {
            name: "z21z37-40Hz-fs51k2",
            zp: 21,
            zw: 37,
            shaft_hz: 40.0,
            fs: 51_200.0,
            duration_s: 8.0,
            contact_ratio: 1.6,
            fan_blades: 6,
            seed: 2137,
        },
        Machine {
            name: "z27z43-30Hz-fs32k",
            zp: 27,
            zw: 43,
            shaft_hz: 30.0,
            fs: 32_000.0,
            duration_s: 8.0,
            contact_ratio: 1.7,
            fan_blades: 5,
            seed: 2743,
        },
        Machine {
            name: "z18z31-15Hz-fs44k1",
            zp: 18,
            zw: 31,
            shaft_hz: 15.0,
            fs: 44_100.0,
            duration_s: 12.0,
            contact_ratio: 1.4,
            fan_blades: 9,
            seed: 1831,
        },
    ]
}

/// Contact-ratio change per metre of centre-distance increase for base radius `rb` and `z` teeth (20 deg).
fn contact_change(rb: f64, z: usize) -> f64 {
    let pb = 2.0 * PI * rb / z as f64;
    -1.0 / (20f64.to_radians().sin() * pb)
}

/// Module 3 mm, 20 deg pressure angle, 20 mm face width, steel discs plus 3e-4 kg m^2 of shaft and hub.
fn gear_geometry(z: usize) -> (f64, f64) {
    let module = 3e-3;
    let r = module * z as f64 / 2.0;
    let rb = r * (20f64.to_radians()).cos();
    let inertia = 7850.0 * 0.02 * PI * r.powi(4) / 2.0 + 3e-4;
    (rb, inertia)
}

fn pair_train(m: &Machine, fault: Option<Fault>, op_rng: &mut Rng, duration: f64) -> Train {
    let f = fault.map(|f| (0, f));
    serial_train(&[(m.zp, m.zw, m.contact_ratio)], f, m.seed, m.shaft_hz, duration, op_rng)
}

/// A serial train of stages `(driving teeth, driven teeth, contact ratio)`, stage i from shaft i to shaft i+1,
/// 5000 N of mesh force (250 N/mm) in the last stage under the mean load; `fault` on (stage, gear of that stage).
fn serial_train(
    stages: &[(usize, usize, f64)],
    fault: Option<(usize, Fault)>,
    gear_seed: u64,
    shaft_hz: f64,
    duration: f64,
    op_rng: &mut Rng,
) -> Train {
    let mut gear_rng = Rng::new(gear_seed);
    let mut bodies: Vec<(GearBody, GearBody)> = stages
        .iter()
        .map(|&(z1, z2, _)| {
            let drv = GearBody::made(z1, &mut gear_rng);
            (drv, GearBody::made(z2, &mut gear_rng))
        })
        .collect();
    if let Some((stage, f)) = fault {
        let mut fr = Rng::new(gear_seed ^ 0xFA17);
        match f.gear {
            Gear::Pinion => bodies[stage].0.apply(f.kind, f.tooth, &mut fr),
            Gear::Wheel => bodies[stage].1.apply(f.kind, f.tooth, &mut fr),
        }
    }
    // shaft i carries the driven gear of stage i-1 and the driving gear of stage i
    let mut inertia = vec![0.0; stages.len() + 1];
    let mut ratio = vec![1.0; stages.len() + 1];
    for (i, &(z1, z2, _)) in stages.iter().enumerate() {
        inertia[i] += gear_geometry(z1).1;
        inertia[i + 1] += gear_geometry(z2).1;
        ratio[i + 1] = ratio[i] * z1 as f64 / z2 as f64;
    }
    let load_n = 5000.0; // 250 N/mm of face width, last stage
    let k_max = 2.8e8; // 1.4e10 N/m per m of face width
    let mut force = load_n;
    let mut meshes = vec![];
    for (i, (&(z1, z2, eps), (drv, drn))) in stages.iter().zip(bodies).enumerate().rev() {
        let (rb1, rb2) = (gear_geometry(z1).0, gear_geometry(z2).0);
        let single = force / k_max;
        let meq = 1.0 / (rb1 * rb1 / inertia[i] + rb2 * rb2 / inertia[i + 1]);
        let mut mesh = Mesh {
            drv,
            drn,
            contact_ratio: eps,
            k_max,
            relief: (single, 0.5 * (eps - 1.0) / eps),
            damping: 0.0,
            contact_per_m: contact_change(rb1, z1),
            rb_drv: rb1,
            rb_drn: rb2,
        };
        mesh.damping = 2.0 * 0.04 * (mesh.mean_stiffness() * meq).sqrt();
        meshes.push(mesh);
        if i > 0 {
            // the next stage up carries this stage's torque on the shared shaft
            force *= rb1 / gear_geometry(stages[i - 1].1).0;
        }
    }
    meshes.reverse();
    let j_motor: f64 = inertia.iter().zip(&ratio).map(|(j, r)| j * r * r).sum();
    let kc = (2.0 * PI * 120.0).powi(2) * j_motor;
    let (kb, mb) = (5e8, 4.0);
    let last = &meshes[meshes.len() - 1];
    let torque0 = load_n * last.rb_drn;
    Train {
        inertia,
        ratio,
        meshes,
        coupling: (kc, 2.0 * 0.05 * (kc * j_motor).sqrt()),
        bearing: (kb, 2.0 * 0.03 * (kb * mb).sqrt(), mb),
        op: Operating::new(shaft_hz, duration, torque0, op_rng),
    }
}

/// Generates one recording of machine `m` with an optional fault; `seed` drives everything that differs
/// between recordings (speed and load fluctuation, noise, shocks, tone phases). `env`: `None` for the plant's
/// surroundings drawn from the seed ([`Environment::plant`]), `Some(&Environment::quiet())` for the gears alone.
pub fn generate(m: &Machine, fault: Option<Fault>, seed: u64, env: Option<&Environment>, duration: f64) -> Recording {
    generate_oversampled(m, fault, seed, env, duration, m.oversampling())
}

/// [`generate`] integrating at `r` times the output rate (r >= 2) instead of the machine's default.
pub fn generate_oversampled(
    m: &Machine,
    fault: Option<Fault>,
    seed: u64,
    env: Option<&Environment>,
    duration: f64,
    r: usize,
) -> Recording {
    let mut rng = Rng::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ m.seed);
    let train = pair_train(m, fault, &mut rng, duration);
    finish_train(&train, m.fs, r, m.seed, m.fan_blades, env, duration, &mut rng)
}

/// [`generate`] with the input speed changing steadily by `change` (a fraction: -0.12 for a coast-down that
/// ends 12 % slower) over `duration`, on top of its fluctuation: the nominal angle's drift term is set so
/// that the speed at the end is (1 + `change`) times the speed at the start (d omega / dt = drift omega0).
pub fn generate_ramp(m: &Machine, fault: Option<Fault>, seed: u64, duration: f64, change: f64) -> Recording {
    let mut rng = Rng::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ m.seed);
    let mut train = pair_train(m, fault, &mut rng, duration);
    train.op.drift = change / duration;
    finish_train(&train, m.fs, m.oversampling(), m.seed, m.fan_blades, None, duration, &mut rng)
}

/// Writes a recording as a two-channel 32-bit float WAV (1: accelerometer m/s^2, 2: tachometer), atomically.
pub fn write_wav(path: &Path, rec: &Recording) {
    write_channels(path, rec.fs, &[&rec.accel, &rec.tacho]);
}

/// Writes channels as a 32-bit float WAV through a temporary file.
pub fn write_channels(path: &Path, fs: f64, channels: &[&[f64]]) {
    let spec = hound::WavSpec {
        channels: channels.len() as u16,
        sample_rate: fs.round() as u32,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    // a name of this writer's own: two tests may write the same recording at once (the later rename wins,
    // with the same content)
    static WRITERS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = WRITERS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = path.with_extension(format!("wav.{}-{n}.part", std::process::id()));
    {
        let mut w = hound::WavWriter::create(&tmp, spec).expect("create wav");
        for k in 0..channels[0].len() {
            for c in channels {
                w.write_sample(c[k] as f32).expect("write sample");
            }
        }
        w.finalize().expect("finalize wav");
    }
    std::fs::rename(&tmp, path).expect("rename wav");
}

// ---------------------------------------------------------------------------------------------------------
// naive spectral helpers for the generator's invariants (independent of gearvib's FFT)

/// |X(f)| of x at frequency f (Hz) by a direct sum with a Hann window, amplitude-corrected.
pub fn dft_amplitude(x: &[f64], fs: f64, f: f64) -> f64 {
    let n = x.len();
    let (mut re, mut im, mut wsum) = (0.0, 0.0, 0.0);
    let w = 2.0 * PI * f / fs;
    for (k, v) in x.iter().enumerate() {
        let win = 0.5 - 0.5 * (2.0 * PI * k as f64 / n as f64).cos();
        re += win * v * (w * k as f64).cos();
        im -= win * v * (w * k as f64).sin();
        wsum += win;
    }
    2.0 * (re * re + im * im).sqrt() / wsum
}

// ---------------------------------------------------------------------------------------------------------
// issue 30: a two-stage parallel box

/// A two-stage parallel box: input -> intermediate (teeth[0] / teeth[1]) -> output (teeth[2] / teeth[3]).
#[derive(Clone, Debug)]
pub struct TwoStage {
    pub teeth: [usize; 4],
    pub input_hz: f64,
    pub fs: f64,
    pub contact_ratio: [f64; 2],
    pub fan_blades: usize,
    pub seed: u64,
}

impl TwoStage {
    /// DESIGN.md's example box: 23/61 then 19/47 at 1480 rpm, recorded at 25.6 kHz.
    pub fn example() -> Self {
        TwoStage {
            teeth: [23, 61, 19, 47],
            input_hz: 1480.0 / 60.0,
            fs: 25_600.0,
            contact_ratio: [1.6, 1.5],
            fan_blades: 9,
            seed: 2361,
        }
    }
    /// Speed of the intermediate and output shafts per input revolution.
    pub fn ratios(&self) -> [f64; 3] {
        let r1 = self.teeth[0] as f64 / self.teeth[1] as f64;
        [1.0, r1, r1 * self.teeth[2] as f64 / self.teeth[3] as f64]
    }
}

/// A fault in a two-stage box: `stage` 0 or 1, `fault.gear` Pinion for that stage's driving gear, Wheel for its
/// driven one (the intermediate shaft carries stage 0's wheel and stage 1's pinion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StageFault {
    pub stage: usize,
    pub fault: Fault,
}

/// One recording of a two-stage box (accelerometer and input-shaft tachometer; `angle` is the input's).
pub fn two_stage(
    b: &TwoStage,
    fault: Option<StageFault>,
    seed: u64,
    env: Option<&Environment>,
    duration: f64,
) -> Recording {
    let mut rng = Rng::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ b.seed);
    let stages = [(b.teeth[0], b.teeth[1], b.contact_ratio[0]), (b.teeth[2], b.teeth[3], b.contact_ratio[1])];
    let train = serial_train(&stages, fault.map(|f| (f.stage, f.fault)), b.seed, b.input_hz, duration, &mut rng);
    let r = ((60_000.0 / b.fs).ceil() as usize).max(2);
    finish_train(&train, b.fs, r, b.seed, b.fan_blades, env, duration, &mut rng)
}

/// Integrates a train and dresses the recording (housing, surroundings, tachometer on the input shaft).
#[allow(clippy::too_many_arguments)]
fn finish_train(
    train: &Train,
    fs: f64,
    r: usize,
    machine_seed: u64,
    blades: usize,
    env: Option<&Environment>,
    duration: f64,
    rng: &mut Rng,
) -> Recording {
    let mut house_rng = Rng::new(machine_seed ^ 0x0B0D);
    let modes = housing(fs, 2 * train.meshes.len(), &mut house_rng);
    let samples = (duration * fs).round() as usize;
    let (mut accel, angle, means) = run_train(train, &modes, fs, r, samples);
    let gear_rms = rms(&accel);
    let plant;
    let env = match env {
        Some(e) => e,
        None => {
            plant = Environment::plant(blades, rng);
            &plant
        }
    };
    let freqs: Vec<f64> = modes.iter().map(|m| m.0).collect();
    surround(&mut accel, &angle, fs, env, &freqs, rng);
    let mut statics = train.op.torque0 / train.meshes[train.meshes.len() - 1].rb_drn;
    let mut mean_force = vec![];
    for (m, mean) in means.iter().enumerate().rev() {
        mean_force.push((*mean, statics));
        if m > 0 {
            statics *= train.meshes[m].rb_drv / train.meshes[m - 1].rb_drn;
        }
    }
    mean_force.reverse();
    Recording { fs, accel, tacho: tacho(&angle), mean_force, gear_rms, angle }
}

// ---------------------------------------------------------------------------------------------------------
// issue 30: a planetary stage

/// A planetary stage: sun input, ring fixed, carrier output; planets at `planet_slots` x 360 / (sun + ring) deg
/// of carrier rotation after planet 1 (the assembly condition for unequal spacing). Planet 1 is at the sensor
/// when the carrier's tachometer pulses; planet i passes it `angle_deg(i)` degrees of carrier rotation later.
#[derive(Clone, Debug)]
pub struct Planetary {
    pub sun: usize,
    pub planet: usize,
    pub ring: usize,
    pub planet_slots: Vec<usize>,
    pub sun_hz: f64,
    pub fs: f64,
    pub contact_ratio: f64,
    pub seed: u64,
}

impl Planetary {
    /// DESIGN.md's stage: sun 21, planets 31, ring 83; three planets at 0, 35 and 69 slots of 360/104 deg.
    pub fn example() -> Self {
        Planetary {
            sun: 21,
            planet: 31,
            ring: 83,
            planet_slots: vec![0, 35, 69],
            sun_hz: 25.0,
            fs: 25_600.0,
            contact_ratio: 1.6,
            seed: 2183,
        }
    }
    /// Carrier speed (Hz): f_sun z_s / (z_s + z_r) with the ring fixed.
    pub fn carrier_hz(&self) -> f64 {
        self.sun_hz * self.sun as f64 / (self.sun + self.ring) as f64
    }
    /// Mesh frequency (Hz): z_r f_c.
    pub fn mesh_hz(&self) -> f64 {
        self.ring as f64 * self.carrier_hz()
    }
    /// Carrier angle (deg) at which planet `i` (1-based) is at the sensor.
    pub fn angle_deg(&self, i: usize) -> f64 {
        360.0 * self.planet_slots[i - 1] as f64 / (self.sun + self.ring) as f64
    }
}

/// Which member of a planetary stage carries a fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Member {
    Sun,
    /// planet number, 1-based
    Planet(usize),
}

/// A fault on a planetary stage: kind (local kinds only: crack, spall, broken) on a member's tooth.
/// Planet tooth numbering: tooth n of planet i is centred in the ring mesh n - 1/2 mesh cycles after planet i
/// passes the sensor (modulo the planet's teeth); its other flank meets the sun floor(z_p / 2) teeth later.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanetaryFault {
    pub member: Member,
    pub kind: FaultKind,
    pub tooth: usize,
}

/// A 1-DOF mesh of a planetary stage (deflection q along its line of action), driven by its share of the load.
struct PlanetMesh {
    mesh: Mesh,
    /// mesh position (cycles) = rate x carrier angle / (2 pi) + offset
    offset: f64,
    mass: f64,
}

/// One recording of a planetary stage: accelerometer on the ring (each planet's ring-mesh force reaches it
/// weighted by ((1 + cos d) / 2)^3, d the planet's angle from the sensor; the sun meshes through the input
/// bearing at 0.3), and a once-per-revolution carrier tachometer. `angle` is the carrier's.
pub fn planetary(
    p: &Planetary,
    fault: Option<PlanetaryFault>,
    seed: u64,
    env: Option<&Environment>,
    duration: f64,
) -> Recording {
    let mut rng = Rng::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ p.seed);
    let mut gear_rng = Rng::new(p.seed);
    let mut fr = Rng::new(p.seed ^ 0xFA17);
    let mut sun = GearBody::made(p.sun, &mut gear_rng);
    let ring = GearBody::made(p.ring, &mut gear_rng);
    let n = p.planet_slots.len();
    let mut planets: Vec<GearBody> = (0..n).map(|_| GearBody::made(p.planet, &mut gear_rng)).collect();
    if let Some(f) = fault {
        match f.member {
            Member::Sun => sun.apply(f.kind, f.tooth, &mut fr),
            Member::Planet(i) => planets[i - 1].apply(f.kind, f.tooth, &mut fr),
        }
    }
    let load_n = 2000.0; // per planet mesh
    let k_max = 2.8e8;
    let eps = p.contact_ratio;
    let mut meshes = vec![];
    let quiet = |mut g: GearBody| {
        g.runout = (0.0, 0.0);
        g
    };
    let half = p.planet / 2;
    let slot = 2.0 * PI / (p.sun + p.ring) as f64;
    for (i, planet) in planets.iter().enumerate() {
        let psi = p.planet_slots[i] as f64 * slot;
        let make = |drv: GearBody, drn: GearBody| Mesh {
            drv: quiet(drv),
            drn: quiet(drn),
            contact_ratio: eps,
            k_max,
            relief: (0.5 * load_n / k_max, 0.5 * (eps - 1.0) / eps),
            damping: 2.0 * 0.04 * (1.6 * k_max * 0.5).sqrt(),
            contact_per_m: 0.0,
            rb_drv: 1.0,
            rb_drn: 1.0,
        };
        // ring mesh: the planet drives nothing here but rolls on the ring; pair j = planet tooth j, ring tooth j
        let ring_mesh = make(planet.clone(), ring.clone());
        // sun mesh: pair j = sun tooth j, planet tooth j + floor(z_p / 2) (the other side of the planet)
        let mut turned = planet.clone();
        turned.teeth.rotate_left(half);
        let sun_mesh = make(sun.clone(), turned);
        // ring mesh cycles: z_r (theta_c - psi) / 2 pi; sun mesh: z_s (theta_s - theta_c + psi) / 2 pi
        // = z_r theta_c / 2 pi + z_s psi / 2 pi (ring fixed)
        meshes.push(PlanetMesh { mesh: ring_mesh, offset: -(p.ring as f64) * psi / (2.0 * PI), mass: 0.5 });
        meshes.push(PlanetMesh { mesh: sun_mesh, offset: p.sun as f64 * psi / (2.0 * PI), mass: 0.5 });
    }
    let op = Operating::new(p.sun_hz, duration, load_n, &mut rng);
    let carrier_per_sun = p.sun as f64 / (p.sun + p.ring) as f64;
    let r = ((60_000.0 / p.fs).ceil() as usize).max(2);
    let rate = p.fs * r as f64;
    let h = 1.0 / rate;
    let fir = decimation_filter(r);
    let fir_half = fir.len() / 2;
    let warm = ((0.3 * rate) as usize).div_ceil(r) * r;
    let samples = (duration * p.fs).round() as usize;
    let total = warm + samples * r + fir_half + 1;
    let mut house_rng = Rng::new(p.seed ^ 0x0B0D);
    let modes = housing(p.fs, 1, &mut house_rng);
    let mut sections: Vec<Mode> = modes.iter().map(|(f, z, g)| Mode::new(*f, *z, g[0], rate)).collect();
    let nm = meshes.len();
    // state: q and q' of every mesh, from the static deflection
    let mut y: Vec<f64> = meshes.iter().flat_map(|m| [load_n / m.mesh.mean_stiffness(), 0.0]).collect();
    let mut sensor = vec![0.0; total];
    let mut angle = vec![0.0; samples];
    let mut clock = Clock::new(&op, -(warm as f64) * h, 0.5 * h);
    let eval = |clock: &Clock, y: &[f64], dy: &mut [f64], forces: &mut [f64]| {
        let (mut a, mut load) = (clock.t + 0.5 * op.drift * clock.t * clock.t, 1.0);
        for (k, &(amp, f, ph)) in op.speed.iter().enumerate() {
            a += amp / (2.0 * PI * f) * (ph.cos() - clock.z[k].0);
        }
        for (k, &(amp, _, _)) in op.load.iter().enumerate() {
            load += amp * clock.z[op.speed.len() + k].1;
        }
        let carrier = op.omega0 * a * carrier_per_sun;
        for (k, m) in meshes.iter().enumerate() {
            let u = p.ring as f64 * carrier / (2.0 * PI) + m.offset;
            let (q, v) = (y[2 * k], y[2 * k + 1]);
            let f = m.mesh.force_at(u, (0.0, eps), q, v);
            forces[k] = f;
            dy[2 * k] = v;
            dy[2 * k + 1] = (op.torque0 * load - f) / m.mass;
        }
        carrier
    };
    let (mut k1, mut k2, mut k3, mut k4, mut tmp) =
        (vec![0.0; 2 * nm], vec![0.0; 2 * nm], vec![0.0; 2 * nm], vec![0.0; 2 * nm], vec![0.0; 2 * nm]);
    let mut forces = vec![0.0; nm];
    let psis: Vec<f64> = p.planet_slots.iter().map(|s| *s as f64 * slot).collect();
    for i in 0..total {
        let carrier = eval(&clock, &y, &mut k1, &mut forces);
        let mut input = 0.0;
        for (k, psi) in psis.iter().enumerate() {
            let w = (0.5 + 0.5 * (carrier - psi).cos()).powi(3);
            input += w * forces[2 * k] + 0.3 * forces[2 * k + 1];
        }
        sensor[i] = sections.iter_mut().map(|s| s.step(input)).sum();
        if i >= warm && (i - warm).is_multiple_of(r) && (i - warm) / r < samples {
            angle[(i - warm) / r] = carrier;
        }
        clock.advance(); // to the middle of the step
        for j in 0..2 * nm {
            tmp[j] = y[j] + 0.5 * h * k1[j];
        }
        eval(&clock, &tmp, &mut k2, &mut forces);
        for j in 0..2 * nm {
            tmp[j] = y[j] + 0.5 * h * k2[j];
        }
        eval(&clock, &tmp, &mut k3, &mut forces);
        clock.advance();
        for j in 0..2 * nm {
            tmp[j] = y[j] + h * k3[j];
        }
        eval(&clock, &tmp, &mut k4, &mut forces);
        for j in 0..2 * nm {
            y[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
    }
    let mut accel: Vec<f64> = (0..samples)
        .map(|k| {
            let c = warm + k * r;
            fir.iter().enumerate().map(|(j, w)| w * sensor[c + j - fir_half]).sum()
        })
        .collect();
    let gear_rms = rms(&accel);
    let plant;
    let env = match env {
        Some(e) => e,
        None => {
            plant = Environment::plant(0, &mut rng);
            &plant
        }
    };
    let freqs: Vec<f64> = modes.iter().map(|m| m.0).collect();
    surround(&mut accel, &angle, p.fs, env, &freqs, &mut rng);
    Recording { fs: p.fs, accel, tacho: tacho(&angle), mean_force: vec![], gear_rms, angle }
}
