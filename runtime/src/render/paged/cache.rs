//! Which bricks are in the pool: slots, the page table the shader reads,
//! and least-recently-requested eviction. Pure bookkeeping (no device), so
//! the policy is tested on its own.

use boxforge::emit::bricks::{page_word, MISSING_PAGE};

/// The pool's slots and the bricks in them.
#[derive(Clone, Debug)]
pub struct BrickCache {
    /// Slots per axis of the pool texture.
    pub slots: [usize; 3],
    /// The page table: one word per brick (x fastest), [`MISSING_PAGE`] when out.
    pub pages: Vec<u32>,
    /// The brick in each slot.
    occupant: Vec<Option<usize>>,
    /// The pass each slot's brick was last requested in.
    stamp: Vec<u64>,
    /// Bricks uploaded so far (counting re-uploads after eviction).
    pub uploads: usize,
    /// Bricks evicted so far.
    pub evictions: usize,
}

impl BrickCache {
    /// An empty pool of `capacity` slots laid out `slots` per axis, for `bricks` bricks.
    pub fn new(slots: [usize; 3], capacity: usize, bricks: usize) -> BrickCache {
        BrickCache {
            slots,
            pages: vec![MISSING_PAGE; bricks],
            occupant: vec![None; capacity],
            stamp: vec![0; capacity],
            uploads: 0,
            evictions: 0,
        }
    }

    /// Slots in the pool.
    pub fn capacity(&self) -> usize {
        self.occupant.len()
    }

    /// Bricks in the pool.
    pub fn resident(&self) -> usize {
        self.occupant.iter().filter(|o| o.is_some()).count()
    }

    /// The slot's coordinates in the pool (slots x fastest).
    pub fn slot_coords(&self, slot: usize) -> [usize; 3] {
        [slot % self.slots[0], (slot / self.slots[0]) % self.slots[1], slot / (self.slots[0] * self.slots[1])]
    }

    /// Admits the `requested` bricks of pass `pass` (pass numbers grow from
    /// 1): each takes a free slot, else the slot whose brick was requested
    /// longest ago, never one requested in this pass. Returns the (brick,
    /// slot) pairs to upload; bricks that found no slot wait for a later pass.
    pub fn admit(&mut self, requested: &[usize], pass: u64) -> Vec<(usize, usize)> {
        let mut uploads = Vec::new();
        // Requested bricks already in the pool are fresh again.
        for (slot, o) in self.occupant.iter().enumerate() {
            if let Some(b) = o {
                if requested.binary_search(b).is_ok() {
                    self.stamp[slot] = pass;
                }
            }
        }
        for &brick in requested {
            if self.pages[brick] != MISSING_PAGE {
                continue;
            }
            let victim = (0..self.capacity())
                .filter(|&s| self.occupant[s].is_none() || self.stamp[s] < pass)
                .min_by_key(|&s| (self.occupant[s].is_some(), self.stamp[s]));
            let Some(slot) = victim else { break };
            if let Some(old) = self.occupant[slot].replace(brick) {
                self.pages[old] = MISSING_PAGE;
                self.evictions += 1;
            }
            self.stamp[slot] = pass;
            self.pages[brick] = page_word(&self.slot_coords(slot));
            self.uploads += 1;
            uploads.push((brick, slot));
        }
        uploads
    }
}

/// The bricks whose bits are set in a request bitset of `bricks` bits, ascending.
pub fn requested_bricks(bits: &[u32], bricks: usize) -> Vec<usize> {
    let mut out = Vec::new();
    for (w, &word) in bits.iter().enumerate() {
        let mut m = word;
        while m != 0 {
            let b = w * 32 + m.trailing_zeros() as usize;
            if b < bricks {
                out.push(b);
            }
            m &= m - 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_fill_free_slots_then_evict_the_least_recently_requested() {
        let mut c = BrickCache::new([2, 1, 1], 2, 10);
        assert_eq!(c.admit(&[3, 7], 1), vec![(3, 0), (7, 1)]);
        assert_eq!(c.pages[3], page_word(&[0, 0, 0]));
        assert_eq!(c.pages[7], page_word(&[1, 0, 0]));
        // Pass 2 asks for 7 again (it stays) and 5 (evicts 3, older).
        assert_eq!(c.admit(&[5, 7], 2), vec![(5, 0)]);
        assert_eq!(c.pages[3], MISSING_PAGE);
        assert_eq!((c.uploads, c.evictions, c.resident()), (3, 1, 2));
        // More requests than slots: those requested this pass are kept, the rest wait.
        let got = c.admit(&[1, 2, 4], 3);
        assert_eq!(got.len(), 2);
        assert!(c.admit(&[8, 9], 3).is_empty(), "every slot was requested in pass 3");
    }

    #[test]
    fn request_bits_list_their_bricks() {
        assert_eq!(requested_bricks(&[0b1010, 1 << 31, 1], 65), vec![1, 3, 63, 64]);
        assert_eq!(requested_bricks(&[u32::MAX], 3), vec![0, 1, 2]);
    }
}
