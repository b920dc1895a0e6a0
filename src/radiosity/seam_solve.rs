//! The seam stitch's linear solve: one independent part of the least-squares problem that
//! `seams::stitch` sets up, (AᵀA + λ²·I + μ²·L)·y = −AᵀA·x₀ for three channels, solved by
//! a sparse Cholesky factor in nested-dissection order, or by Jacobi-preconditioned
//! conjugate gradients where the factor would be too large. Pure numerics: no atlas, no scene.

use rayon::prelude::*;

use super::dissection::nested_dissection;

/// The stitch's weights: λ (pull towards the solved texels), μ (smoothness between
/// neighbours), and the conjugate-gradient iterations at most.
#[derive(Clone, Copy, Debug)]
pub(super) struct Weights {
    pub closeness: f64,
    pub smoothness: f64,
    pub max_iterations: u32,
}

/// One independent stitching problem, in its own unknowns' indices.
pub(super) struct Problem {
    /// Constraint rows: (unknown, weight).
    rows: Vec<Vec<(usize, f64)>>,
    /// Per unknown: its neighbours among the unknowns, and how many neighbours stay.
    neighbours: Vec<(Vec<usize>, f64)>,
}

impl Problem {
    /// The component of `members` (global unknowns) with constraint rows `part_rows`.
    pub(super) fn part(
        members: &[usize],
        part_rows: &[usize],
        rows: &[&[(usize, f64)]],
        neighbours: &[(Vec<usize>, f64)],
        local: &[usize],
    ) -> Problem {
        Problem {
            rows: part_rows
                .iter()
                .map(|&r| rows[r].iter().map(|&(i, w)| (local[i], w)).collect())
                .collect(),
            neighbours: members
                .iter()
                .map(|&i| {
                    let (nbrs, fixed) = &neighbours[i];
                    (nbrs.iter().map(|&j| local[j]).collect(), *fixed)
                })
                .collect(),
        }
    }

    /// The change of the unknowns from `x0` (see [`stitch`]) and the iterations run, stopping
    /// at residual `stop` per channel.
    pub(super) fn solve(
        &self,
        x0: &[[f64; 3]],
        weights: Weights,
        stop: [f64; 3],
    ) -> (Vec<[f64; 3]>, u32) {
        let n = x0.len();
        let rows: Vec<&[(usize, f64)]> = self.rows.iter().map(|r| r.as_slice()).collect();
        let neighbours = &self.neighbours;
        // Aᵀ by unknown: (row, weight), rows in order.
        let mut by_unknown: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for (r, row) in rows.iter().enumerate() {
            for &(i, w) in row.iter() {
                by_unknown[i].push((r, w));
            }
        }
        // y = (AᵀA + λ²·I + μ²·L)·v for the three channels (L: the graph Laplacian of the
        // neighbours, a neighbour that stays counting as 0). Rows, then unknowns, each
        // computed on its own: the same sums in the same order whatever the thread count.
        let lambda2 = weights.closeness * weights.closeness;
        let mu2 = weights.smoothness * weights.smoothness;
        let apply = |v: &[[f64; 3]], y: &mut [[f64; 3]]| {
            let av = row_products(&rows, v);
            y.par_iter_mut().enumerate().for_each(|(i, yi)| {
                let (nbrs, fixed) = &neighbours[i];
                let degree = nbrs.len() as f64 + fixed;
                let mut s = [0.0; 3];
                for c in 0..3 {
                    s[c] = (lambda2 + mu2 * degree) * v[i][c];
                }
                for &j in nbrs {
                    for c in 0..3 {
                        s[c] -= mu2 * v[j][c];
                    }
                }
                for &(r, w) in &by_unknown[i] {
                    for c in 0..3 {
                        s[c] += w * av[r][c];
                    }
                }
                *yi = s;
            });
        };
        let diag: Vec<f64> = (0..n)
            .map(|i| {
                let (nbrs, fixed) = &neighbours[i];
                lambda2
                    + mu2 * (nbrs.len() as f64 + fixed)
                    + by_unknown[i].iter().map(|&(_, w)| w * w).sum::<f64>()
            })
            .collect();
        // b = −AᵀA·x₀
        let ax0 = row_products(&rows, x0);
        let b: Vec<[f64; 3]> = by_unknown
            .iter()
            .map(|col| {
                let mut s = [0.0; 3];
                for &(r, w) in col {
                    for c in 0..3 {
                        s[c] -= w * ax0[r][c];
                    }
                }
                s
            })
            .collect();
        if let Some(factor) = Sparse::factor(self, lambda2, mu2) {
            return (factor.solve(&b), 0);
        }
        conjugate_gradients(&apply, &diag, &b, stop, weights.max_iterations)
    }
}

/// Most entries of a part's Cholesky factor (and most multiply-adds to compute it, /
/// [`DIRECT_WORK_PER_ENTRY`]) for a direct solve; a larger part is solved iteratively.
const DIRECT_MAX_ENTRIES: usize = 1 << 24;

/// See [`DIRECT_MAX_ENTRIES`].
const DIRECT_WORK_PER_ENTRY: f64 = 2048.0;

/// The sparse Cholesky factor L (M = L·Lᵀ, in the order `order`) of a part's matrix
/// M = AᵀA + λ²·I + μ²·L_graph, stored by columns, each column's diagonal first. The stitch's
/// weights span orders of magnitude (constraints of weight ~1 against pulls of λ²), which
/// leaves Jacobi-preconditioned conjugate gradients far from converged at their iteration
/// cap; the factor solves exactly. A part's unknowns lie on a surface (the texels along its
/// seams, joined across them), so a nested-dissection order keeps the factor near
/// n·log n entries where a banded order costs n times the band. Up-looking factorisation
/// (Davis, "Direct Methods for Sparse Linear Systems", 2006, ch. 4, `cs_chol`): row k of L
/// solves a sparse triangular system whose pattern is row k's reach in the elimination tree.
struct Sparse {
    /// Unknown at each position.
    order: Vec<usize>,
    /// Per position: where its column starts in `rows` and `values` (one more at the end).
    start: Vec<usize>,
    /// Row (position) of each entry; each column's diagonal first.
    rows: Vec<u32>,
    /// L's entries.
    values: Vec<f64>,
}

impl Sparse {
    /// The factor of `p`'s matrix, or `None` when it would be too large (or rounding
    /// left the matrix not positive definite): the caller iterates instead.
    fn factor(p: &Problem, lambda2: f64, mu2: f64) -> Option<Sparse> {
        let n = p.neighbours.len();
        // The matrix's graph: unknowns one constraint row reads together, and neighbours.
        let mut by_unknown: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (r, row) in p.rows.iter().enumerate() {
            for &(a, _) in row {
                by_unknown[a].push(r);
            }
        }
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut seen = vec![usize::MAX; n];
        for a in 0..n {
            seen[a] = a;
            let (nbrs, _) = &p.neighbours[a];
            for b in nbrs.iter().copied().chain(
                by_unknown[a]
                    .iter()
                    .flat_map(|&r| p.rows[r].iter().map(|e| e.0)),
            ) {
                if seen[b] != a {
                    seen[b] = a;
                    adj[a].push(b);
                }
            }
            adj[a].sort_unstable();
        }
        let order = nested_dissection(&adj);
        let mut pos = vec![0usize; n];
        for (k, &u) in order.iter().enumerate() {
            pos[u] = k;
        }
        // M's upper triangle by columns in the new order: column k holds M(i, k), i ≤ k,
        // each entry summed in a fixed order (the pulls, then the rows in order).
        let mut col_start = Vec::with_capacity(n + 1);
        let (mut col_rows, mut col_values) = (Vec::new(), Vec::new());
        let mut sum = vec![0.0f64; n];
        col_start.push(0);
        for &a in &order {
            let (nbrs, fixed) = &p.neighbours[a];
            sum[a] += lambda2 + mu2 * (nbrs.len() as f64 + fixed);
            for &b in nbrs {
                sum[b] -= mu2;
            }
            for &r in &by_unknown[a] {
                let row = &p.rows[r];
                let wa = row.iter().find(|e| e.0 == a).map_or(0.0, |e| e.1);
                for &(b, wb) in row {
                    sum[b] += wa * wb;
                }
            }
            let k = pos[a];
            for &b in adj[a].iter().chain(std::iter::once(&a)) {
                if pos[b] <= k {
                    col_rows.push(pos[b] as u32);
                    col_values.push(sum[b]);
                }
                sum[b] = 0.0;
            }
            col_start.push(col_rows.len());
        }
        let column = |k: usize| {
            col_rows[col_start[k]..col_start[k + 1]]
                .iter()
                .map(|&i| i as usize)
        };
        // The elimination tree (Davis ch. 4, `cs_etree`), with path compression through `ancestor`.
        const NONE: usize = usize::MAX;
        let mut parent = vec![NONE; n];
        let mut ancestor = vec![NONE; n];
        for k in 0..n {
            for mut i in column(k) {
                while i != NONE && i < k {
                    let next = ancestor[i];
                    ancestor[i] = k;
                    if next == NONE {
                        parent[i] = k;
                    }
                    i = next;
                }
            }
        }
        // Row k's pattern in L: the reach of column k's entries towards k in the tree,
        // returned in `stack[top..]` so that each node comes before its ancestors.
        let mut flag = vec![NONE; n];
        let mut stack = vec![0usize; n];
        let mut reach = |k: usize, stack: &mut [usize]| -> usize {
            let mut top = n;
            flag[k] = k;
            for mut i in column(k) {
                let mut len = 0;
                while flag[i] != k {
                    stack[len] = i;
                    len += 1;
                    flag[i] = k;
                    i = parent[i];
                }
                while len > 0 {
                    top -= 1;
                    len -= 1;
                    stack[top] = stack[len];
                }
            }
            top
        };
        // Column counts first: the size (and work) decides whether to factor at all.
        let mut count = vec![1usize; n];
        for k in 0..n {
            let top = reach(k, &mut stack);
            for &i in &stack[top..] {
                count[i] += 1;
            }
        }
        let entries: usize = count.iter().sum();
        let work: f64 = count.iter().map(|&c| ((c - 1) as f64).powi(2)).sum();
        if entries > DIRECT_MAX_ENTRIES || work > DIRECT_WORK_PER_ENTRY * DIRECT_MAX_ENTRIES as f64
        {
            return None;
        }
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        for &c in &count {
            start.push(start.last().unwrap() + c);
        }
        let mut rows = vec![0u32; entries];
        let mut values = vec![0.0f64; entries];
        let mut next: Vec<usize> = start[..n].to_vec();
        let mut x = vec![0.0f64; n];
        for k in 0..n {
            let top = reach(k, &mut stack);
            for p in col_start[k]..col_start[k + 1] {
                x[col_rows[p] as usize] = col_values[p];
            }
            let mut d = x[k];
            x[k] = 0.0;
            // L(k, i) = (M(i, k) − Σ_j L(k, j)·L(i, j)) / L(i, i), i in row k's pattern.
            for &i in &stack[top..] {
                let l = x[i] / values[start[i]];
                x[i] = 0.0;
                for p in start[i] + 1..next[i] {
                    x[rows[p] as usize] -= values[p] * l;
                }
                d -= l * l;
                rows[next[i]] = k as u32;
                values[next[i]] = l;
                next[i] += 1;
            }
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            rows[next[k]] = k as u32;
            values[next[k]] = d.sqrt();
            next[k] += 1;
        }
        Some(Sparse {
            order,
            start,
            rows,
            values,
        })
    }

    /// M⁻¹·b for the three channels.
    fn solve(&self, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let n = self.order.len();
        // L·z = b, then Lᵀ·x = z, in the factor's order.
        let mut z: Vec<[f64; 3]> = self.order.iter().map(|&u| b[u]).collect();
        for j in 0..n {
            let (s, e) = (self.start[j], self.start[j + 1]);
            let zj = z[j].map(|v| v / self.values[s]);
            z[j] = zj;
            for p in s + 1..e {
                let (i, l) = (self.rows[p] as usize, self.values[p]);
                for c in 0..3 {
                    z[i][c] -= l * zj[c];
                }
            }
        }
        for j in (0..n).rev() {
            let (s, e) = (self.start[j], self.start[j + 1]);
            let mut zj = z[j];
            for p in s + 1..e {
                let (i, l) = (self.rows[p] as usize, self.values[p]);
                for c in 0..3 {
                    zj[c] -= l * z[i][c];
                }
            }
            z[j] = zj.map(|v| v / self.values[s]);
        }
        let mut x = vec![[0.0; 3]; n];
        for (&u, v) in self.order.iter().zip(z) {
            x[u] = v;
        }
        x
    }
}

/// A·v for the three channels, one row at a time.
pub(super) fn row_products(rows: &[&[(usize, f64)]], v: &[[f64; 3]]) -> Vec<[f64; 3]> {
    rows.par_iter()
        .map(|row| {
            let mut s = [0.0; 3];
            for &(i, w) in row.iter() {
                for c in 0..3 {
                    s[c] += w * v[i][c];
                }
            }
            s
        })
        .collect()
}

/// Elements per partial sum of [`dot`]: fixed, so that the sum's rounding does not depend
/// on the thread count.
const DOT_CHUNK: usize = 4096;

/// Per channel, Σ aᵢ·bᵢ: partial sums over fixed chunks in parallel, added in order.
pub(super) fn dot(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    let partial: Vec<[f64; 3]> = a
        .par_chunks(DOT_CHUNK)
        .zip(b.par_chunks(DOT_CHUNK))
        .map(|(a, b)| {
            let mut s = [0.0; 3];
            for (x, y) in a.iter().zip(b) {
                for c in 0..3 {
                    s[c] += x[c] * y[c];
                }
            }
            s
        })
        .collect();
    partial
        .iter()
        .fold([0.0; 3], |s, p| [0, 1, 2].map(|c| s[c] + p[c]))
}

/// y = M·v for the three channels.
type Operator<'a> = dyn Fn(&[[f64; 3]], &mut [[f64; 3]]) + Sync + 'a;

/// Solves M·x = b for symmetric positive definite M (given as `apply`) and three right-hand
/// sides at once (each with its own step lengths) by conjugate gradients, preconditioned by
/// M's diagonal, until each channel's residual is at most `stop`; returns x and the
/// iterations run.
fn conjugate_gradients(
    apply: &Operator<'_>,
    diag: &[f64],
    b: &[[f64; 3]],
    stop: [f64; 3],
    max_iterations: u32,
) -> (Vec<[f64; 3]>, u32) {
    let n = b.len();
    let mut x = vec![[0.0; 3]; n];
    let mut r = b.to_vec();
    let mut z: Vec<[f64; 3]> = r.iter().zip(diag).map(|(r, d)| r.map(|c| c / d)).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut q = vec![[0.0; 3]; n];
    for it in 0..max_iterations {
        let rr = dot(&r, &r);
        if (0..3).all(|c| rr[c].sqrt() <= stop[c]) {
            return (x, it);
        }
        apply(&p, &mut q);
        let pq = dot(&p, &q);
        // A channel that has converged (or has nothing to do) takes no more steps.
        let alpha = [0, 1, 2].map(|c| {
            if rr[c].sqrt() > stop[c] && pq[c] > 0.0 {
                rz[c] / pq[c]
            } else {
                0.0
            }
        });
        x.par_iter_mut()
            .zip(r.par_iter_mut())
            .zip(z.par_iter_mut())
            .zip(p.par_iter().zip(q.par_iter()).zip(diag.par_iter()))
            .for_each(|(((x, r), z), ((p, q), d))| {
                for c in 0..3 {
                    x[c] += alpha[c] * p[c];
                    r[c] -= alpha[c] * q[c];
                    z[c] = r[c] / d;
                }
            });
        let rz_next = dot(&r, &z);
        let beta = [0, 1, 2].map(|c| if rz[c] > 0.0 { rz_next[c] / rz[c] } else { 0.0 });
        rz = rz_next;
        p.par_iter_mut().zip(z.par_iter()).for_each(|(p, z)| {
            for c in 0..3 {
                p[c] = z[c] + beta[c] * p[c];
            }
        });
    }
    (x, max_iterations)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// M·v through `p`'s rows and neighbours, term by term as [`stitch`] defines M.
    fn apply(p: &Problem, lambda2: f64, mu2: f64, v: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut y: Vec<[f64; 3]> = p
            .neighbours
            .iter()
            .enumerate()
            .map(|(i, (nbrs, fixed))| {
                let mut s = [0.0; 3];
                for c in 0..3 {
                    s[c] = (lambda2 + mu2 * (nbrs.len() as f64 + fixed)) * v[i][c];
                    for &j in nbrs {
                        s[c] -= mu2 * v[j][c];
                    }
                }
                s
            })
            .collect();
        for row in &p.rows {
            let mut a = [0.0; 3];
            for &(i, w) in row {
                for c in 0..3 {
                    a[c] += w * v[i][c];
                }
            }
            for &(i, w) in row {
                for c in 0..3 {
                    y[i][c] += w * a[c];
                }
            }
        }
        y
    }

    /// `p`'s factor (its order checked to be a permutation), a smooth right-hand side b and
    /// the factor's solution of M·x = b.
    fn factor_and_solve(
        p: &Problem,
        lambda2: f64,
        mu2: f64,
    ) -> (Sparse, Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let n = p.neighbours.len();
        let factor = Sparse::factor(p, lambda2, mu2).expect("small enough to factor");
        let mut order = factor.order.clone();
        order.sort_unstable();
        assert_eq!(order, (0..n).collect::<Vec<_>>(), "not a permutation");
        let b: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let t = i as f64;
                [t.sin(), 1.0, -(0.3 * t).cos()]
            })
            .collect();
        let x = factor.solve(&b);
        (factor, b, x)
    }

    /// Two 40-texel sides of a seam tied by constraints of weight ~1 against the stitch's
    /// weak pulls (λ² = 10⁻⁶, μ² = 9·10⁻⁶), plus a texel no constraint reads (a second
    /// connected part): the factor's solution satisfies M·x = b to rounding.
    #[test]
    fn the_factor_solves_a_stiff_seam_problem_exactly() {
        let side: usize = 40;
        let mut rows = Vec::new();
        for k in 0..side {
            rows.push(vec![
                (k, 0.75),
                (side + k, -0.5),
                (side + (k + 1) % side, -0.25),
            ]);
        }
        let mut neighbours: Vec<(Vec<usize>, f64)> = Vec::new();
        for s in 0..2 {
            for k in 0..side {
                let nbrs = [k.checked_sub(1), (k + 1 < side).then_some(k + 1)]
                    .into_iter()
                    .flatten()
                    .map(|j| s * side + j)
                    .collect::<Vec<_>>();
                let fixed = 4.0 - nbrs.len() as f64 - 1.0;
                neighbours.push((nbrs, fixed));
            }
        }
        neighbours.push((Vec::new(), 4.0));
        let p = Problem { rows, neighbours };
        let (lambda2, mu2) = (1e-6, 9e-6);
        let (_, b, x) = factor_and_solve(&p, lambda2, mu2);
        let mx = apply(&p, lambda2, mu2, &x);
        for (i, (got, want)) in mx.iter().zip(&b).enumerate() {
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-8,
                    "unknown {i}, channel {c}: M·x = {} against b = {}",
                    got[c],
                    want[c]
                );
            }
        }
    }

    /// A `w` × `h` grid of unknowns (4-neighbours; each texel short of 4 counts the missing
    /// ones as neighbours that stay), numbered row by row from `first`.
    fn grid(first: usize, w: usize, h: usize) -> Vec<(Vec<usize>, f64)> {
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let nbrs: Vec<usize> = [
                    (x > 0).then(|| first + y * w + x - 1),
                    (x + 1 < w).then(|| first + y * w + x + 1),
                    (y > 0).then(|| first + (y - 1) * w + x),
                    (y + 1 < h).then(|| first + (y + 1) * w + x),
                ]
                .into_iter()
                .flatten()
                .collect();
                let fixed = 4.0 - nbrs.len() as f64;
                out.push((nbrs, fixed));
            }
        }
        out
    }

    /// M·x = b solved densely: Gaussian elimination with partial pivoting.
    fn dense_solve(mut m: Vec<Vec<f64>>, mut b: Vec<[f64; 3]>) -> Vec<[f64; 3]> {
        let n = b.len();
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| m[i][k].abs().total_cmp(&m[j][k].abs()))
                .unwrap();
            m.swap(k, p);
            b.swap(k, p);
            let (pivot, below) = m.split_at_mut(k + 1);
            let (pivot, bk) = (&pivot[k], b[k]);
            for (i, row) in below.iter_mut().enumerate() {
                let f = row[k] / pivot[k];
                if f != 0.0 {
                    for (x, p) in row[k..].iter_mut().zip(&pivot[k..]) {
                        *x -= f * p;
                    }
                    for (x, p) in b[k + 1 + i].iter_mut().zip(bk) {
                        *x -= f * p;
                    }
                }
            }
        }
        let mut x = vec![[0.0; 3]; n];
        for k in (0..n).rev() {
            for c in 0..3 {
                let s: f64 = (k + 1..n).map(|j| m[k][j] * x[j][c]).sum();
                x[k][c] = (b[k][c] - s) / m[k][k];
            }
        }
        x
    }

    /// Two 24 × 8 charts side by side, their facing columns tied by bilinear-like rows
    /// (2 × 2 texels a side) and B-spline-like ones (4 × 4), with the stitch's weak pulls:
    /// large enough that the order dissects it, and the factor's solution agrees with a dense
    /// solve of the same matrix to 10⁻⁹ of its size.
    #[test]
    fn the_factor_of_a_dissected_problem_agrees_with_a_dense_solve() {
        let (w, h) = (24usize, 8usize);
        let mut neighbours = grid(0, w, h);
        neighbours.extend(grid(w * h, w, h));
        let n = neighbours.len();
        let at = |chart: usize, x: usize, y: usize| chart * w * h + y.min(h - 1) * w + x;
        let mut rows = Vec::new();
        for k in 0..3 * (h - 1) {
            let (y, f) = (k / 3, (k % 3) as f64 / 3.0 + 1.0 / 6.0);
            let weight = 1.0 + 0.1 * (k as f64).sin();
            let mut row = Vec::new();
            for (side, xs) in [(0usize, [w - 2, w - 1]), (1, [0, 1])] {
                let sign = if side == 0 { weight } else { -weight };
                for (dy, wy) in [(0, 1.0 - f), (1, f)] {
                    for (dx, &x) in xs.iter().enumerate() {
                        row.push((at(side, x, y + dy), sign * wy * [0.4, 0.6][dx]));
                    }
                }
            }
            rows.push(row.clone());
            // The wider footprint: 4 × 4 texels a side.
            row.clear();
            for (side, xs) in [(0usize, [w - 4, w - 3, w - 2, w - 1]), (1, [0, 1, 2, 3])] {
                let sign = if side == 0 { weight } else { -weight };
                for dy in 0..4 {
                    for (dx, &x) in xs.iter().enumerate() {
                        let wt = sign * (1.0 + dx as f64) * (1.0 + dy as f64) / 100.0;
                        row.push((at(side, x, (y + dy).saturating_sub(1)), wt));
                    }
                }
            }
            row.sort_by_key(|e| e.0);
            row.dedup_by(|b, a| {
                let same = a.0 == b.0;
                if same {
                    a.1 += b.1;
                }
                same
            });
            rows.push(row);
        }
        let p = Problem { rows, neighbours };
        let (lambda2, mu2) = (1e-6, 9e-6);
        let (factor, b, x) = factor_and_solve(&p, lambda2, mu2);
        // Dissected: the unknowns are not eliminated in their own order.
        assert_ne!(factor.order, (0..n).collect::<Vec<_>>());
        let mut m = vec![vec![0.0; n]; n];
        for j in 0..n {
            let mut e = vec![[0.0; 3]; n];
            e[j] = [1.0; 3];
            for (i, v) in apply(&p, lambda2, mu2, &e).iter().enumerate() {
                m[i][j] = v[0];
            }
        }
        let want = dense_solve(m, b);
        let size = want.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        for (i, (got, want)) in x.iter().zip(&want).enumerate() {
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 1e-9 * size,
                    "unknown {i}, channel {c}: {} against the dense {} (of {size})",
                    got[c],
                    want[c]
                );
            }
        }
    }

    /// On a 100 × 100 grid the nested-dissection order's factor costs under a fifth of the
    /// multiply-adds of the grid's own banded order (n·w², w = 100), and under half its
    /// entries (n·w).
    #[test]
    fn nested_dissection_keeps_a_grid_factor_far_below_the_band() {
        let w = 100usize;
        let p = Problem {
            rows: Vec::new(),
            neighbours: grid(0, w, w),
        };
        let factor = Sparse::factor(&p, 1.0, 1.0).expect("small enough to factor");
        let n = w * w;
        let work: f64 = factor
            .start
            .windows(2)
            .map(|s| ((s[1] - s[0] - 1) as f64).powi(2))
            .sum();
        let entries = factor.values.len();
        println!("{n} unknowns: {entries} entries, {work:.3e} multiply-adds");
        assert!(work < 0.2 * (n * w * w) as f64, "{work:.3e} multiply-adds");
        assert!(entries < n * w / 2, "{entries} entries");
    }
}
