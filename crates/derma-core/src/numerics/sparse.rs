//! Sparse symmetric positive definite systems (Laplacians, screened Poisson problems, mesh
//! parameterisation, registration): derma's own sparse Cholesky P A Pᵀ = L Lᵀ, column by column
//! in a nested-dissection order (George & Liu, "Computer Solution of Large Sparse Positive
//! Definite Systems", 1981, ch. 5 and 8), factorised once and solved for many right-hand sides;
//! where one pattern is refactorised many times, its ordering and the pattern of L are found once.

use super::NumericsError;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::Arc;

/// An absent index in the linked lists and marks below.
const NONE: u32 = u32::MAX;

/// What does not depend on the values: the order, the pattern of L and where each stored entry
/// of A lands in it.
struct Symbolic {
    n: usize,
    /// perm[i]: the original index of row i of P A Pᵀ.
    perm: Vec<u32>,
    /// Supernodes: runs of consecutive columns of L with the same rows below them (George & Liu
    /// §5.4.3), each kept as a dense column-major block of `rows × width` values. Supernode k
    /// holds columns `first[k]..first[k + 1]`, its rows are `rows[row_ptr[k]..row_ptr[k + 1]]`
    /// (ascending, its own columns first) and its block starts at `value_ptr[k]`.
    first: Vec<usize>,
    row_ptr: Vec<usize>,
    rows: Vec<u32>,
    value_ptr: Vec<usize>,
    /// The supernode of each column.
    supernode_of: Vec<u32>,
    /// Entries of L below and on the diagonal (the fill).
    fill: usize,
    /// For each stored entry of A (in its pattern's order), the entry of L it is added to.
    a_to_l: Vec<usize>,
}

impl Symbolic {
    /// Orders the graph of the lower pattern (`col_ptr`, `row_idx`: each column's rows
    /// ascending, the diagonal among them) by nested dissection with minimum-degree leaves and
    /// records L's pattern on the way.
    /// `Effort::Refactorised`: the pattern will be factorised many times, so both orders of
    /// [`fill_reducing_orders`] are tried and the one with less fill is kept.
    fn analyse(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        effort: Effort,
    ) -> Result<Self, NumericsError> {
        if u32::try_from(n).is_err() {
            return Err(NumericsError::Shape {
                what: "sparse pattern",
                detail: format!("{n} unknowns (at most {} supported)", u32::MAX),
            });
        }
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                if r != c {
                    adj[r].push(c as u32);
                    adj[c].push(r as u32);
                }
            }
        }
        for a in &mut adj {
            a.sort_unstable();
            a.dedup();
        }
        let inverse_of = |perm: &[u32]| {
            let mut inverse = vec![0u32; n];
            for (new, &old) in perm.iter().enumerate() {
                inverse[old as usize] = new as u32;
            }
            inverse
        };
        // The supervariables once, ordered once or twice.
        let leaves: &[usize] = match effort {
            Effort::Once => &[LEAF],
            Effort::Refactorised => &[LEAF, usize::MAX],
        };
        let mut orders = fill_reducing_orders(&adj, leaves).into_iter();
        let mut perm = orders.next().expect("one order per leaf size");
        let mut inverse = inverse_of(&perm);
        let (mut l_ptr, mut l_row) = pattern_of_l(n, col_ptr, row_idx, &inverse);
        if let Some(md) = orders.next() {
            // Minimum degree on the whole graph (no dissection): slower to find, sometimes
            // much less fill on graphs that are not flat meshes (the registration's).
            let md_inverse = inverse_of(&md);
            let (p2, r2) = pattern_of_l(n, col_ptr, row_idx, &md_inverse);
            if r2.len() < l_row.len() {
                (perm, inverse, l_ptr, l_row) = (md, md_inverse, p2, r2);
            }
        }
        drop(adj);
        // Column j joins the supernode of j − 1 when j is j − 1's parent and has its rows.
        let (mut first, mut row_ptr, mut rows, mut value_ptr) =
            (Vec::new(), vec![0], Vec::new(), vec![0]);
        let mut supernode_of = vec![0u32; n];
        let count = |j: usize| l_ptr[j + 1] - l_ptr[j];
        for j in 0..n {
            let joins = j > 0
                && count(j - 1) == count(j) + 1
                && l_row.get(l_ptr[j - 1] + 1) == Some(&(j as u32));
            if !joins {
                if !first.is_empty() {
                    let (k, m) = (
                        first.len() - 1,
                        row_ptr[first.len()] - row_ptr[first.len() - 1],
                    );
                    value_ptr.push(value_ptr[k] + m * (j - first[k]));
                }
                first.push(j);
                rows.extend_from_slice(&l_row[l_ptr[j]..l_ptr[j + 1]]);
                row_ptr.push(rows.len());
            }
            supernode_of[j] = (first.len() - 1) as u32;
        }
        if let Some(&f) = first.last() {
            let k = first.len() - 1;
            value_ptr.push(value_ptr[k] + (row_ptr[k + 1] - row_ptr[k]) * (n - f));
        }
        first.push(n);
        let fill = l_row.len();
        drop((l_ptr, l_row));
        let mut symbolic = Self {
            n,
            perm,
            first,
            row_ptr,
            rows,
            value_ptr,
            supernode_of,
            fill,
            a_to_l: Vec::new(),
        };
        let mut a_to_l = Vec::with_capacity(row_idx.len());
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                let (pr, pc) = (inverse[r], inverse[c]);
                let (row, col) = (pr.max(pc), pr.min(pc) as usize);
                a_to_l.push(symbolic.slot(row, col));
            }
        }
        symbolic.a_to_l = a_to_l;
        Ok(symbolic)
    }

    /// Where entry (row, col) of L (new order, row ≥ col, in its pattern) is stored.
    fn slot(&self, row: u32, col: usize) -> usize {
        let k = self.supernode_of[col] as usize;
        let rows = &self.rows[self.row_ptr[k]..self.row_ptr[k + 1]];
        let at = rows
            .binary_search(&row)
            .expect("an entry of A lies in the pattern of L");
        self.value_ptr[k] + (col - self.first[k]) * rows.len() + at
    }

    /// The numeric factorisation of A with `values` in its pattern's order: left-looking by
    /// supernodes (Ng & Peyton 1993). Each supernode gathers the updates of the earlier ones
    /// with rows among its columns (found through linked lists, George & Liu §5.5.2) as dense
    /// products, then factorises its own dense panel. The same operations in the same order at
    /// any thread count.
    fn factor(&self, values: &[f64]) -> Result<Vec<f64>, NumericsError> {
        let supernodes = self.first.len() - 1;
        let mut lv = vec![0.0; *self.value_ptr.last().unwrap_or(&0)];
        for (&slot, v) in self.a_to_l.iter().zip(values) {
            lv[slot] += v;
        }
        // head[k]: the first supernode waiting to update supernode k; next chains them; at[d]:
        // the index in d's rows of the first row it has yet to update.
        let mut head = vec![NONE; supernodes];
        let mut next = vec![NONE; supernodes];
        let mut at = vec![0usize; supernodes];
        let mut product: Vec<f64> = Vec::new();
        let mut position = vec![0usize; self.n];
        for k in 0..supernodes {
            let (f, l) = (self.first[k], self.first[k + 1]);
            let rows_k = &self.rows[self.row_ptr[k]..self.row_ptr[k + 1]];
            let mk = rows_k.len();
            for (i, &r) in rows_k.iter().enumerate() {
                position[r as usize] = i;
            }
            let (before, rest) = lv.split_at_mut(self.value_ptr[k]);
            let block = &mut rest[..mk * (l - f)];
            let mut d = std::mem::replace(&mut head[k], NONE);
            while d != NONE {
                let du = d as usize;
                let following = next[du];
                let rows_d = &self.rows[self.row_ptr[du]..self.row_ptr[du + 1]];
                let (md, wd) = (rows_d.len(), self.first[du + 1] - self.first[du]);
                let ld = &before[self.value_ptr[du]..self.value_ptr[du] + md * wd];
                let p0 = at[du];
                let p1 = p0 + rows_d[p0..].partition_point(|&r| (r as usize) < l);
                // product[:, c] = L_d[p0.., :] · L_d[p0 + c, :]ᵀ for the target columns c.
                let (tall, wide) = (md - p0, p1 - p0);
                product.clear();
                product.resize(tall * wide, 0.0);
                for c in 0..wide {
                    let out = &mut product[c * tall + c..(c + 1) * tall];
                    let column = |s: usize| &ld[s * md + p0 + c..(s + 1) * md];
                    multiply_add(out, wd, column, 1.0);
                }
                for c in 0..wide {
                    let target = (rows_d[p0 + c] as usize - f) * mk;
                    for i in c..tall {
                        block[target + position[rows_d[p0 + i] as usize]] -= product[c * tall + i];
                    }
                }
                if p1 < md {
                    at[du] = p1;
                    let t = self.supernode_of[rows_d[p1] as usize] as usize;
                    next[du] = head[t];
                    head[t] = d;
                }
                d = following;
            }
            // The dense panel: Cholesky of the diagonal block and the rows below it.
            for j in 0..l - f {
                let (left, right) = block.split_at_mut(j * mk);
                let column = |s: usize| &left[s * mk + j..(s + 1) * mk];
                multiply_add(&mut right[j..mk], j, column, -1.0);
                let diag = block[j * mk + j];
                if !(diag > 0.0) {
                    return Err(NumericsError::NotPositiveDefinite {
                        what: "sparse Cholesky",
                        n: self.n,
                        column: self.perm[f + j] as usize,
                        pivot: diag,
                    });
                }
                let diag = diag.sqrt();
                block[j * mk + j] = diag;
                for x in &mut block[j * mk + j + 1..(j + 1) * mk] {
                    *x /= diag;
                }
            }
            let w = l - f;
            if mk > w {
                at[k] = w;
                let t = self.supernode_of[rows_k[w] as usize] as usize;
                next[k] = head[t];
                head[t] = k as u32;
            }
        }
        Ok(lv)
    }
}

/// out += sign · Σₛ column(s) · column(s)[0] for s < count: the dense kernel of the
/// factorisation (every column starts at the row of `out`'s first entry). Four columns a pass,
/// summed in a fixed order, so the result does not depend on the machine.
fn multiply_add<'a>(out: &mut [f64], count: usize, column: impl Fn(usize) -> &'a [f64], sign: f64) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2. The same multiplies and adds in the same order (no fused
        // multiply-add), four lanes wide: the same bits as the portable loop.
        unsafe { multiply_add_avx2(out, count, column, sign) };
        return;
    }
    multiply_add_portable(out, count, column, sign);
}

/// [`multiply_add`] compiled for AVX2 (wider vectors, the same arithmetic).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn multiply_add_avx2<'a>(
    out: &mut [f64],
    count: usize,
    column: impl Fn(usize) -> &'a [f64],
    sign: f64,
) {
    multiply_add_portable(out, count, column, sign);
}

#[inline(always)]
fn multiply_add_portable<'a>(
    out: &mut [f64],
    count: usize,
    column: impl Fn(usize) -> &'a [f64],
    sign: f64,
) {
    let mut s = 0;
    while s + 4 <= count {
        let (a, b, c, d) = (column(s), column(s + 1), column(s + 2), column(s + 3));
        let (ka, kb, kc, kd) = (sign * a[0], sign * b[0], sign * c[0], sign * d[0]);
        for ((((o, xa), xb), xc), xd) in out.iter_mut().zip(a).zip(b).zip(c).zip(d) {
            *o += (xa * ka + xb * kb) + (xc * kc + xd * kd);
        }
        s += 4;
    }
    for s in s..count {
        let a = column(s);
        let ka = sign * a[0];
        for (o, xa) in out.iter_mut().zip(a) {
            *o += xa * ka;
        }
    }
}

/// The pattern of L for P A Pᵀ (`inverse`: new index of each original one), column by column
/// in the new order: column j holds A's entries below the diagonal in column j and the rows of
/// every column whose elimination-tree parent is j (George & Liu §5.4; the parent of a column is
/// its first row below the diagonal). Cost in proportion to the entries of L.
fn pattern_of_l(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    inverse: &[u32],
) -> (Vec<usize>, Vec<u32>) {
    // A's lower triangle in the new order: rows below the diagonal of each new column.
    let mut a_cols: Vec<Vec<u32>> = vec![Vec::new(); n];
    for c in 0..n {
        for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
            let (pr, pc) = (inverse[r], inverse[c]);
            if pr != pc {
                a_cols[pr.min(pc) as usize].push(pr.max(pc));
            }
        }
    }
    let mut first_child = vec![NONE; n];
    let mut next_sibling = vec![NONE; n];
    let mut mark = vec![NONE; n];
    let mut l_ptr = Vec::with_capacity(n + 1);
    let mut l_row: Vec<u32> = Vec::new();
    let mut rows: Vec<u32> = Vec::new();
    l_ptr.push(0);
    for j in 0..n {
        rows.clear();
        mark[j] = j as u32;
        let mut take = |r: u32, rows: &mut Vec<u32>| {
            if mark[r as usize] != j as u32 {
                mark[r as usize] = j as u32;
                rows.push(r);
            }
        };
        for &r in &a_cols[j] {
            take(r, &mut rows);
        }
        let mut c = first_child[j];
        while c != NONE {
            let cu = c as usize;
            // The child's rows below its diagonal are all ≥ j (j is the first of them).
            for k in l_ptr[cu] + 1..l_ptr[cu + 1] {
                let r = l_row[k];
                if r != j as u32 {
                    take(r, &mut rows);
                }
            }
            c = next_sibling[cu];
        }
        rows.sort_unstable();
        l_row.push(j as u32);
        l_row.extend_from_slice(&rows);
        l_ptr.push(l_row.len());
        if let Some(&parent) = rows.first() {
            next_sibling[j] = first_child[parent as usize];
            first_child[parent as usize] = j as u32;
        }
    }
    (l_ptr, l_row)
}

/// The orders of [`nested_dissection`], one per leaf size in `leaves`, on the graph's
/// supervariables (found once): vertices with the same
/// neighbours and each other (the unknowns of one vertex of a mesh, such as the registration's
/// 4 × 4 blocks) are ordered as one and numbered consecutively, so no separator splits them and
/// the order costs a fraction (George & Liu §5.3, indistinguishable nodes).
fn fill_reducing_orders(adj: &[Vec<u32>], leaves: &[usize]) -> Vec<Vec<u32>> {
    let n = adj.len();
    let closed = |v: usize| {
        let a = &adj[v];
        let at = a.partition_point(|&u| u < v as u32);
        a[..at]
            .iter()
            .copied()
            .chain(std::iter::once(v as u32))
            .chain(a[at..].iter().copied())
    };
    // FNV-1a over each closed neighbourhood (the 64-bit offset basis and prime of Fowler, Noll
    // & Vo's FNV specification); equal hashes are compared in full.
    let hash = |v: usize| {
        closed(v).fold(0xcbf2_9ce4_8422_2325u64, |h, u| {
            (h ^ u as u64).wrapping_mul(0x0000_0100_0000_01b3)
        })
    };
    let hashes: Vec<u64> = (0..n).map(hash).collect();
    let mut by_hash: Vec<u32> = (0..n as u32).collect();
    by_hash.sort_unstable_by_key(|&v| (hashes[v as usize], adj[v as usize].len(), v));
    let mut group = vec![u32::MAX; n];
    let mut members: Vec<Vec<u32>> = Vec::new();
    let mut start = 0;
    while start < n {
        let key = |v: u32| (hashes[v as usize], adj[v as usize].len());
        let end = start
            + by_hash[start..]
                .iter()
                .take_while(|&&v| key(v) == key(by_hash[start]))
                .count();
        let mut reps: Vec<u32> = Vec::new();
        for &v in &by_hash[start..end] {
            let same = reps
                .iter()
                .copied()
                .find(|&r| closed(r as usize).eq(closed(v as usize)));
            match same {
                Some(r) => {
                    let g = group[r as usize];
                    group[v as usize] = g;
                    members[g as usize].push(v);
                }
                None => {
                    group[v as usize] = members.len() as u32;
                    members.push(vec![v]);
                    reps.push(v);
                }
            }
        }
        start = end;
    }
    // Groups numbered by their lowest member, so the quotient graph does not depend on hashes.
    let mut by_first: Vec<u32> = (0..members.len() as u32).collect();
    by_first.sort_unstable_by_key(|&g| members[g as usize].iter().min().copied());
    let mut renumber = vec![0u32; members.len()];
    for (new, &g) in by_first.iter().enumerate() {
        renumber[g as usize] = new as u32;
    }
    let quotient: Vec<Vec<u32>> = by_first
        .iter()
        .map(|&g| {
            let mut a: Vec<u32> = members[g as usize]
                .iter()
                .flat_map(|&v| adj[v as usize].iter())
                .map(|&u| renumber[group[u as usize] as usize])
                .filter(|&h| h != renumber[g as usize])
                .collect();
            a.sort_unstable();
            a.dedup();
            a
        })
        .collect();
    for m in &mut members {
        m.sort_unstable();
    }
    leaves
        .iter()
        .map(|&leaf| {
            let mut order = Vec::with_capacity(n);
            for q in nested_dissection(&quotient, leaf) {
                order.extend_from_slice(&members[by_first[q as usize] as usize]);
            }
            order
        })
        .collect()
}

/// Subgraphs at most this large are ordered by minimum degree instead of being dissected: small
/// enough that the explicit elimination graph stays cheap, large enough that minimum degree's
/// better fill on irregular graphs is kept (the registration's 4 125-vertex system: 6.3·10⁶
/// entries of L, against 7.9·10⁶ with leaves of 96).
const LEAF: usize = 2048;

/// How much a pattern's analysis may cost.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Effort {
    /// Factorised once: the quick order.
    Once,
    /// Factorised many times ([`SparsePattern`]): the better of two orders.
    Refactorised,
}

/// A fill-reducing order of a graph (sorted adjacency lists without self-loops) by nested
/// dissection (George 1973; George & Liu ch. 8): split each connected part at the middle level of
/// a breadth-first search from a pseudo-peripheral vertex, order both halves the same way, the
/// separating level last; parts of at most `leaf` vertices by minimum degree. For the mesh
/// Laplacians derma solves, the separators are ~√n, so L has O(n log n) entries, and the order
/// costs O(n log n). Deterministic: ties go to the lowest index.
fn nested_dissection(adj: &[Vec<u32>], leaf: usize) -> Vec<u32> {
    let n = adj.len();
    let mut d = Dissection {
        adj,
        part: vec![0; n],
        level: vec![0; n],
        parts: 1,
        order: Vec::with_capacity(n),
        leaf,
    };
    let all: Vec<u32> = (0..n as u32).collect();
    d.dissect(all, 0);
    d.order
}

/// The state of [`nested_dissection`]: each vertex's current part (a label; `u32::MAX` once
/// ordered) and breadth-first level.
struct Dissection<'a> {
    adj: &'a [Vec<u32>],
    part: Vec<u32>,
    level: Vec<u32>,
    parts: u32,
    order: Vec<u32>,
    /// Parts at most this large are ordered by minimum degree.
    leaf: usize,
}

impl Dissection<'_> {
    const ORDERED: u32 = u32::MAX;

    /// A new part label for `nodes`.
    fn relabel(&mut self, nodes: &[u32]) -> u32 {
        let label = self.parts;
        self.parts += 1;
        for &v in nodes {
            self.part[v as usize] = label;
        }
        label
    }

    /// Breadth-first levels from `root` within part `label`; returns the vertices reached in
    /// visiting order (levels ascending) and the number of levels.
    fn levels(&mut self, root: u32, label: u32) -> (Vec<u32>, u32) {
        let mut seen = vec![root];
        self.level[root as usize] = 0;
        // Mark visited by moving them to a scratch label, restored below.
        let scratch = self.parts;
        self.part[root as usize] = scratch;
        let mut head = 0;
        while head < seen.len() {
            let v = seen[head];
            head += 1;
            let lv = self.level[v as usize];
            for &u in &self.adj[v as usize] {
                if self.part[u as usize] == label {
                    self.part[u as usize] = scratch;
                    self.level[u as usize] = lv + 1;
                    seen.push(u);
                }
            }
        }
        for &v in &seen {
            self.part[v as usize] = label;
        }
        let depth = self.level[*seen.last().expect("the root") as usize] + 1;
        (seen, depth)
    }

    fn dissect(&mut self, nodes: Vec<u32>, label: u32) {
        if nodes.len() <= self.leaf {
            self.leaf(&nodes);
            return;
        }
        // Each connected component on its own.
        let mut components = Vec::new();
        for &v in &nodes {
            if self.part[v as usize] == label {
                let (reached, _) = self.levels(v, label);
                let l = self.relabel(&reached);
                components.push((reached, l));
            }
        }
        if components.len() > 1 {
            for (c, l) in components {
                self.dissect(c, l);
            }
            return;
        }
        let (nodes, label) = components.pop().expect("a part is not empty");
        // A pseudo-peripheral root: restart from the last level's lowest-degree vertex while the
        // search gets deeper (George & Liu 1979), at most four times (the depth rarely grows after
        // two; each restart is one more breadth-first search of the part).
        let (mut seen, mut depth) = self.levels(nodes[0], label);
        for _ in 0..4 {
            let last = seen
                .iter()
                .copied()
                .filter(|&v| self.level[v as usize] == depth - 1)
                .min_by_key(|&v| (self.adj[v as usize].len(), v))
                .expect("the last level is not empty");
            let (s2, d2) = self.levels(last, label);
            // `level` now holds the search from `last`: its visiting order goes with it.
            let deeper = d2 > depth;
            (seen, depth) = (s2, d2);
            if !deeper {
                break;
            }
        }
        if depth < 3 {
            // No level splits it (a clique-like part): minimum degree orders it whole.
            self.leaf(&nodes);
            return;
        }
        // The middle level by count; vertices of it with no neighbour beyond it join the near half.
        let half = seen.len() / 2;
        let mid = self.level[seen[half] as usize].clamp(1, depth - 2);
        let (mut near, mut far, mut separator) = (Vec::new(), Vec::new(), Vec::new());
        for &v in &seen {
            let l = self.level[v as usize];
            if l < mid {
                near.push(v);
            } else if l > mid {
                far.push(v);
            } else if self.adj[v as usize]
                .iter()
                .any(|&u| self.part[u as usize] == label && self.level[u as usize] > mid)
            {
                separator.push(v);
            } else {
                near.push(v);
            }
        }
        for &v in &separator {
            self.part[v as usize] = Self::ORDERED;
        }
        let (near_label, far_label) = (self.relabel(&near), self.relabel(&far));
        self.dissect(near, near_label);
        self.dissect(far, far_label);
        self.order.extend_from_slice(&separator);
    }

    /// Orders a small part by minimum degree on its own subgraph.
    fn leaf(&mut self, nodes: &[u32]) {
        let mut local = std::collections::HashMap::with_capacity(nodes.len());
        for (i, &v) in nodes.iter().enumerate() {
            local.insert(v, i as u32);
        }
        let sub: Vec<Vec<u32>> = nodes
            .iter()
            .map(|&v| {
                let mut a: Vec<u32> = self.adj[v as usize]
                    .iter()
                    .filter_map(|u| local.get(u).copied())
                    .collect();
                a.sort_unstable();
                a
            })
            .collect();
        for i in minimum_degree(sub) {
            let v = nodes[i as usize];
            self.part[v as usize] = Self::ORDERED;
            self.order.push(v);
        }
    }
}

/// The minimum-degree order of a small graph (sorted adjacency lists without self-loops):
/// repeatedly eliminate the vertex of least degree (ties to the lowest index), joining its
/// neighbours into a clique (Rose 1972; George & Liu §5.1).
fn minimum_degree(mut adj: Vec<Vec<u32>>) -> Vec<u32> {
    let n = adj.len();
    let mut done = vec![false; n];
    let mut heap: BinaryHeap<Reverse<(u32, u32)>> = (0..n)
        .map(|v| Reverse((adj[v].len() as u32, v as u32)))
        .collect();
    let mut order = Vec::with_capacity(n);
    let mut merged = Vec::new();
    while let Some(Reverse((degree, v))) = heap.pop() {
        let vu = v as usize;
        if done[vu] || adj[vu].len() as u32 != degree {
            continue;
        }
        done[vu] = true;
        let clique = std::mem::take(&mut adj[vu]);
        for &u in &clique {
            // adj[u] ← (adj[u] ∪ clique) ∖ {u, v}, both sorted.
            let own = &adj[u as usize];
            merged.clear();
            let (mut i, mut k) = (0, 0);
            while i < own.len() || k < clique.len() {
                let x = match (own.get(i), clique.get(k)) {
                    (Some(&a), Some(&b)) if a == b => {
                        i += 1;
                        k += 1;
                        a
                    }
                    (Some(&a), Some(&b)) if a < b => {
                        i += 1;
                        a
                    }
                    (Some(&a), None) => {
                        i += 1;
                        a
                    }
                    (_, Some(&b)) => {
                        k += 1;
                        b
                    }
                    (None, None) => unreachable!(),
                };
                if x != u && x != v {
                    merged.push(x);
                }
            }
            std::mem::swap(&mut adj[u as usize], &mut merged);
            heap.push(Reverse((adj[u as usize].len() as u32, u)));
        }
        order.push(v);
    }
    order
}

/// A factorised sparse symmetric positive definite matrix.
pub struct SparseCholesky {
    symbolic: Arc<Symbolic>,
    values: Vec<f64>,
}

impl SparseCholesky {
    /// Factorises the n × n matrix given by (row, column, value) entries of its lower triangle
    /// (entries above the diagonal are ignored; repeated entries are summed).
    pub fn new(n: usize, entries: &[(usize, usize, f64)]) -> Result<Self, NumericsError> {
        if let Some(&(r, c, _)) = entries.iter().find(|(r, c, _)| *r >= n || *c >= n) {
            return Err(NumericsError::Shape {
                what: "sparse Cholesky",
                detail: format!("entry ({r}, {c}) outside a {n} × {n} matrix"),
            });
        }
        let pairs: Vec<(usize, usize)> = entries.iter().map(|&(r, c, _)| (r, c)).collect();
        let pattern = SparsePattern::analysed(n, &pairs, Effort::Once)?;
        let mut values = vec![0.0; pattern.len()];
        for &(r, c, v) in entries.iter().filter(|(r, c, _)| r >= c) {
            values[pattern
                .slot(r, c)
                .expect("every entry is in its own pattern")] += v;
        }
        pattern.factor(&values)
    }

    fn check(&self, len: usize) -> Result<(), NumericsError> {
        let n = self.symbolic.n;
        if len != n {
            return Err(NumericsError::Shape {
                what: "sparse Cholesky solve",
                detail: format!("right-hand side of {len} for a {n} × {n} matrix"),
            });
        }
        Ok(())
    }

    /// Solves A X = B in place for K right-hand sides stored row by row: P b, one pass of
    /// L y = P b and one of Lᵀ z = y for all K columns together, then Pᵀ z.
    fn solve_rows<const K: usize>(&self, b: &mut [[f64; K]]) {
        let s = &*self.symbolic;
        let mut y: Vec<[f64; K]> = s.perm.iter().map(|&i| b[i as usize]).collect();
        // Each supernode's rows gathered once into a dense vector, its columns applied there,
        // and scattered back: the same operations in the same order as column by column.
        let mut local: Vec<[f64; K]> = Vec::new();
        let supernodes = s.first.len() - 1;
        let block = |k: usize| {
            let rows = &s.rows[s.row_ptr[k]..s.row_ptr[k + 1]];
            let w = s.first[k + 1] - s.first[k];
            (
                rows,
                w,
                &self.values[s.value_ptr[k]..s.value_ptr[k] + rows.len() * w],
            )
        };
        for k in 0..supernodes {
            let (rows, w, l) = block(k);
            let m = rows.len();
            local.clear();
            local.extend(rows.iter().map(|&r| y[r as usize]));
            for j in 0..w {
                let col = &l[j * m..(j + 1) * m];
                let yj = local[j].map(|x| x / col[j]);
                local[j] = yj;
                for (v, x) in col[j + 1..].iter().zip(&mut local[j + 1..]) {
                    for c in 0..K {
                        x[c] -= v * yj[c];
                    }
                }
            }
            for (&r, x) in rows.iter().zip(&local) {
                y[r as usize] = *x;
            }
        }
        for k in (0..supernodes).rev() {
            let (rows, w, l) = block(k);
            let m = rows.len();
            local.clear();
            local.extend(rows.iter().map(|&r| y[r as usize]));
            for j in (0..w).rev() {
                let col = &l[j * m..(j + 1) * m];
                let mut acc = local[j];
                for (v, x) in col[j + 1..].iter().zip(&local[j + 1..]) {
                    for c in 0..K {
                        acc[c] -= v * x[c];
                    }
                }
                local[j] = acc.map(|x| x / col[j]);
            }
            for (&r, x) in rows[..w].iter().zip(&local) {
                y[r as usize] = *x;
            }
        }
        for (&i, z) in s.perm.iter().zip(&y) {
            b[i as usize] = *z;
        }
    }

    /// The solutions of A X = B for several right-hand sides (up to four per pass over L).
    pub fn solve_many(&self, b: &[&[f64]]) -> Result<Vec<Vec<f64>>, NumericsError> {
        for c in b {
            self.check(c.len())?;
        }
        let n = self.symbolic.n;
        let mut out = Vec::with_capacity(b.len());
        // Four right-hand sides a pass: one f64x4 row each, as the factor's kernel takes four
        // columns a pass.
        for chunk in b.chunks(4) {
            let mut rows: Vec<[f64; 4]> = (0..n)
                .map(|i| std::array::from_fn(|c| chunk.get(c).map_or(0.0, |col| col[i])))
                .collect();
            self.solve_rows(&mut rows);
            for c in 0..chunk.len() {
                out.push(rows.iter().map(|r| r[c]).collect());
            }
        }
        Ok(out)
    }

    /// The solution x of A x = b.
    pub fn solve(&self, b: &[f64]) -> Result<Vec<f64>, NumericsError> {
        self.check(b.len())?;
        let mut rows: Vec<[f64; 1]> = b.iter().map(|&x| [x]).collect();
        self.solve_rows(&mut rows);
        Ok(rows.into_iter().map(|[x]| x).collect())
    }

    /// Solves A X = B in place for a 2-column B given as rows [b₀, b₁] (u and v of a
    /// parameterisation in one pass over L).
    pub fn solve_pairs(&self, b: &mut [[f64; 2]]) -> Result<(), NumericsError> {
        self.check(b.len())?;
        self.solve_rows(b);
        Ok(())
    }

    /// Stored entries of L (its fill, for reports and tests).
    pub fn factor_len(&self) -> usize {
        self.symbolic.fill
    }
}

/// The lower-triangle pattern of a sparse symmetric matrix with its symbolic Cholesky
/// analysis (ordering and the pattern of L), for matrices refactorised many times with new
/// values on the same pattern.
pub struct SparsePattern {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: Arc<Symbolic>,
}

impl SparsePattern {
    /// The pattern of the n × n matrix with entries at `(row, column)` (lower triangle; the
    /// diagonal is added where missing; entries above it are ignored; repeats are merged).
    pub fn new(n: usize, entries: &[(usize, usize)]) -> Result<Self, NumericsError> {
        Self::analysed(n, entries, Effort::Refactorised)
    }

    fn analysed(
        n: usize,
        entries: &[(usize, usize)],
        effort: Effort,
    ) -> Result<Self, NumericsError> {
        if let Some(&(r, c)) = entries.iter().find(|(r, c)| *r >= n || *c >= n) {
            return Err(NumericsError::Shape {
                what: "sparse pattern",
                detail: format!("entry ({r}, {c}) outside a {n} × {n} matrix"),
            });
        }
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        for &(r, c) in entries.iter().filter(|(r, c)| r >= c) {
            cols[c].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (c, rows) in cols.iter_mut().enumerate() {
            rows.push(c);
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend_from_slice(rows);
            col_ptr.push(row_idx.len());
        }
        let symbolic = Arc::new(Symbolic::analyse(n, &col_ptr, &row_idx, effort)?);
        Ok(Self {
            col_ptr,
            row_idx,
            symbolic,
        })
    }

    /// Stored entries (the length of a values array).
    pub fn len(&self) -> usize {
        self.row_idx.len()
    }

    /// Whether it stores nothing.
    pub fn is_empty(&self) -> bool {
        self.row_idx.is_empty()
    }

    /// Where entry (row, column) of the lower triangle lives in a values array.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let (r, c) = if row >= col { (row, col) } else { (col, row) };
        let (a, b) = (*self.col_ptr.get(c)?, *self.col_ptr.get(c + 1)?);
        self.row_idx[a..b].binary_search(&r).ok().map(|k| a + k)
    }

    /// The factorisation of the matrix with these values (in [`SparsePattern::slot`] order).
    pub fn factor(&self, values: &[f64]) -> Result<SparseCholesky, NumericsError> {
        if values.len() != self.len() {
            return Err(NumericsError::Shape {
                what: "sparse factorisation",
                detail: format!("{} values for a pattern of {}", values.len(), self.len()),
            });
        }
        Ok(SparseCholesky {
            values: self.symbolic.factor(values)?,
            symbolic: Arc::clone(&self.symbolic),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_laplacian_matches_dense_elimination() {
        // A 1-D screened Laplacian (tridiagonal: 2 + ε on the diagonal, −1 beside it).
        let n = 50;
        let mut entries = Vec::new();
        let mut dense = vec![0.0; n * n];
        for i in 0..n {
            entries.push((i, i, 2.01));
            dense[i * n + i] = 2.01;
            if i > 0 {
                entries.push((i, i - 1, -1.0));
                dense[i * n + i - 1] = -1.0;
                dense[(i - 1) * n + i] = -1.0;
            }
        }
        let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
        let chol = SparseCholesky::new(n, &entries).unwrap();
        let x = chol.solve(&b).unwrap();
        let want = super::super::dense::solve(&dense, &b, n).unwrap();
        for (a, w) in x.iter().zip(&want) {
            assert!((a - w).abs() < 1e-10, "{a} vs {w}");
        }
        // Several right-hand sides at once give each one's solution.
        let b2: Vec<f64> = b.iter().map(|v| 3.0 - v).collect();
        let many = chol.solve_many(&[&b, &b2]).unwrap();
        assert_eq!(many[0], x);
        let want2 = super::super::dense::solve(&dense, &b2, n).unwrap();
        for (a, w) in many[1].iter().zip(&want2) {
            assert!((a - w).abs() < 1e-10, "{a} vs {w}");
        }
        assert!(chol.solve_many(&[&b, &b2[1..]]).is_err());
    }

    /// A screened 2-D grid Laplacian (w × w, 5-point), lower-triangle entries.
    fn grid(w: usize) -> Vec<(usize, usize, f64)> {
        let mut entries = Vec::new();
        for i in 0..w * w {
            entries.push((i, i, 4.05 + (i % 3) as f64 * 0.1));
            if i % w > 0 {
                entries.push((i, i - 1, -1.0));
            }
            if i >= w {
                entries.push((i, i - w, -1.0));
            }
        }
        entries
    }

    /// A x for a symmetric A given by its lower-triangle entries.
    fn apply(n: usize, entries: &[(usize, usize, f64)], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; n];
        for &(r, c, v) in entries {
            y[r] += v * x[c];
            if r != c {
                y[c] += v * x[r];
            }
        }
        y
    }

    #[test]
    fn grid_solves_match_dense_elimination_and_fill_less_than_the_band() {
        let w = 12;
        let n = w * w;
        let entries = grid(w);
        let mut dense = vec![0.0; n * n];
        for &(r, c, v) in &entries {
            dense[r * n + c] = v;
            dense[c * n + r] = v;
        }
        let b0: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
        let b1: Vec<f64> = (0..n).map(|i| ((i * 3) % 11) as f64 * 0.3).collect();
        let want = [
            super::super::dense::solve(&dense, &b0, n).unwrap(),
            super::super::dense::solve(&dense, &b1, n).unwrap(),
        ];
        let chol = SparseCholesky::new(n, &entries).unwrap();
        assert_ne!(chol.symbolic.perm, (0..n as u32).collect::<Vec<_>>());
        // Minimum degree fills less than the natural order's band (n · w below the diagonal).
        assert!(
            chol.factor_len() < n * w * 3 / 4,
            "fill {}",
            chol.factor_len()
        );
        let mut pairs: Vec<[f64; 2]> = b0.iter().zip(&b1).map(|(a, b)| [*a, *b]).collect();
        chol.solve_pairs(&mut pairs).unwrap();
        let many = chol.solve_many(&[&b0, &b1, &b0, &b1, &b0]).unwrap();
        for i in 0..n {
            for c in 0..2 {
                assert!((pairs[i][c] - want[c][i]).abs() < 1e-12);
                assert_eq!(many[c][i], many[c + 2][i]);
            }
            assert!((many[0][i] - want[0][i]).abs() < 1e-12);
            assert!((many[4][i] - want[0][i]).abs() < 1e-12);
        }
        assert!(chol.solve_pairs(&mut pairs[1..]).is_err());
        assert!(SparseCholesky::new(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
    }

    #[test]
    fn a_large_grid_solves_to_rounding() {
        // 90 × 90 (8100 unknowns): the residual of the solution, relative to the right-hand side.
        let w = 90;
        let n = w * w;
        let entries = grid(w);
        let b: Vec<f64> = (0..n).map(|i| ((i as f64) * 0.013).sin()).collect();
        let x = SparseCholesky::new(n, &entries).unwrap().solve(&b).unwrap();
        let ax = apply(n, &entries, &x);
        let err = ax
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-12, "residual {err}");
    }

    #[test]
    fn disconnected_parts_and_lone_unknowns_order_and_solve() {
        // Three grids of different sizes side by side, and 5000 unknowns coupled to nothing:
        // every component is dissected on its own, and nothing recurses once per component.
        let mut entries = Vec::new();
        let mut base = 0;
        for w in [30, 7, 16] {
            for (r, c, v) in grid(w) {
                entries.push((r + base, c + base, v));
            }
            base += w * w;
        }
        for i in 0..5000 {
            entries.push((base + i, base + i, 2.0 + (i % 7) as f64));
        }
        let n = base + 5000;
        let b: Vec<f64> = (0..n).map(|i| ((i * 13) % 9) as f64 - 4.0).collect();
        let chol = SparseCholesky::new(n, &entries).unwrap();
        let mut sorted = chol.symbolic.perm.clone();
        sorted.sort_unstable();
        assert_eq!(
            sorted,
            (0..n as u32).collect::<Vec<_>>(),
            "the order is a permutation"
        );
        let x = chol.solve(&b).unwrap();
        let ax = apply(n, &entries, &x);
        for (a, w) in ax.iter().zip(&b) {
            assert!((a - w).abs() < 1e-12);
        }
        // The same pattern gives the same order (no hashing or thread order in it).
        assert_eq!(
            SparseCholesky::new(n, &entries).unwrap().symbolic.perm,
            chol.symbolic.perm
        );
    }

    #[test]
    fn nested_dissection_fills_a_large_grid_like_n_log_n() {
        // 100 × 100: a fill-reducing order keeps L near 20–25 entries a row (minimum degree and
        // nested dissection both land there); the natural order's band would give 100.
        let w = 100;
        let n = w * w;
        let chol = SparseCholesky::new(n, &grid(w)).unwrap();
        let per_row = chol.factor_len() as f64 / n as f64;
        assert!(per_row < 26.0, "{per_row} entries of L a row");
    }

    #[test]
    fn the_dense_kernel_gives_the_same_bits_on_every_path() {
        // The runtime-dispatched kernel (AVX2 where the CPU has it) against the portable loop.
        let data: Vec<f64> = (0..4000)
            .map(|i| ((i * 7919) % 1013) as f64 / 97.0 - 5.0)
            .collect();
        for count in [0, 1, 3, 4, 7, 13] {
            let column = |s: usize| &data[s * 211..s * 211 + 190];
            let mut a: Vec<f64> = (0..190).map(|i| i as f64 * 0.01).collect();
            let mut b = a.clone();
            multiply_add(&mut a, count, column, -1.0);
            multiply_add_portable(&mut b, count, column, -1.0);
            assert_eq!(a, b, "{count} columns");
        }
    }

    #[test]
    fn block_systems_of_every_size_factor_like_dense() {
        // Dense-ish random SPD systems with 4 × 4 blocks (the shape of the registration's
        // normal equations): diagonally dominant, couplings on a ring and a chord.
        for blocks in [1, 2, 7, 30] {
            let n = 4 * blocks;
            let mut entries = Vec::new();
            for i in 0..n {
                for j in 0..=i {
                    let (bi, bj) = (i / 4, j / 4);
                    let near = bi == bj
                        || bi == bj + 1
                        || (bj == 0 && bi == blocks - 1)
                        || bi == bj + blocks / 2;
                    if near {
                        let v = if i == j {
                            40.0
                        } else {
                            ((i * 13 + j * 7) % 17) as f64 / 17.0 - 0.5
                        };
                        entries.push((i, j, v));
                    }
                }
            }
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
            let x = SparseCholesky::new(n, &entries).unwrap().solve(&b).unwrap();
            let ax = apply(n, &entries, &x);
            for (a, w) in ax.iter().zip(&b) {
                assert!((a - w).abs() < 1e-12, "{blocks} blocks: {a} vs {w}");
            }
        }
    }

    #[test]
    fn indefinite_and_misshapen_inputs_are_errors() {
        assert!(SparseCholesky::new(2, &[(0, 0, 1.0), (1, 1, -1.0)]).is_err());
        // A star of eight whose hub (0) has a negative diagonal: the hub is ordered last, and
        // the error names it as the matrix was given, not by its place in the ordering.
        let mut star: Vec<(usize, usize, f64)> = (0..8)
            .map(|i| (i, i, if i == 0 { -4.0 } else { 4.0 }))
            .collect();
        star.extend((1..8).map(|i| (i, 0, -1.0)));
        match SparseCholesky::new(8, &star) {
            Err(NumericsError::NotPositiveDefinite {
                n, column, pivot, ..
            }) => {
                assert_eq!((n, column), (8, 0));
                assert!(pivot <= 0.0);
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("an indefinite matrix factorised"),
        }
        assert!(SparseCholesky::new(2, &[(0, 2, 1.0)]).is_err());
        let c = SparseCholesky::new(1, &[(0, 0, 4.0)]).unwrap();
        assert_eq!(c.solve(&[2.0]).unwrap(), vec![0.5]);
        assert!(c.solve(&[1.0, 2.0]).is_err());
    }

    #[test]
    fn a_reused_pattern_factorises_like_a_fresh_matrix() {
        let n = 30;
        let mut pairs = Vec::new();
        for i in 0..n {
            pairs.push((i, i));
            if i > 0 {
                pairs.push((i, i - 1));
            }
            if i > 4 {
                pairs.push((i, i - 5));
            }
        }
        let pattern = SparsePattern::new(n, &pairs).unwrap();
        let b: Vec<f64> = (0..n).map(|i| (i % 4) as f64 - 1.5).collect();
        for scale in [1.0, 3.0] {
            let mut values = vec![0.0; pattern.len()];
            let mut entries = Vec::new();
            for &(r, c) in &pairs {
                let v = if r == c {
                    4.0 * scale + r as f64 * 0.01
                } else {
                    -0.7
                };
                values[pattern.slot(r, c).unwrap()] += v;
                entries.push((r, c, v));
            }
            let x = pattern.factor(&values).unwrap().solve(&b).unwrap();
            let want = SparseCholesky::new(n, &entries).unwrap().solve(&b).unwrap();
            for (a, w) in x.iter().zip(&want) {
                assert!((a - w).abs() < 1e-12);
            }
        }
        assert_eq!(pattern.slot(0, 1), pattern.slot(1, 0));
        assert!(pattern.slot(7, 0).is_none());
        assert!(pattern.factor(&[1.0]).is_err());
    }
}
