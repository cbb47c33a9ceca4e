//! Projected tetrahedra (Mattausch et al. 2003, §4).
pub mod tets;
