//! The cone term: the plain data shared by the PP-form ([`super::pieces`])
//! and its integer tables ([`super::piece_tables`]). It lives apart so that
//! the dependency runs one way: the tables are built from cone terms, and the
//! PP-form owns the tables.

use crate::math::exact::Q;
use crate::math::linalg::QVec;

/// c * prod_{v in V} t_v^(a_v - 1) / (a_v - 1)! / |det V| on the cone t = V^-1 y >= 0.
#[derive(Clone, Debug)]
pub struct ConeTerm {
    /// Rows of V^-1.
    pub inv: Vec<QVec>,
    /// a_v - 1 per basis vector.
    pub powers: Vec<u32>,
    /// c / |det V| / prod (a_v - 1)!.
    pub coef: Q,
}
