//! An independent box-spline evaluator, used as a test oracle for the
//! piecewise-polynomial derivation: de Boor's recurrence (docs/BOX_SPLINES.md §3
//! step 5) in exact rationals, memoised.
//!
//! It deliberately shares no code with the rest of the generator except
//! [`crate::math::exact`], [`crate::math::linalg`], [`crate::spec::lattice`] and [`crate::spec`].
//!
//! Method. Equal columns are grouped into distinct directions `d_k` with
//! multiplicities, so a sub-multiset of Xi is a multiplicity vector `mu`
//! (stored once per distinct `mu` in a `Node`). For a node with `m`
//! columns, `m > s`, and any `t` with `Xi t = x`:
//!
//! `(m - s) M_mu(x) = sum_k [ T_k M_{mu-e_k}(x) + (mu_k - T_k) M_{mu-e_k}(x - d_k) ]`
//!
//! where `T_k` is the sum of `t` over the columns equal to `d_k`. The node
//! fixes `t` by solving with a basis `B` of `s` of its distinct directions (one
//! column each, all other entries 0), so only the basis directions contribute
//! an unshifted term. Terms whose sub-multiset no longer spans are dropped
//! (they vanish off the knot planes). The base case `m = s` is
//! `1/|det B|` on `B[0,1)^s`.
//!
//! Every point met while evaluating at `p` is `p` minus an integer vector, so
//! points are stored as `base + shift` with `base = p - floor(p)` fixed and an
//! integer `shift`; the memo is keyed on `(node, shift)` and is reset only when
//! the fractional base changes (all `phi(x - j)` of one [`Oracle::spline_value`]
//! call share it). Before any rational work each call rejects points outside
//! the node's zonotope exactly, by integer tests against every knot-plane
//! normal of the filter (the facet normals of every sub-zonotope are among
//! them) and the coordinate axes.
//!
//! Validity: the recurrence and the half-open base case are exact at points
//! off all knot planes of the shifted spline space (n.x not in (1/2)Z for
//! the knot normals n, after centring). On a knot plane the dropped
//! non-spanning terms need not vanish and the result is meaningless (not even
//! a one-sided limit): callers must evaluate strictly inside cells.

use crate::math::exact::Q;
use crate::math::linalg::{dot_iq, inverse, primitive_normal, rank_of_vectors, IVec, QVec};
use crate::spec::lattice::Lattice;
use crate::spec::Filter;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Largest supported dimension.
const MAXD: usize = 4;
/// Integer shift relative to the current fractional base point.
type Shift = [i64; MAXD];
/// A child index not yet resolved to a node.
const UNRESOLVED: u32 = u32::MAX;

/// A tiny multiplicative hasher for the packed `u128` memo keys (the default
/// SipHash is a measurable share of the run time here).
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(23) ^ x).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    fn write_u128(&mut self, x: u128) {
        self.write_u64(x as u64);
        self.write_u64((x >> 64) as u64);
        self.0 ^= self.0 >> 29;
    }
}

type Memo = HashMap<u128, Q, BuildHasherDefault<KeyHasher>>;

#[derive(Clone, Copy)]
struct Child {
    /// Index of the distinct direction removed.
    dir: usize,
    /// Mixed-radix code of the child multiplicity vector.
    code: u64,
    /// Node index once resolved, else [`UNRESOLVED`].
    node: u32,
}

/// One sub-multiset of Xi (a multiplicity vector over the distinct directions).
struct Node {
    mult: Vec<u32>,
    /// Number of columns.
    m: usize,
    /// B^-1 = adj / den with den = |det B| > 0 (rows of adj, integers).
    adj: Vec<Shift>,
    den: i64,
    /// B^-1 in rationals (for t at the base point).
    binv: Vec<QVec>,
    /// 1 / |det B| (the base-case value).
    inv_det: Q,
    /// Zonotope bounds lo <= n.x <= hi for each oracle normal n.
    lo: Vec<i64>,
    hi: Vec<i64>,
    /// Children that still span (the others are dropped terms).
    children: Vec<Child>,
    /// For each child, the position of its direction in `basis`, if any.
    child_basis_pos: Vec<Option<usize>>,
}

/// Independent box-spline evaluator: de Boor's recurrence, exact, memoised.
pub struct Oracle {
    dim: usize,
    /// Distinct directions, padded to MAXD with zeros (their multiplicities
    /// are the root node's `mult`).
    dirs: Vec<Shift>,
    /// Mixed-radix strides of the multiplicity codes.
    stride: Vec<u64>,
    /// |det G|.
    det_g: i64,
    /// c = (1/2) sum xi.
    center: QVec,
    lattice: Lattice,
    /// Bounding box of the full support (non-centred): lo_i <= x_i <= hi_i.
    box_lo: IVec,
    box_hi: IVec,
    /// Knot-plane normals of the filter plus the coordinate axes.
    normals: Vec<Shift>,
    nodes: Vec<Node>,
    node_of_code: HashMap<u64, u32>,
    root: u32,
    /// Current fractional base point (None before the first evaluation).
    base: Option<QVec>,
    /// floor(n.base) per normal, and whether n.base is an integer.
    n_floor: Vec<i64>,
    n_int: Vec<bool>,
    /// B^-1 base per node, for the current base.
    t0: Vec<Option<QVec>>,
    memo: Memo,
    /// Statistics: recursive calls that reached the memo lookup.
    visits: u64,
}

fn pad(v: &[i64]) -> Shift {
    let mut out = [0i64; MAXD];
    out[..v.len()].copy_from_slice(v);
    out
}

fn dot_s(a: &Shift, b: &Shift) -> i64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

fn pack(node: u32, sh: &Shift) -> u128 {
    let mut k = node as u128;
    for (i, &x) in sh.iter().enumerate() {
        assert!(x.abs() < 1 << 23, "shift out of the oracle's packed-key range");
        k |= (((x + (1 << 23)) as u128) & 0xFF_FFFF) << (32 + 24 * i);
    }
    k
}

impl Oracle {
    /// The oracle for a filter's directions and lattice.
    ///
    /// # Panics
    ///
    /// Outside dimensions 1..=4, or if the number of sub-multisets of the
    /// directions (prod of multiplicity + 1) exceeds u64.
    pub fn new(filter: &Filter) -> Oracle {
        let dim = filter.dim();
        assert!((1..=MAXD).contains(&dim), "oracle supports dimensions 1..=4");
        let mut distinct: Vec<IVec> = Vec::new();
        let mut mult: Vec<u32> = Vec::new();
        for d in &filter.directions {
            match distinct.iter().position(|e| e == d) {
                Some(k) => mult[k] += 1,
                None => {
                    distinct.push(d.clone());
                    mult.push(1);
                }
            }
        }
        let mut stride = Vec::with_capacity(mult.len());
        let mut acc: u64 = 1;
        for &mk in &mult {
            stride.push(acc);
            acc = acc
                .checked_mul(mk as u64 + 1)
                .expect("the sub-multisets number at most u64::MAX (the precondition of Oracle::new)");
        }
        let mut center = vec![Q::zero(); dim];
        for d in &filter.directions {
            for (c, &x) in center.iter_mut().zip(d) {
                *c += Q::frac(x, 2);
            }
        }
        let box_lo: IVec = (0..dim).map(|i| filter.directions.iter().map(|d| d[i].min(0)).sum()).collect();
        let box_hi: IVec = (0..dim).map(|i| filter.directions.iter().map(|d| d[i].max(0)).sum()).collect();
        // Knot-plane normals: one per linearly independent (s-1)-subset of
        // distinct directions, plus the axes (cheap bounding-box tests).
        let mut normals: Vec<IVec> = Vec::new();
        let mut push = |n: IVec| {
            if !normals.contains(&n) {
                normals.push(n);
            }
        };
        for i in 0..dim {
            let mut e = vec![0i64; dim];
            e[i] = 1;
            push(e);
        }
        let mut subset: Vec<usize> = Vec::new();
        fn rec(start: usize, k: usize, n: usize, cur: &mut Vec<usize>, f: &mut dyn FnMut(&[usize])) {
            if cur.len() == k {
                f(cur);
                return;
            }
            for i in start..n {
                cur.push(i);
                rec(i + 1, k, n, cur, f);
                cur.pop();
            }
        }
        if dim == 1 {
            // No knot-plane normals beyond the axis.
        } else {
            rec(0, dim - 1, distinct.len(), &mut subset, &mut |s: &[usize]| {
                let vs: Vec<&[i64]> = s.iter().map(|&k| distinct[k].as_slice()).collect();
                if let Some(n) = primitive_normal(&vs, dim) {
                    push(n);
                }
            });
        }
        let mut o = Oracle {
            dim,
            dirs: distinct.iter().map(|d| pad(d)).collect(),
            stride,
            det_g: filter.lattice.det(),
            center,
            lattice: filter.lattice.clone(),
            box_lo,
            box_hi,
            n_floor: vec![0; normals.len()],
            n_int: vec![false; normals.len()],
            normals: normals.iter().map(|n| pad(n)).collect(),
            nodes: Vec::new(),
            node_of_code: HashMap::new(),
            root: 0,
            base: None,
            t0: Vec::new(),
            memo: Memo::default(),
            visits: 0,
        };
        o.root = o.node_for(&mult);
        o
    }

    fn code_of(&self, mult: &[u32]) -> u64 {
        mult.iter().zip(&self.stride).map(|(&m, &s)| m as u64 * s).sum()
    }

    fn spans(&self, mult: &[u32]) -> bool {
        let present: Vec<IVec> =
            (0..mult.len()).filter(|&k| mult[k] > 0).map(|k| self.dirs[k][..self.dim].to_vec()).collect();
        rank_of_vectors(&present) == self.dim
    }

    /// The node of a spanning multiplicity vector, created on first use.
    fn node_for(&mut self, mult: &[u32]) -> u32 {
        let code = self.code_of(mult);
        if let Some(&i) = self.node_of_code.get(&code) {
            return i;
        }
        let s = self.dim;
        debug_assert!(self.spans(mult));
        // Greedy basis among the present distinct directions.
        let mut basis: Vec<usize> = Vec::new();
        let mut vecs: Vec<IVec> = Vec::new();
        for (k, &mk) in mult.iter().enumerate() {
            if mk == 0 || basis.len() == s {
                continue;
            }
            vecs.push(self.dirs[k][..s].to_vec());
            if rank_of_vectors(&vecs) == vecs.len() {
                basis.push(k);
            } else {
                vecs.pop();
            }
        }
        assert_eq!(basis.len(), s, "node does not span");
        // Row-major B (columns are the basis directions), then B^-1.
        let b: Vec<QVec> = (0..s).map(|i| basis.iter().map(|&k| Q::int(self.dirs[k][i])).collect()).collect();
        let binv = inverse(&b).expect("the greedy basis has s independent directions, so B is invertible");
        let det = crate::math::linalg::det(&b)
            .abs()
            .to_i64()
            .expect("det B is an integer of at most 4! * 64^4: directions are within ±64 (Filter::new)");
        let adj: Vec<Shift> = binv
            .iter()
            .map(|row| {
                let r: IVec = row
                    .iter()
                    .map(|x| {
                        (x * &Q::int(det))
                            .to_i64()
                            .expect("det B * B^-1 is the adjugate, an integer matrix of minors of B")
                    })
                    .collect();
                pad(&r)
            })
            .collect();
        let lo = self
            .normals
            .iter()
            .map(|n| (0..mult.len()).map(|k| mult[k] as i64 * dot_s(n, &self.dirs[k]).min(0)).sum())
            .collect();
        let hi = self
            .normals
            .iter()
            .map(|n| (0..mult.len()).map(|k| mult[k] as i64 * dot_s(n, &self.dirs[k]).max(0)).sum())
            .collect();
        let m: usize = mult.iter().map(|&x| x as usize).sum();
        let mut children = Vec::new();
        let mut child_basis_pos = Vec::new();
        if m > s {
            for k in 0..mult.len() {
                if mult[k] == 0 {
                    continue;
                }
                let mut cm = mult.to_vec();
                cm[k] -= 1;
                if cm[k] == 0 && !self.spans(&cm) {
                    continue; // M of a non-spanning set vanishes off the knot planes
                }
                children.push(Child { dir: k, code: code - self.stride[k], node: UNRESOLVED });
                child_basis_pos.push(basis.iter().position(|&bk| bk == k));
            }
        }
        let node = Node {
            mult: mult.to_vec(),
            m,
            adj,
            den: det,
            binv,
            inv_det: Q::frac(1, det),
            lo,
            hi,
            children,
            child_basis_pos,
        };
        let idx = self.nodes.len() as u32;
        self.nodes.push(node);
        self.t0.push(None);
        self.node_of_code.insert(code, idx);
        idx
    }

    fn child_node(&mut self, node: u32, c: usize) -> u32 {
        let ch = self.nodes[node as usize].children[c];
        if ch.node != UNRESOLVED {
            return ch.node;
        }
        let idx = match self.node_of_code.get(&ch.code) {
            Some(&i) => i,
            None => {
                let mut cm = self.nodes[node as usize].mult.clone();
                cm[ch.dir] -= 1;
                self.node_for(&cm)
            }
        };
        self.nodes[node as usize].children[c].node = idx;
        idx
    }

    /// Makes `p` the current point: sets the fractional base (resetting the
    /// memo if it changed) and returns the integer shift floor(p).
    fn set_point(&mut self, p: &[Q]) -> Shift {
        assert_eq!(p.len(), self.dim, "point dimension");
        let fl: IVec = p
            .iter()
            .map(|x| {
                x.floor_i64().expect("the point is within the i64 range (the precondition of box_spline, phi, weights)")
            })
            .collect();
        let base: QVec = p.iter().zip(&fl).map(|(x, &f)| x - &Q::int(f)).collect();
        if self.base.as_ref() != Some(&base) {
            self.memo.clear();
            self.t0.iter_mut().for_each(|t| *t = None);
            for (i, n) in self.normals.iter().enumerate() {
                let v = dot_iq(&n[..self.dim], &base);
                self.n_floor[i] =
                    v.floor_i64().expect("the base lies in [0,1)^s and the normals are small, so |n.base| < sum |n_i|");
                self.n_int[i] = v.is_integer();
            }
            self.base = Some(base);
        }
        pad(&fl)
    }

    /// Exact zonotope membership (closed) of base + sh for a node.
    fn outside(&self, node: &Node, sh: &Shift) -> bool {
        for (i, n) in self.normals.iter().enumerate() {
            let v = self.n_floor[i] + dot_s(n, sh);
            // n.x = v + f with 0 <= f < 1 (f = 0 iff n_int).
            if v < node.lo[i] || v > node.hi[i] || (v == node.hi[i] && !self.n_int[i]) {
                return true;
            }
        }
        false
    }

    /// t = B^-1 (base + sh) for a node's basis.
    fn t_at(&mut self, idx: u32, sh: &Shift) -> QVec {
        let s = self.dim;
        if self.t0[idx as usize].is_none() {
            let base = self.base.as_ref().expect("eval runs after set_point, which sets the base");
            let t0 = self.nodes[idx as usize].binv.iter().map(|row| crate::math::linalg::dot_q(row, base)).collect();
            self.t0[idx as usize] = Some(t0);
        }
        let node = &self.nodes[idx as usize];
        let t0 = self.t0[idx as usize].as_ref().expect("t0 was filled just above");
        (0..s)
            .map(|r| {
                let a = dot_s(&node.adj[r], sh);
                if a == 0 {
                    t0[r].clone()
                } else {
                    &t0[r] + &Q::frac(a, node.den)
                }
            })
            .collect()
    }

    /// M_node(base + sh).
    fn eval(&mut self, idx: u32, sh: &Shift) -> Q {
        if self.outside(&self.nodes[idx as usize], sh) {
            return Q::zero();
        }
        let key = pack(idx, sh);
        if let Some(v) = self.memo.get(&key) {
            return v.clone();
        }
        self.visits += 1;
        let t = self.t_at(idx, sh);
        let (m, value) = {
            let node = &self.nodes[idx as usize];
            (node.m, if node.m == self.dim { Some(node.inv_det.clone()) } else { None })
        };
        let value = if let Some(inv_det) = value {
            if t.iter().all(|ti| !ti.is_negative() && *ti < Q::one()) {
                inv_det
            } else {
                Q::zero()
            }
        } else {
            let mut acc = Q::zero();
            let nch = self.nodes[idx as usize].children.len();
            for c in 0..nch {
                let child = self.child_node(idx, c);
                let node = &self.nodes[idx as usize];
                let k = node.children[c].dir;
                let mu = node.mult[k] as i64;
                let pos = node.child_basis_pos[c];
                let d = self.dirs[k];
                let shifted: Shift = [sh[0] - d[0], sh[1] - d[1], sh[2] - d[2], sh[3] - d[3]];
                let behind = self.eval(child, &shifted);
                match pos {
                    Some(p) => {
                        let here = self.eval(child, sh);
                        if !here.is_zero() {
                            acc += &t[p] * &here;
                        }
                        if !behind.is_zero() {
                            acc += &(&Q::int(mu) - &t[p]) * &behind;
                        }
                    }
                    None => {
                        if !behind.is_zero() {
                            acc += &Q::int(mu) * &behind;
                        }
                    }
                }
            }
            acc / Q::int((m - self.dim) as i64)
        };
        self.memo.insert(key, value.clone());
        value
    }

    /// Non-centred M_Xi(x) (integral 1, support Xi[0,1)^s), valid at points off all knot planes.
    ///
    /// # Panics
    ///
    /// If a coordinate of `x` is beyond the i64 range.
    pub fn box_spline(&mut self, x: &[Q]) -> Q {
        let sh = self.set_point(x);
        self.eval(self.root, &sh)
    }

    /// Centred, lattice-normalised phi(x) = |det G| * M_Xi(x + c), c = (1/2) sum xi.
    pub fn phi(&mut self, x: &[Q]) -> Q {
        let p: QVec = x.iter().zip(&self.center).map(|(a, b)| a + b).collect();
        Q::int(self.det_g) * self.box_spline(&p)
    }

    /// The non-zero weights phi(x - j) over the lattice points j (each j
    /// once, in lexicographic order). Off the knot planes these are exactly
    /// the j whose shifted support contains x in its interior.
    ///
    /// # Panics
    ///
    /// If a coordinate of `x` plus the support box leaves the i64 range.
    pub fn weights(&mut self, x: &[Q]) -> Vec<(IVec, Q)> {
        let s = self.dim;
        let p: QVec = x.iter().zip(&self.center).map(|(a, b)| a + b).collect();
        let sh = self.set_point(&p);
        // phi(x - j) = |det G| M(p - j) != 0 needs box_lo <= p - j <= box_hi.
        const BOX: &str = "p - j stays within the i64 range over the support box (the precondition of weights)";
        let lo: IVec = (0..s).map(|i| (&p[i] - &Q::int(self.box_hi[i])).floor_i64().expect(BOX)).collect();
        let hi: IVec = (0..s).map(|i| (&p[i] - &Q::int(self.box_lo[i])).floor_i64().expect(BOX) + 1).collect();
        let mut out = Vec::new();
        let mut j = lo.clone();
        let g = Q::int(self.det_g);
        'outer: loop {
            if self.lattice.contains(&j) {
                let jj = pad(&j);
                let shift: Shift = [sh[0] - jj[0], sh[1] - jj[1], sh[2] - jj[2], sh[3] - jj[3]];
                let v = self.eval(self.root, &shift);
                if !v.is_zero() {
                    out.push((j.clone(), &g * &v));
                }
            }
            for i in (0..s).rev() {
                if j[i] < hi[i] {
                    j[i] += 1;
                    continue 'outer;
                }
                j[i] = lo[i];
            }
            break;
        }
        out
    }

    /// The spline value sum_{j in L} data(j) * phi(x - j) (j over all lattice
    /// points whose shifted support contains x; `data` is called only where
    /// phi(x - j) is non-zero).
    pub fn spline_value(&mut self, x: &[Q], data: &dyn Fn(&[i64]) -> Q) -> Q {
        let mut acc = Q::zero();
        for (j, w) in self.weights(x) {
            acc += &(data(&j) * w);
        }
        acc
    }

    /// The centre c = (1/2) sum xi.
    pub fn center(&self) -> &[Q] {
        &self.center
    }

    /// Number of sub-multiset nodes created and of memo misses so far
    /// (diagnostics for tests and timing reports).
    pub fn stats(&self) -> (usize, u64) {
        (self.nodes.len(), self.visits)
    }
}

#[cfg(test)]
mod tests;
