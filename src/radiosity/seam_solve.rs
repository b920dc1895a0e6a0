//! The seam stitch's linear solve: one independent part of the least-squares problem that
//! `seams::stitch` sets up, (AᵀA + λ²·I + μ²·L)·y = −AᵀA·x₀ for three channels, solved by
//! an envelope Cholesky factor in reverse Cuthill–McKee order, or by Jacobi-preconditioned
//! conjugate gradients where the factor would be too large. Pure numerics: no atlas, no scene.

use rayon::prelude::*;

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
        if let Some(factor) = Envelope::factor(self, lambda2, mu2) {
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

/// The Cholesky factor L (M = L·Lᵀ) of a part's matrix M = AᵀA + λ²·I + μ²·L_graph, stored
/// by rows over each row's envelope (its first non-zero column up to the diagonal), with the
/// unknowns in reverse Cuthill–McKee order: a seam's texels form long thin strips, which that
/// order turns into a narrow band. The stitch's weights span orders of magnitude (constraints
/// of weight ~1 against pulls of λ²), which leaves Jacobi-preconditioned conjugate gradients
/// far from converged at their iteration cap; the factor solves exactly at the cost of the band.
struct Envelope {
    /// Unknown at each position.
    order: Vec<usize>,
    /// Per position: the first column its row stores.
    first: Vec<usize>,
    /// Per position: where its row starts in `values`.
    start: Vec<usize>,
    /// Rows of L, each from column `first` to the diagonal.
    values: Vec<f64>,
}

impl Envelope {
    /// The factor of `p`'s matrix, or `None` when its envelope is too large (or rounding
    /// left it not positive definite): the caller iterates instead.
    fn factor(p: &Problem, lambda2: f64, mu2: f64) -> Option<Envelope> {
        let n = p.neighbours.len();
        // The matrix's graph: unknowns one constraint row reads together, and neighbours.
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
        for row in &p.rows {
            for &(a, _) in row {
                adj[a].extend(row.iter().map(|e| e.0).filter(|&b| b != a));
            }
        }
        for (i, (nbrs, _)) in p.neighbours.iter().enumerate() {
            adj[i].extend_from_slice(nbrs);
        }
        for a in &mut adj {
            a.sort_unstable();
            a.dedup();
        }
        let order = reverse_cuthill_mckee(&adj);
        let mut pos = vec![0; n];
        for (k, &u) in order.iter().enumerate() {
            pos[u] = k;
        }
        let first: Vec<usize> = order
            .iter()
            .enumerate()
            .map(|(k, &u)| adj[u].iter().map(|&v| pos[v]).fold(k, usize::min))
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        let (mut entries, mut work) = (0usize, 0.0f64);
        for (k, &f) in first.iter().enumerate() {
            start.push(entries);
            entries += k - f + 1;
            work += ((k - f) as f64).powi(2);
        }
        if entries > DIRECT_MAX_ENTRIES || work > DIRECT_WORK_PER_ENTRY * DIRECT_MAX_ENTRIES as f64
        {
            return None;
        }
        let mut values = vec![0.0; entries];
        // M's lower triangle, in a fixed order.
        let at = |i: usize, j: usize| start[i] + j - first[i];
        for (u, (nbrs, fixed)) in p.neighbours.iter().enumerate() {
            let i = pos[u];
            values[at(i, i)] += lambda2 + mu2 * (nbrs.len() as f64 + fixed);
            for &v in nbrs {
                let j = pos[v];
                if j < i {
                    values[at(i, j)] -= mu2;
                }
            }
        }
        for row in &p.rows {
            for &(a, wa) in row {
                let i = pos[a];
                for &(b, wb) in row {
                    let j = pos[b];
                    if j <= i {
                        values[at(i, j)] += wa * wb;
                    }
                }
            }
        }
        // Row by row: L_ij = (M_ij − Σ_k L_ik·L_jk) / L_jj over the columns both rows store.
        for i in 0..n {
            let fi = first[i];
            for j in fi..i {
                let k0 = fi.max(first[j]);
                let s = values[at(i, j)]
                    - values[at(i, k0)..at(i, j)]
                        .iter()
                        .zip(&values[at(j, k0)..at(j, j)])
                        .map(|(x, y)| x * y)
                        .sum::<f64>();
                values[at(i, j)] = s / values[at(j, j)];
            }
            let d = values[at(i, i)]
                - values[at(i, fi)..at(i, i)]
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>();
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            values[at(i, i)] = d.sqrt();
        }
        Some(Envelope {
            order,
            first,
            start,
            values,
        })
    }

    /// M⁻¹·b for the three channels.
    fn solve(&self, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let n = self.order.len();
        let row = |i: usize| &self.values[self.start[i]..self.start[i] + i - self.first[i] + 1];
        // L·z = b, then Lᵀ·x = z, in the factor's order.
        let mut z: Vec<[f64; 3]> = self.order.iter().map(|&u| b[u]).collect();
        for i in 0..n {
            let (r, fi) = (row(i), self.first[i]);
            let (off, d) = (&r[..r.len() - 1], r[r.len() - 1]);
            let mut s = z[i];
            for (k, l) in off.iter().enumerate() {
                for c in 0..3 {
                    s[c] -= l * z[fi + k][c];
                }
            }
            z[i] = s.map(|x| x / d);
        }
        for i in (0..n).rev() {
            let (r, fi) = (row(i), self.first[i]);
            let (off, d) = (&r[..r.len() - 1], r[r.len() - 1]);
            let x = z[i].map(|x| x / d);
            z[i] = x;
            for (k, l) in off.iter().enumerate() {
                for c in 0..3 {
                    z[fi + k][c] -= l * x[c];
                }
            }
        }
        let mut x = vec![[0.0; 3]; n];
        for (&u, v) in self.order.iter().zip(z) {
            x[u] = v;
        }
        x
    }
}

/// Reverse Cuthill–McKee order of the graph `adj` (sorted neighbour lists): breadth-first
/// from a far node of each connected part, neighbours by increasing degree, reversed.
fn reverse_cuthill_mckee(adj: &[Vec<usize>]) -> Vec<usize> {
    let n = adj.len();
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut mark = vec![usize::MAX; n];
    let bfs_last = |root: usize, mark: &mut Vec<usize>| -> usize {
        // The last node reached breadth-first from `root` with the least degree.
        let mut level = vec![root];
        mark[root] = root;
        loop {
            let mut next = Vec::new();
            for &u in &level {
                for &v in &adj[u] {
                    if mark[v] != root {
                        mark[v] = root;
                        next.push(v);
                    }
                }
            }
            if next.is_empty() {
                return *level.iter().min_by_key(|&&u| (adj[u].len(), u)).unwrap();
            }
            level = next;
        }
    };
    for s in 0..n {
        if seen[s] {
            continue;
        }
        let root = bfs_last(s, &mut mark);
        let begin = order.len();
        order.push(root);
        seen[root] = true;
        let mut head = begin;
        while head < order.len() {
            let u = order[head];
            head += 1;
            let mut next: Vec<usize> = adj[u].iter().copied().filter(|&v| !seen[v]).collect();
            next.sort_unstable_by_key(|&v| (adj[v].len(), v));
            for v in next {
                seen[v] = true;
                order.push(v);
            }
        }
    }
    order.reverse();
    order
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
        let n = neighbours.len();
        let p = Problem { rows, neighbours };
        let (lambda2, mu2) = (1e-6, 9e-6);
        let factor = Envelope::factor(&p, lambda2, mu2).expect("small enough to factor");
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
}
