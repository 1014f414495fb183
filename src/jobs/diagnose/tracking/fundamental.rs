//! Which multiple or divisor of a repetition's mesh order is the mesh fundamental.

use super::*;

/// Smallest amplitude of a mesh fundamental relative to its strongest harmonic: the bundled cracked-tooth
/// scene's first mesh line is 10 % of its second (a resonance near twice the mesh), while on the real
/// SpectraQuest recordings the lines at half and a quarter of the mesh order are 1.6 % and 4.5 % of the
/// mesh: an engineering choice between the two.
const MESH_FUNDAMENTAL_SHARE: f64 = 0.07;

/// The mesh order whose fundamental is really there: a repetition lag can hold two or three mesh periods,
/// or only half or a third of one (a strong second harmonic), and a harmonic family can score through its
/// even harmonics; so among z / 3, z / 2, z, 2z and 3z (whole divisors and multiples, at least 8) the
/// smallest whose line reaches [`MESH_FUNDAMENTAL_SHARE`] of its strongest harmonic (orders 1..=4 times
/// it) is taken, summed over channels; a divisor must moreover stand 4 times above the orders around it
/// (a line at half the mesh order from elsewhere in the machine is not a mesh).
pub(super) fn fundamental_mesh(channels: &[&[f32]], period: f64, z: usize) -> usize {
    // summed over channels, the strongest line within +-`search` orders of `order`
    let amp = |order: f64, search: f64| -> f64 {
        let f = order / period;
        if f >= 0.5 {
            return 0.0;
        }
        channels.iter().map(|c| ind_line(c, f, search / period)).sum()
    };
    fundamental_mesh_by(&amp, z)
}

/// [`fundamental_mesh`] on any amplitude reading: `amp(order, search)` is the strongest line within
/// +-`search` orders of `order`.
pub(super) fn fundamental_mesh_by(amp: &dyn Fn(f64, f64) -> f64, z: usize) -> usize {
    // a divisor of z must also be a line of its own: 4 times the median of orders c +- 1..3
    let clear_line = |c: usize| -> bool {
        let mut near: Vec<f64> = [-3.0, -2.0, -1.0, 1.0, 2.0, 3.0].iter().map(|d| amp(c as f64 + d, 0.2)).collect();
        near.sort_by(f64::total_cmp);
        amp(c as f64, 0.2) >= 4.0 * 0.5 * (near[2] + near[3])
    };
    let mut candidates: Vec<usize> = [z / 3, z / 2, z, 2 * z, 3 * z]
        .into_iter()
        .filter(|&c| c >= 8 && (c % z == 0 || z.is_multiple_of(c)))
        .collect();
    candidates.dedup();
    for c in candidates {
        // +-0.2 orders: a wheel of 2.5 times as many teeth puts lines every 0.4 pinion orders
        let own = amp(c as f64, 0.2);
        let strongest = (1..=4).map(|k| amp((k * c) as f64, 0.2)).fold(0.0, f64::max);
        if own >= MESH_FUNDAMENTAL_SHARE * strongest && own > 0.0 && (c >= z || clear_line(c)) {
            return c;
        }
    }
    z
}
