//! The small WGSL expression writer: literals, straight-line `let` bodies,
//! vector shapes, linear combinations and the static op count.

use crate::derive::symmetry::SignedPerm;
use crate::math::exact::Q;
use std::fmt::Write;

pub(crate) const AXES: [&str; 4] = ["x", "y", "z", "w"];

/// An f32 literal for an exact rational (shortest round-trip form).
pub fn lit(q: &Q) -> String {
    flit(q.to_f64() as f32)
}

pub(crate) fn flit(v: f32) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// Straight-line code with fresh `let` names.
pub(crate) struct Body {
    pub(crate) text: String,
    pub(crate) next: usize,
    pub(crate) indent: usize,
}

impl Body {
    pub(crate) fn new() -> Body {
        Body { text: String::new(), next: 0, indent: 1 }
    }
    pub(crate) fn line(&mut self, s: &str) {
        for _ in 0..self.indent {
            self.text.push_str("    ");
        }
        self.text.push_str(s);
        self.text.push('\n');
    }
    pub(crate) fn bind(&mut self, prefix: &str, expr: &str) -> String {
        let name = format!("{prefix}_{}", self.next);
        self.next += 1;
        self.line(&format!("let {name} = {expr};"));
        name
    }
}

/// Shapes of vectors for a dimension.
pub(crate) struct Shapes {
    pub(crate) s: usize,
    pub(crate) vecf: String,
    pub(crate) veci: String,
}

impl Shapes {
    pub(crate) fn new(s: usize) -> Shapes {
        Shapes { s, vecf: format!("vec{s}<f32>"), veci: format!("vec{s}<i32>") }
    }
    /// The `eval_grad` result of filter `name`: `vec{s+1}<f32>(value, grad)`
    /// up to 3D; in 4D, where WGSL has no five-component vector, the
    /// module's `<name>_Gradient` struct.
    pub(crate) fn grad_result(&self, name: &str, value: &str, grad: &str) -> String {
        if self.s <= 3 {
            format!("vec{}<f32>({value}, {grad})", self.s + 1)
        } else {
            format!("{name}_Gradient({value}, {grad})")
        }
    }
    pub(crate) fn ivec(&self, v: &[i64]) -> String {
        format!("{}({})", self.veci, v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "))
    }
    pub(crate) fn fvec(&self, v: &[String]) -> String {
        format!("{}({})", self.vecf, v.join(", "))
    }
    /// R v for a signed permutation R and a vector expression `v`.
    pub(crate) fn perm_apply(&self, r: &SignedPerm, v: &str) -> String {
        let comps: Vec<String> = r
            .iter()
            .map(|row| {
                let (j, sgn) = row
                    .iter()
                    .enumerate()
                    .find(|(_, x)| **x != 0)
                    .map(|(j, x)| (j, *x))
                    .expect("every row of a signed permutation has one non-zero entry");
                if sgn > 0 {
                    format!("{v}.{}", AXES[j])
                } else {
                    format!("-{v}.{}", AXES[j])
                }
            })
            .collect();
        self.fvec(&comps)
    }
}

/// sum of coefficient * term, skipping zeros and writing +-1 without a product.
pub(crate) fn linear_combination(terms: &[(Q, String)]) -> String {
    let mut out = String::new();
    for (c, t) in terms {
        if c.is_zero() {
            continue;
        }
        let mag = c.abs();
        let piece = if mag.is_one() { t.clone() } else { format!("{} * {t}", lit(&mag)) };
        if out.is_empty() {
            out = if c.is_negative() { format!("-{piece}") } else { piece };
        } else if c.is_negative() {
            let _ = write!(out, " - {piece}");
        } else {
            let _ = write!(out, " + {piece}");
        }
    }
    if out.is_empty() {
        "0.0".to_string()
    } else {
        out
    }
}

/// `n . w <= b` with a small tolerance so neighbouring cells overlap (the
/// last satisfied candidate wins; neighbours agree on shared faces).
pub(crate) fn plane_test(sh: &Shapes, normal: &[Q], bound: &Q, w: &str) -> String {
    let terms: Vec<(Q, String)> = (0..sh.s).map(|i| (normal[i].clone(), format!("{w}.{}", AXES[i]))).collect();
    format!("({} <= {} + 1e-6)", linear_combination(&terms), lit(bound))
}

pub(crate) fn sum_or_zero(terms: &[String]) -> String {
    if terms.is_empty() {
        "0.0".into()
    } else {
        terms.join(" + ")
    }
}

/// Counts operators, selects, comparisons and builtin calls in WGSL source.
pub fn count_ops(src: &str) -> usize {
    let mut n = 0;
    for tok in [
        " + ", " - ", " * ", " / ", "select(", " < ", " <= ", " >= ", " == ", "abs(", "round(", "floor(", "min(",
        "max(", " & ",
    ] {
        n += src.matches(tok).count();
    }
    n
}
