//! The cache's size: the paper's memory formula over the counts.

use super::{B_DB, B_GB, B_IV, B_SAT, B_SB};

/// Quantized positions per cell axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quant {
    /// N: density positions per axis (N^3 per cell).
    pub density: u32,
    /// M: gradient positions per axis (M^3 per cell).
    pub gradient: u32,
}

/// The sizes the memory formula is applied to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    /// S: cells of the volume.
    pub cells: u64,
    /// Rows of x (entries of the summed-area table).
    pub rows: u64,
    /// N_cc: candidate cells.
    pub candidates: u64,
    /// N and M.
    pub quant: Quant,
}

/// Bytes per part of the cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "files", derive(serde::Serialize))]
pub struct Memory {
    /// Index volume (IV).
    pub index_volume: u64,
    /// Summed-area table.
    pub summed_area: u64,
    /// Density buffer (DB).
    pub density: u64,
    /// Gradient magnitudes (GB).
    pub gradient: u64,
    /// Gradient signs (SB).
    pub sign: u64,
}

impl Memory {
    /// All parts.
    pub fn total(&self) -> u64 {
        self.index_volume + self.summed_area + self.density + self.gradient + self.sign
    }

    /// One line, bytes per part.
    pub fn describe(&self) -> String {
        format!(
            "{} bytes (index volume {}, summed-area table {}, densities {}, gradients {}, signs {})",
            self.total(),
            self.index_volume,
            self.summed_area,
            self.density,
            self.gradient,
            self.sign
        )
    }
}

/// The paper's equation 6 (equation 3 when N = M) with our byte sizes, plus
/// the summed-area table: S b_iv + rows b_sat + N_cc N^3 b_db +
/// N_cc M^3 (3 b_gb + b_sb).
pub fn formula(c: &Counts) -> Memory {
    let (n3, m3) = (u64::from(c.quant.density).pow(3), u64::from(c.quant.gradient).pow(3));
    Memory {
        index_volume: c.cells * B_IV,
        summed_area: c.rows * B_SAT,
        density: c.candidates * n3 * B_DB,
        gradient: c.candidates * m3 * 3 * B_GB,
        sign: c.candidates * m3 * B_SB,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_formula_is_equation_six() {
        let c = Counts { cells: 1000, rows: 100, candidates: 10, quant: Quant { density: 5, gradient: 3 } };
        let m = formula(&c);
        assert_eq!(m.total(), 1000 * 2 + 100 * 4 + 10 * 125 * 2 + 10 * 27 * 3 + 10 * 27);
    }
}
