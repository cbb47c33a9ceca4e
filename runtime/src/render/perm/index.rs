//! Which cells are cached, and the index volume that finds them.

use crate::render::dvr::empty_flags;
use crate::render::dvr::skip_flags;
use crate::render::dvr::transfer::Tf1d;

/// Which cells are cached: visible cells (the transfer function is not
/// transparent over the cell's [min, max]) dilated by `radius` cells.
/// Returns (visible, candidate) flags, x fastest.
pub fn select_cells(bounds: &[[f32; 2]], dims: [usize; 3], table: &Tf1d, radius: i32) -> (Vec<bool>, Vec<bool>) {
    let empty: Vec<u32> = empty_flags(bounds, table);
    let visible = empty.iter().map(|&e| e == 0).collect();
    // A cell is far from every visible cell when it and all cells within
    // the radius are transparent: the skipping's min filter.
    let far = skip_flags(&empty, dims.map(|n| n as i32), radius);
    (visible, far.iter().map(|&f| f == 0).collect())
}

/// The index volume and summed-area table of templates/perm.wgsl.j2.
#[derive(Clone, Debug, PartialEq)]
pub struct Index {
    /// 16-bit entries, two per word (cell 2i in the low half of word i).
    pub words: Vec<u32>,
    /// Per row of x: the candidates of all earlier rows.
    pub sat: Vec<u32>,
    /// Candidate cells in slot order (linear cell index).
    pub cells: Vec<u32>,
}

/// The 15-bit substitute of a non-candidate cell: the middle of its
/// [min, max] in fixed point over the table's range (clamped: the tables
/// clamp too).
fn substitute(b: [f32; 2], table: &Tf1d) -> u32 {
    let mid = 0.5 * (b[0] as f64 + b[1] as f64);
    let u = ((mid - table.lo as f64) / (table.hi as f64 - table.lo as f64)).clamp(0.0, 1.0);
    if u.is_nan() {
        return 0;
    }
    (u * 32767.0).round() as u32
}

/// Builds the index volume: candidates get their index within the row,
/// others `0x8000 | substitute`.
pub fn build_index(candidate: &[bool], bounds: &[[f32; 2]], dims: [usize; 3], table: &Tf1d) -> Index {
    let nx = dims[0];
    let rows = dims[1] * dims[2];
    let mut entries = vec![0u32; candidate.len()];
    let mut sat = Vec::with_capacity(rows);
    let mut cells = Vec::new();
    for r in 0..rows {
        sat.push(cells.len() as u32);
        let mut local = 0u32;
        for x in 0..nx {
            let i = r * nx + x;
            if candidate[i] {
                entries[i] = local;
                local += 1;
                cells.push(i as u32);
            } else {
                entries[i] = 0x8000 | substitute(bounds[i], table);
            }
        }
    }
    let words = entries.chunks(2).map(|p| p[0] | (p.get(1).copied().unwrap_or(0) << 16)).collect();
    Index { words, sat, cells }
}

impl Index {
    /// The slot of cell `i` as the shader finds it (None: not a candidate).
    pub fn slot(&self, i: usize, nx: usize) -> Option<u32> {
        let w = (self.words[i >> 1] >> ((i & 1) << 4)) & 0xffff;
        (w & 0x8000 == 0).then(|| self.sat[i / nx] + (w & 0x7fff))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::dvr::transfer::TransferFunction;

    #[test]
    fn the_index_finds_every_candidate_and_keeps_substitutes_transparent() {
        let tf = TransferFunction::parse(
            r#"{"range": [0, 1], "points": [{"value": 0, "color": [0, 0, 0], "opacity": 0},
                {"value": 0.3, "color": [0, 0, 0], "opacity": 0}, {"value": 0.5, "color": [1, 1, 1], "opacity": 0.8}]}"#,
            "t",
        )
        .unwrap()
        .table();
        let dims = [5, 3, 2];
        // Cell bounds: a visible cell at (2, 1, 1), everything else clear.
        let mut bounds = vec![[0.0f32, 0.05]; 30];
        bounds[2 + 5 * (1 + 3)] = [0.2, 0.8];
        let (visible, candidate) = select_cells(&bounds, dims, &tf, 1);
        assert_eq!(visible.iter().filter(|&&v| v).count(), 1);
        // Brute-force dilation.
        for z in 0..2i32 {
            for y in 0..3i32 {
                for x in 0..5i32 {
                    let near = (x - 2).abs() <= 1 && (y - 1).abs() <= 1 && (z - 1).abs() <= 1;
                    assert_eq!(candidate[(x + 5 * (y + 3 * z)) as usize], near, "({x}, {y}, {z})");
                }
            }
        }
        let index = build_index(&candidate, &bounds, dims, &tf);
        let mut seen = vec![];
        for (i, &c) in candidate.iter().enumerate() {
            match index.slot(i, 5) {
                Some(s) => {
                    assert!(c);
                    assert_eq!(index.cells[s as usize], i as u32);
                    seen.push(s);
                }
                None => {
                    assert!(!c);
                    let w = (index.words[i >> 1] >> ((i & 1) << 4)) & 0x7fff;
                    let v = tf.lo + (tf.hi - tf.lo) * w as f32 / 32767.0;
                    assert!((v - 0.025).abs() < 1e-4 && tf.transparent(v as f64, v as f64));
                }
            }
        }
        seen.sort();
        assert_eq!(seen, (0..index.cells.len() as u32).collect::<Vec<_>>(), "slots are 0..N_cc, each once");
    }
}
