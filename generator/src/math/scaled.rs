//! Integer vectors over one common denominator, in checked `i128`.
//!
//! The derivation's inner loops (pieces, BB weights) multiply and add
//! thousands of rationals that share few denominators. Normalising every
//! intermediate [`Q`] costs a gcd each time; scaling a whole vector to one
//! denominator turns those loops into plain integer arithmetic. Every
//! operation is checked: `None` means "too large for i128", and callers fall
//! back to the [`Q`] path, so results stay exact either way.

use crate::math::exact::Q;
use num_integer::Integer;
use num_rational::Ratio;

/// `values[i] = numerators[i] / denominator`, `denominator > 0`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Scaled {
    /// Numerators over the common denominator.
    pub numerators: Vec<i128>,
    /// The common denominator, positive.
    pub denominator: i128,
}

impl Scaled {
    /// The vector over the least common denominator of its entries, or
    /// `None` when an entry is a big rational or the lcm overflows.
    pub fn from_q(values: &[Q]) -> Option<Scaled> {
        let mut denominator: i128 = 1;
        for v in values {
            let r = small(v)?;
            let d = *r.denom();
            denominator = denominator.checked_div(denominator.gcd(&d))?.checked_mul(d)?;
        }
        let numerators = values
            .iter()
            .map(|v| {
                let r = small(v)?;
                r.numer().checked_mul(denominator / r.denom())
            })
            .collect::<Option<Vec<i128>>>()?;
        Some(Scaled { numerators, denominator })
    }

    /// The exact rationals again (each normalised once).
    pub fn to_q(&self) -> Vec<Q> {
        self.numerators.iter().map(|&n| ratio(n, self.denominator)).collect()
    }
}

/// The `i128` ratio inside a small [`Q`].
pub fn small(v: &Q) -> Option<&Ratio<i128>> {
    match v {
        Q::Small(r) => Some(r),
        Q::Big(_) => None,
    }
}

/// n / d as a normalised [`Q`] (d != 0).
pub fn ratio(n: i128, d: i128) -> Q {
    Q::Small(Ratio::new(n, d))
}

/// The integer value of `v` if it is an integer that fits an `i128`.
pub fn integer(v: &Q) -> Option<i128> {
    let r = small(v)?;
    r.is_integer().then(|| *r.numer())
}

/// `acc + a * b`, checked.
#[inline]
pub fn mul_add(acc: i128, a: i128, b: i128) -> Option<i128> {
    acc.checked_add(a.checked_mul(b)?)
}

/// Least common multiple of positive values, checked.
pub fn lcm(a: i128, b: i128) -> Option<i128> {
    a.checked_div(a.gcd(&b))?.checked_mul(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_over_the_least_common_denominator() {
        let v = vec![Q::frac(1, 6), Q::frac(-3, 4), Q::int(2), Q::zero()];
        let s = Scaled::from_q(&v).unwrap();
        assert_eq!(s.denominator, 12);
        assert_eq!(s.numerators, vec![2, -9, 24, 0]);
        assert_eq!(s.to_q(), v);
    }

    #[test]
    fn refuses_what_does_not_fit() {
        let huge = Q::int(i64::MAX).pow(3); // a big rational
        assert!(Scaled::from_q(&[huge]).is_none());
        let fine = Q::frac(1, i64::MAX);
        let other = Q::frac(1, i64::MAX - 1);
        let third = Q::frac(1, i64::MAX - 2);
        assert!(Scaled::from_q(&[fine, other, third]).is_none(), "lcm overflows i128");
        assert_eq!(mul_add(1, i128::MAX, 2), None);
    }
}
