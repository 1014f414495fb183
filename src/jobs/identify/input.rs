//! What `identify` checks and derives before fitting: the gear pair, the channels, the sample rate, the
//! quantity, the tracked angle, and which orders the recording can resolve.

use super::*;

/// The scene's gear pair, without its errors, faults and crack (what the fit estimates).
pub(super) fn gear_params(job: &IdentifyJob, warnings: &mut Vec<String>) -> Result<GearPairParams, Error> {
    let scene = Scene::load(&job.scene.display().to_string())?;
    let Model::GearPair(pair) = &scene.model else {
        return Err(bad(
            &job.scene,
            "the scene is not a gear pair (model gear_pair): identify fits a gear pair's tooth errors",
        ));
    };
    let params = pair.params().clone();
    if !matches!(params.mesh, MeshStiffness::Fourier(_)) {
        return Err(bad(
            &job.scene,
            "mesh_stiffness must be a Fourier series for identify (its transfers are solved by harmonic balance)",
        ));
    }
    if !params.pinion_errors.is_constant() || !params.wheel_errors.is_constant() || params.crack.is_some() {
        warnings.push("the scene's own tooth errors, faults and crack are ignored: they are what is fitted".into());
    }
    Ok(params)
}

/// Channel roles of a recording: the vibration channel and the tachometers (0-based).
pub(super) struct Channels {
    /// The vibration channel analysed.
    pub vibration: usize,
    /// The pinion's tachometer, when there is one.
    pub pinion_tacho: Option<usize>,
    /// The wheel's tachometer, when there is one.
    pub wheel_tacho: Option<usize>,
}

pub(super) fn channels(job: &IdentifyJob, rec: &Recording) -> Result<Channels, Error> {
    let n = rec.channels.len();
    let check = |role: crate::jobs::ChannelRole, c: usize| -> Result<usize, Error> {
        if c == 0 || c > n {
            Err(JobError::Channel { file: job.recording.display().to_string(), role, index: c, count: n }.into())
        } else {
            Ok(c - 1)
        }
    };
    let named = |name: &str| rec.names.iter().position(|c| c == name);
    let pinion_tacho = match job.tacho_channel {
        Some(c) => Some(check(crate::jobs::ChannelRole::Tachometer, c)?),
        None => named(crate::jobs::diagnose::PINION_TACHO),
    };
    let wheel_tacho = named("tacho wheel");
    let vibration = match job.channel {
        Some(c) => check(crate::jobs::ChannelRole::Vibration, c)?,
        None => (0..n)
            .find(|&c| Some(c) != pinion_tacho && !rec.names[c].starts_with("tacho") && rec.units[c] != "pulse")
            .ok_or_else(|| bad(&job.recording, "no vibration channel besides the tachometers"))?,
    };
    if Some(vibration) == pinion_tacho {
        return Err(bad(
            &job.recording,
            format!("channel {} is the tachometer: it cannot also be the vibration", vibration + 1),
        ));
    }
    Ok(Channels { vibration, pinion_tacho, wheel_tacho })
}

pub(super) fn sample_rate(job: &IdentifyJob, rec: &Recording) -> Result<f64, Error> {
    let fs = job.fs_hz.or(rec.sample_rate_hz).ok_or_else(|| {
        Error::from(JobError::NoSampleRate { file: job.recording.display().to_string(), for_speed: false })
    })?;
    let (lo, hi) = crate::jobs::diagnose::SAMPLE_RATE_RANGE_HZ;
    if !(fs.is_finite() && (lo..=hi).contains(&fs)) {
        return Err(value(Given::SampleRate, format!("must be between {lo} Hz and {hi:e} Hz, got {fs:e} Hz")));
    }
    Ok(fs)
}

pub(super) fn quantity(job: &IdentifyJob, rec: &Recording, c: usize, warnings: &mut Vec<String>) -> Quantity {
    if let Some(q) = job.quantity {
        return q;
    }
    match Quantity::from_unit(&rec.units[c]) {
        Some(q) => q,
        None => {
            warnings.push(format!(
                "channel {} names no unit: taken as velocity (dq/dt); give the quantity if it is not",
                c + 1
            ));
            Quantity::Velocity
        }
    }
}

/// The tracked angle; checks the speed against the scene's.
pub(super) fn track(
    job: &IdentifyJob,
    rec: &Recording,
    ch: &Channels,
    fs: f64,
    p: &GearPairParams,
) -> Result<Angle, Error> {
    let scene_hz = p.speed_rpm / 60.0;
    let teeth = (p.pinion_teeth, p.wheel_teeth);
    let x = &rec.channels[ch.vibration];
    let angle = match ch.pinion_tacho {
        Some(t) => measure::angle_from_tacho(&rec.channels[t], ch.wheel_tacho.map(|w| &*rec.channels[w]), teeth)
            .map_err(|e| bad(&job.recording, format!("tachometer channel {}: {e}", t + 1)))?,
        None => measure::angle_from_mesh(x, fs / scene_hz, p.pinion_teeth).map_err(|e| {
            bad(
                &job.recording,
                format!("no tachometer, and the mesh line (order {}) cannot be tracked: {e}", p.pinion_teeth),
            )
        })?,
    };
    let mean_hz = angle.speed.mean * fs;
    let off = mean_hz / scene_hz - 1.0;
    if off.abs() > MAX_SPEED_OFFSET {
        return Err(bad(
            &job.recording,
            format!(
                "runs at {mean_hz:.3} Hz ({:.1} rpm), {:+.1} % from the scene's {:.1} rpm: the scene does not model this operating point (more than {:.0} % apart)",
                mean_hz * 60.0,
                100.0 * off,
                p.speed_rpm,
                100.0 * MAX_SPEED_OFFSET
            ),
        ));
    }
    Ok(angle)
}

/// Highest harmonic of the averaged period the fit may use (the harmonic-balance and averaging work grows
/// with it; the bundled 14/39 pair with wheel orders needs about 4000).
pub const MAX_PERIOD_ORDER: usize = 1 << 18;

/// Largest relative difference between the recording's speed and the scene's that the model is re-solved
/// for (beyond it the scene is another operating point).
pub const MAX_SPEED_OFFSET: f64 = 0.10;

/// Mesh harmonics the sample rate resolves with every sideband of the fit below [`MAX_LINE_FRACTION`].
pub(super) fn resolvable_harmonics(job: &IdentifyJob, p: &GearPairParams, per_rev: f64) -> Result<usize, Error> {
    let (z1, z2) = (p.pinion_teeth, p.wheel_teeth);
    let side = (job.pinion_orders as f64).max(job.wheel_orders as f64 * z1 as f64 / z2 as f64);
    let top = MAX_LINE_FRACTION * per_rev;
    let h = ((top - side) / z1 as f64).floor();
    if h < 1.0 {
        return Err(bad(
            &job.recording,
            format!(
                "{per_rev:.1} samples per pinion revolution resolve orders up to {top:.1}: the first mesh harmonic (order {z1}) and its sidebands up to order {:.1} are beyond it; the sample rate is too low for this gear pair",
                z1 as f64 + side
            ),
        ));
    }
    Ok((h as usize).min(job.mesh_harmonics.unwrap_or(MAX_HARMONICS)))
}

pub(super) fn check_orders(job: &IdentifyJob, p: &GearPairParams) -> Result<(), Error> {
    let (z1, z2) = (p.pinion_teeth, p.wheel_teeth);
    if job.pinion_orders == 0 && job.wheel_orders == 0 {
        return Err(value(Given::Orders, "the pinion and wheel orders to fit are both 0: nothing to fit"));
    }
    if 2 * job.pinion_orders >= z1 {
        return Err(value(
            Given::PinionOrders,
            format!(
                "{} with {z1} pinion teeth: the sidebands of orders {} and {} of neighbouring mesh harmonics fall on the same lines, so orders from z1 / 2 = {} up are not identifiable; use at most {}",
                job.pinion_orders,
                z1 / 2,
                z1 - z1 / 2,
                z1 as f64 / 2.0,
                (z1 - 1) / 2
            ),
        ));
    }
    if 2 * job.wheel_orders >= z2 {
        return Err(value(
            Given::WheelOrders,
            format!("{} with {z2} wheel teeth: use at most {}", job.wheel_orders, (z2 - 1) / 2),
        ));
    }
    // a pit's Gaussian needs about 6.2 z / w harmonics of the gear angle: 1e-6 pitches asked for 2.7 GB
    // (an abort), 1e-300 overflowed, and below 0.01 the transfer's solve cannot meet its tolerance
    if !(job.pit_width_teeth.is_finite() && (0.01..=3.0).contains(&job.pit_width_teeth)) {
        return Err(value(
            Given::PitWidth,
            format!(
                "must be in [0.01, 3] tooth pitches (a narrower pit's profile needs more harmonics than the model resolves), got {:e}",
                job.pit_width_teeth
            ),
        ));
    }
    Ok(())
}
