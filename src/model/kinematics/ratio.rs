//! The exact signed rationals of the kinematics: speed ratios and orders, gcd-reduced, with checked
//! arithmetic (i128 products that overflow give `None`, never a wrapped value).

use std::fmt;

/// An exact signed rational num/den (den > 0, gcd-reduced), for speed ratios and orders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Ratio {
    num: i128,
    den: i128,
}

/// Greatest common divisor of |a| and |b| (0 when both are 0).
pub(super) fn gcd_i(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.abs(), b.abs());
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

impl Ratio {
    /// Zero.
    pub const ZERO: Ratio = Ratio { num: 0, den: 1 };
    /// One.
    pub const ONE: Ratio = Ratio { num: 1, den: 1 };

    /// num/den reduced; `None` when den is 0.
    pub fn new(num: i128, den: i128) -> Option<Self> {
        if den == 0 {
            return None;
        }
        let g = gcd_i(num, den).max(1);
        let s = if den < 0 { -1 } else { 1 };
        Some(Self { num: s * num / g, den: s * den / g })
    }
    /// The integer n.
    pub fn integer(n: i128) -> Self {
        Self { num: n, den: 1 }
    }
    /// Numerator (carries the sign).
    pub fn num(self) -> i128 {
        self.num
    }
    /// Denominator (positive).
    pub fn den(self) -> i128 {
        self.den
    }
    /// Product, `None` on overflow (factors cross-reduced first).
    pub fn checked_mul(self, o: Self) -> Option<Self> {
        let g1 = gcd_i(self.num, o.den).max(1);
        let g2 = gcd_i(o.num, self.den).max(1);
        let num = (self.num / g1).checked_mul(o.num / g2)?;
        let den = (self.den / g2).checked_mul(o.den / g1)?;
        Self::new(num, den)
    }
    /// Quotient, `None` on overflow or division by zero.
    pub fn checked_div(self, o: Self) -> Option<Self> {
        if o.num == 0 {
            return None;
        }
        self.checked_mul(Self::new(o.den, o.num)?)
    }
    /// Sum, `None` on overflow.
    pub fn checked_add(self, o: Self) -> Option<Self> {
        let g = gcd_i(self.den, o.den).max(1);
        let num = self.num.checked_mul(o.den / g)?.checked_add(o.num.checked_mul(self.den / g)?)?;
        let den = (self.den / g).checked_mul(o.den)?;
        Self::new(num, den)
    }
    /// Difference, `None` on overflow.
    pub fn checked_sub(self, o: Self) -> Option<Self> {
        self.checked_add(Self { num: -o.num, den: o.den })
    }
    /// |self|.
    pub fn abs(self) -> Self {
        Self { num: self.num.abs(), den: self.den }
    }
    /// Nearest f64.
    pub fn to_f64(self) -> f64 {
        self.num as f64 / self.den as f64
    }
    /// True for 0.
    pub fn is_zero(self) -> bool {
        self.num == 0
    }
}

impl fmt::Display for Ratio {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.den == 1 { write!(f, "{}", self.num) } else { write!(f, "{}/{}", self.num, self.den) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_arithmetic_works() {
        let a = Ratio::new(6, -4).unwrap();
        assert_eq!((a.num(), a.den()), (-3, 2));
        let b = Ratio::new(5, 6).unwrap();
        assert_eq!(a.checked_mul(b).unwrap(), Ratio::new(-5, 4).unwrap());
        assert_eq!(a.checked_add(b).unwrap(), Ratio::new(-2, 3).unwrap());
        assert_eq!(a.checked_div(b).unwrap(), Ratio::new(-9, 5).unwrap());
        assert_eq!(a.checked_sub(a).unwrap(), Ratio::ZERO);
        assert!(Ratio::new(1, 0).is_none());
        assert_eq!(format!("{}", Ratio::new(61, 23).unwrap()), "61/23");
        let big = Ratio::integer(i128::MAX / 2);
        assert!(big.checked_mul(Ratio::integer(3)).is_none());
    }
}
