//! The quantity a scene reports and writes.

/// What `simulate` reports: a linear function of the state, or a component of x' = P x + f.
#[derive(Clone, Debug, PartialEq)]
pub enum OutputQuantity {
    /// `sum_i weights[i] x_i`.
    Linear {
        /// Weight of each state component.
        weights: Vec<f64>,
        /// Physical unit of the result, e.g. "m/s".
        unit: String,
        /// Name shown to people, e.g. "dq/dt".
        name: String,
    },
    /// Component `index` of x' = P(t) x + f(t) (an acceleration for index >= N).
    Derivative {
        /// State index.
        index: usize,
        /// Physical unit.
        unit: String,
        /// Name shown to people.
        name: String,
    },
}

impl OutputQuantity {
    /// Evaluates the quantity from state `x` and, for `Derivative`, from `xdot = P x + f`.
    pub fn value(&self, x: &[f64], xdot: &[f64]) -> f64 {
        match self {
            Self::Linear { weights, .. } => weights.iter().zip(x).map(|(w, v)| w * v).sum(),
            Self::Derivative { index, .. } => xdot[*index],
        }
    }
    /// Whether `value` needs x'.
    pub fn needs_derivative(&self) -> bool {
        matches!(self, Self::Derivative { .. })
    }
    /// Unit string.
    pub fn unit(&self) -> &str {
        match self {
            Self::Linear { unit, .. } | Self::Derivative { unit, .. } => unit,
        }
    }
    /// Display name.
    pub fn name(&self) -> &str {
        match self {
            Self::Linear { name, .. } | Self::Derivative { name, .. } => name,
        }
    }
}

/// A physical motion quantity: what a sensor measures (accelerometer, laser vibrometer, proximity probe)
/// and what a gear-pair scene writes. Also the unit conversion between them for a line at angular
/// frequency w: displacement = velocity / w = acceleration / w^2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// Acceleration (m/s^2 for the gear pair's dq/dt derivative).
    Acceleration,
    /// Velocity (m/s; what `gearvib simulate` writes for the gear pair, dq/dt).
    Velocity,
    /// Displacement (m).
    Displacement,
}

impl Quantity {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Acceleration => "acceleration",
            Self::Velocity => "velocity",
            Self::Displacement => "displacement",
        }
    }
    /// The quantity a physical unit measures ("m/s" velocity; "m/s^2", "m/s2", "g" acceleration; "m", "mm",
    /// "um" displacement), `None` for anything else.
    pub fn from_unit(unit: &str) -> Option<Self> {
        match unit.trim().replace(['²', ' '], "^2").as_str() {
            "m/s" | "mm/s" | "in/s" => Some(Self::Velocity),
            "m/s^2" | "m/s2" | "mm/s^2" | "g" => Some(Self::Acceleration),
            "m" | "mm" | "um" | "µm" => Some(Self::Displacement),
            _ => None,
        }
    }
    /// A line amplitude `a` of this quantity at angular frequency `w_rad_s` (1/s) as a velocity amplitude.
    pub fn to_velocity(self, a: f64, w_rad_s: f64) -> f64 {
        match self {
            Self::Velocity => a,
            Self::Acceleration => a / w_rad_s,
            Self::Displacement => a * w_rad_s,
        }
    }
}

impl std::str::FromStr for Quantity {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "acceleration" => Ok(Self::Acceleration),
            "velocity" => Ok(Self::Velocity),
            "displacement" => Ok(Self::Displacement),
            other => Err(format!("expected acceleration, velocity or displacement, got \"{other}\"")),
        }
    }
}
