//! Ratio statistics over interleaved timing rounds: each round times every
//! contender once (rotating which goes first), the ratio is taken per round,
//! and a comparison reports the median ratio with its min..max over rounds.
//! A comparison whose range contains 1.0 is a tie.

use serde::Serialize;

/// Median of the values (mean of the middle two for an even count); NaN for none.
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// (min, max) of the values; (NaN, NaN) for none.
pub fn range(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

/// True when the ratios' range spans 1.0 (neither side wins every round).
pub fn is_tie(min: f64, max: f64) -> bool {
    min <= 1.0 && max >= 1.0
}

/// A ratio measured over rounds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Ratio {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    pub rounds: usize,
    pub tie: bool,
}

impl Ratio {
    /// From per-round ratios.
    pub fn from_rounds(ratios: &[f64]) -> Ratio {
        let (min, max) = range(ratios);
        Ratio { median: median(ratios), min, max, rounds: ratios.len(), tie: is_tie(min, max) }
    }

    /// From per-round rates of a and b: the ratio a / b of each round.
    pub fn of_rates(a: &[f64], b: &[f64]) -> Ratio {
        assert_eq!(a.len(), b.len(), "one rate per round on each side");
        let r: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
        Ratio::from_rounds(&r)
    }

    /// "1.23 [1.10..1.31]", with ", tie" when the range spans 1.
    pub fn display(&self) -> String {
        format!("{:.2} [{:.2}..{:.2}]{}", self.median, self.min, self.max, if self.tie { ", tie" } else { "" })
    }
}

/// The order in which `n` contenders run in round `r`: a rotation by r, so
/// each one goes first equally often.
pub fn round_order(n: usize, r: usize) -> Vec<usize> {
    (0..n).map(|k| (k + r) % n.max(1)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_odd_even_and_unsorted() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[7.0]), 7.0);
        assert!(median(&[]).is_nan());
        // Robust to one outlier, unlike the mean.
        assert_eq!(median(&[1.0, 1.1, 100.0]), 1.1);
    }

    #[test]
    fn range_is_min_and_max() {
        assert_eq!(range(&[2.0, -1.0, 5.0, 0.5]), (-1.0, 5.0));
        let (a, b) = range(&[]);
        assert!(a.is_nan() && b.is_nan());
    }

    #[test]
    fn tie_when_the_range_spans_one() {
        assert!(is_tie(0.9, 1.1));
        assert!(is_tie(1.0, 1.3));
        assert!(is_tie(0.7, 1.0));
        assert!(!is_tie(1.01, 1.5));
        assert!(!is_tie(0.2, 0.99));
    }

    #[test]
    fn ratio_per_round_not_ratio_of_medians() {
        // Round-by-round: a is always 2x b although both drift.
        let a = [2.0, 4.0, 8.0];
        let b = [1.0, 2.0, 4.0];
        let r = Ratio::of_rates(&a, &b);
        assert_eq!((r.median, r.min, r.max, r.rounds, r.tie), (2.0, 2.0, 2.0, 3, false));
        // One round the other way round: a tie.
        let r = Ratio::of_rates(&[2.0, 0.5, 3.0], &[1.0, 1.0, 1.0]);
        assert!(r.tie);
        assert_eq!(r.median, 2.0);
        assert_eq!(r.display(), "2.00 [0.50..3.00], tie");
    }

    #[test]
    fn rotation_puts_each_first_once_per_cycle() {
        assert_eq!(round_order(2, 0), vec![0, 1]);
        assert_eq!(round_order(2, 1), vec![1, 0]);
        assert_eq!(round_order(3, 1), vec![1, 2, 0]);
        let firsts: Vec<usize> = (0..3).map(|r| round_order(3, r)[0]).collect();
        assert_eq!(firsts, vec![0, 1, 2]);
    }
}
