//! Exact rational numbers: a fast `i128` path that promotes itself to a
//! big rational on overflow, so derivations never lose precision and never
//! wrap silently.

use num_bigint::BigInt;
use num_integer::Integer;
use num_rational::{BigRational, Ratio};
use num_traits::{CheckedAdd, CheckedDiv, CheckedMul, CheckedSub, One, Signed, ToPrimitive, Zero};
use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// An exact rational. Always normalised: `Big` only holds values that do not
/// fit the `Small` representation, so structural equality is value equality.
#[derive(Clone, Debug)]
pub enum Q {
    /// A value whose numerator and denominator fit `i128`.
    Small(Ratio<i128>),
    /// A value that does not fit `Small` (never one that does).
    Big(Box<BigRational>),
}

fn big_of(r: &Ratio<i128>) -> BigRational {
    BigRational::new_raw(BigInt::from(*r.numer()), BigInt::from(*r.denom()))
}

fn demote(b: BigRational) -> Q {
    match (b.numer().to_i128(), b.denom().to_i128()) {
        (Some(n), Some(d)) => Q::Small(Ratio::new_raw(n, d)),
        _ => Q::Big(Box::new(b)),
    }
}

impl Q {
    /// 0.
    pub fn zero() -> Q {
        Q::Small(Ratio::from_integer(0))
    }
    /// 1.
    pub fn one() -> Q {
        Q::Small(Ratio::from_integer(1))
    }
    /// The integer n.
    pub fn int(n: i64) -> Q {
        Q::Small(Ratio::from_integer(n as i128))
    }
    /// n/d; panics only on d == 0 (a programming error, never user input).
    pub fn frac(n: i64, d: i64) -> Q {
        assert!(d != 0, "zero denominator");
        Q::Small(Ratio::new(n as i128, d as i128))
    }
    fn big(&self) -> BigRational {
        match self {
            Q::Small(r) => big_of(r),
            Q::Big(b) => (**b).clone(),
        }
    }
    /// Is it 0?
    pub fn is_zero(&self) -> bool {
        match self {
            Q::Small(r) => r.is_zero(),
            Q::Big(_) => false,
        }
    }
    /// Is it 1?
    pub fn is_one(&self) -> bool {
        matches!(self, Q::Small(r) if r.is_one())
    }
    /// Is the denominator 1?
    pub fn is_integer(&self) -> bool {
        match self {
            Q::Small(r) => r.is_integer(),
            Q::Big(b) => b.is_integer(),
        }
    }
    /// Is it < 0?
    pub fn is_negative(&self) -> bool {
        match self {
            Q::Small(r) => r.is_negative(),
            Q::Big(b) => b.is_negative(),
        }
    }
    /// Is it > 0?
    pub fn is_positive(&self) -> bool {
        match self {
            Q::Small(r) => r.is_positive(),
            Q::Big(b) => b.is_positive(),
        }
    }
    /// -1, 0 or 1.
    pub fn signum(&self) -> i32 {
        if self.is_zero() {
            0
        } else if self.is_negative() {
            -1
        } else {
            1
        }
    }
    /// |x|.
    pub fn abs(&self) -> Q {
        if self.is_negative() {
            -self
        } else {
            self.clone()
        }
    }
    /// Largest integer <= self.
    pub fn floor(&self) -> Q {
        match self {
            Q::Small(r) => Q::Small(r.floor()),
            Q::Big(b) => demote(b.floor()),
        }
    }
    /// Floor as i64, or None when it does not fit.
    pub fn floor_i64(&self) -> Option<i64> {
        match self.floor() {
            Q::Small(r) => r.to_integer().to_i64(),
            Q::Big(b) => b.to_integer().to_i64(),
        }
    }
    /// The integer value, if this is an integer that fits an i64.
    pub fn to_i64(&self) -> Option<i64> {
        if self.is_integer() {
            self.floor_i64()
        } else {
            None
        }
    }
    /// An f64 approximation (exact when numerator and denominator are below 2^52).
    pub fn to_f64(&self) -> f64 {
        match self {
            Q::Small(r) => {
                let (n, d) = (*r.numer(), *r.denom());
                if n.unsigned_abs() < (1u128 << 52) && d < (1i128 << 52) {
                    n as f64 / d as f64
                } else {
                    big_of(r).to_f64().unwrap_or(f64::NAN)
                }
            }
            Q::Big(b) => b.to_f64().unwrap_or(f64::NAN),
        }
    }
    /// 1/x (panics on 0, like the division).
    pub fn recip(&self) -> Q {
        Q::one() / self
    }
    /// x^e by repeated multiplication.
    pub fn pow(&self, e: u32) -> Q {
        let mut acc = Q::one();
        for _ in 0..e {
            acc = &acc * self;
        }
        acc
    }
    /// Numerator and denominator as decimal strings.
    pub fn numer_denom(&self) -> (String, String) {
        match self {
            Q::Small(r) => (r.numer().to_string(), r.denom().to_string()),
            Q::Big(b) => (b.numer().to_string(), b.denom().to_string()),
        }
    }
    /// Parses "a", "-a/b".
    pub fn parse(s: &str) -> Option<Q> {
        let s = s.trim();
        let (n, d) = match s.split_once('/') {
            Some((n, d)) => (n.trim(), d.trim()),
            None => (s, "1"),
        };
        let n: BigInt = n.parse().ok()?;
        let d: BigInt = d.parse().ok()?;
        if d.is_zero() {
            return None;
        }
        Some(demote(BigRational::new(n, d)))
    }
}

impl fmt::Display for Q {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (n, d) = self.numer_denom();
        if d == "1" {
            write!(f, "{n}")
        } else {
            write!(f, "{n}/{d}")
        }
    }
}

impl PartialEq for Q {
    fn eq(&self, other: &Q) -> bool {
        match (self, other) {
            (Q::Small(a), Q::Small(b)) => a == b,
            (Q::Big(a), Q::Big(b)) => a == b,
            _ => false,
        }
    }
}
impl Eq for Q {}

impl Hash for Q {
    fn hash<H: Hasher>(&self, state: &mut H) {
        match self {
            Q::Small(r) => {
                0u8.hash(state);
                r.numer().hash(state);
                r.denom().hash(state);
            }
            Q::Big(b) => {
                1u8.hash(state);
                b.numer().hash(state);
                b.denom().hash(state);
            }
        }
    }
}

impl PartialOrd for Q {
    fn partial_cmp(&self, other: &Q) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Q {
    fn cmp(&self, other: &Q) -> Ordering {
        match (self, other) {
            (Q::Small(a), Q::Small(b)) => a.cmp(b),
            _ => self.big().cmp(&other.big()),
        }
    }
}

impl From<i64> for Q {
    fn from(n: i64) -> Q {
        Q::int(n)
    }
}
impl From<i32> for Q {
    fn from(n: i32) -> Q {
        Q::int(n as i64)
    }
}

macro_rules! binop {
    ($Tr:ident, $f:ident, $checked:ident, $op:tt) => {
        impl<'a> $Tr<&'a Q> for &'a Q {
            type Output = Q;
            fn $f(self, rhs: &'a Q) -> Q {
                if let (Q::Small(a), Q::Small(b)) = (self, rhs) {
                    if let Some(r) = a.$checked(b) {
                        return Q::Small(r);
                    }
                }
                demote(self.big() $op rhs.big())
            }
        }
        impl $Tr<Q> for Q {
            type Output = Q;
            fn $f(self, rhs: Q) -> Q {
                (&self).$f(&rhs)
            }
        }
        impl<'a> $Tr<&'a Q> for Q {
            type Output = Q;
            fn $f(self, rhs: &'a Q) -> Q {
                (&self).$f(rhs)
            }
        }
        impl<'a> $Tr<Q> for &'a Q {
            type Output = Q;
            fn $f(self, rhs: Q) -> Q {
                self.$f(&rhs)
            }
        }
    };
}
binop!(Add, add, checked_add, +);
binop!(Sub, sub, checked_sub, -);
binop!(Mul, mul, checked_mul, *);

impl<'a> Div<&'a Q> for &'a Q {
    type Output = Q;
    fn div(self, rhs: &'a Q) -> Q {
        assert!(!rhs.is_zero(), "division by zero in exact arithmetic");
        if let (Q::Small(a), Q::Small(b)) = (self, rhs) {
            if let Some(r) = a.checked_div(b) {
                return Q::Small(r);
            }
        }
        demote(self.big() / rhs.big())
    }
}
impl Div<Q> for Q {
    type Output = Q;
    fn div(self, rhs: Q) -> Q {
        &self / &rhs
    }
}
impl<'a> Div<&'a Q> for Q {
    type Output = Q;
    fn div(self, rhs: &'a Q) -> Q {
        &self / rhs
    }
}

impl Neg for &Q {
    type Output = Q;
    fn neg(self) -> Q {
        match self {
            Q::Small(r) => match r.numer().checked_neg() {
                Some(n) => Q::Small(Ratio::new_raw(n, *r.denom())),
                None => demote(-big_of(r)),
            },
            Q::Big(b) => demote(-(**b).clone()),
        }
    }
}
impl Neg for Q {
    type Output = Q;
    fn neg(self) -> Q {
        -&self
    }
}

impl AddAssign<&Q> for Q {
    fn add_assign(&mut self, rhs: &Q) {
        *self = &*self + rhs;
    }
}
impl AddAssign<Q> for Q {
    fn add_assign(&mut self, rhs: Q) {
        *self = &*self + &rhs;
    }
}
impl SubAssign<&Q> for Q {
    fn sub_assign(&mut self, rhs: &Q) {
        *self = &*self - rhs;
    }
}
impl SubAssign<Q> for Q {
    fn sub_assign(&mut self, rhs: Q) {
        *self = &*self - &rhs;
    }
}
impl MulAssign<&Q> for Q {
    fn mul_assign(&mut self, rhs: &Q) {
        *self = &*self * rhs;
    }
}

impl std::iter::Sum for Q {
    fn sum<I: Iterator<Item = Q>>(iter: I) -> Q {
        iter.fold(Q::zero(), |a, b| a + b)
    }
}

impl Default for Q {
    fn default() -> Q {
        Q::zero()
    }
}

impl serde::Serialize for Q {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

/// Greatest common divisor of integers (non-negative result).
pub fn gcd(a: i64, b: i64) -> i64 {
    a.gcd(&b)
}

/// n! as an exact rational.
pub fn factorial(n: u32) -> Q {
    (1..=n as i64).fold(Q::one(), |acc, k| acc * Q::int(k))
}

/// Binomial coefficient as an exact rational.
pub fn binomial(n: u32, k: u32) -> Q {
    if k > n {
        return Q::zero();
    }
    let mut acc = Q::one();
    for i in 0..k {
        acc = acc * Q::int((n - i) as i64) / Q::int((i + 1) as i64);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overflow_promotes_and_demotes() {
        let big = Q::int(i64::MAX);
        let sq = &big * &big; // fits i128
        let quad = &sq * &sq; // does not
        assert!(matches!(quad, Q::Big(_)));
        let back = &quad / &sq;
        assert_eq!(back, sq);
        assert!(matches!(back, Q::Small(_)));
        assert_eq!(&quad - &quad, Q::zero());
    }

    #[test]
    fn display_and_parse_round_trip() {
        let q = Q::frac(-1, 24);
        assert_eq!(q.to_string(), "-1/24");
        assert_eq!(Q::parse("-1/24").unwrap(), q);
        assert_eq!(Q::parse("6/3").unwrap().to_string(), "2");
        assert!(Q::parse("1/0").is_none());
    }

    #[test]
    fn floor_and_order() {
        assert_eq!(Q::frac(-1, 2).floor(), Q::int(-1));
        assert_eq!(Q::frac(7, 2).floor_i64(), Some(3));
        assert!(Q::frac(1, 3) < Q::frac(1, 2));
        let huge = Q::int(i64::MAX).pow(4);
        assert!(huge > Q::int(1));
        assert!(-&huge < Q::int(-1));
    }

    #[test]
    fn combinatorics() {
        assert_eq!(factorial(5), Q::int(120));
        assert_eq!(binomial(9, 4), Q::int(126));
        assert_eq!(binomial(3, 4), Q::zero());
    }
}
