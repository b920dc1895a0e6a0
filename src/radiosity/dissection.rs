//! A fill-reducing elimination order for the seam stitch's sparse Cholesky factor
//! (`seam_solve`): nested dissection of the matrix's graph. Pure graph code.

/// Unknowns below which [`nested_dissection`] stops splitting a piece of the graph: eliminating
/// a piece this small costs little whatever its order.
const DISSECTION_LEAF: usize = 32;

/// A fill-reducing elimination order of the graph `adj` (sorted neighbour lists): nested
/// dissection by level structures (George, "Nested dissection of a regular finite element
/// mesh", 1973; George and Liu, "Computer Solution of Large Sparse Positive Definite
/// Systems", 1981, ch. 8). Each piece of the graph is searched breadth-first from
/// a far node; a small level near its middle separates what comes before from what comes
/// after, and is eliminated after both, which are ordered the same way. Pieces under
/// [`DISSECTION_LEAF`] unknowns keep their breadth-first order.
pub(super) fn nested_dissection(adj: &[Vec<usize>]) -> Vec<usize> {
    let n = adj.len();
    let mut order = vec![0usize; n];
    // Which piece each node is in now (pieces get fresh ids as they are split).
    let mut piece = vec![0usize; n];
    let mut pieces = 1;
    let mut level_of = vec![0usize; n];
    // Pieces still to order: their nodes and where in `order` they go.
    let mut work: Vec<(Vec<usize>, usize)> = Vec::new();
    // The connected parts of the whole graph first.
    {
        let mut seen = vec![false; n];
        let mut at = 0;
        for s in 0..n {
            if seen[s] {
                continue;
            }
            seen[s] = true;
            let nodes = flood(adj, s, |v| !std::mem::replace(&mut seen[v], true));
            let len = nodes.len();
            work.push((nodes, at));
            at += len;
        }
        work.reverse();
    }
    // Breadth-first levels of piece `id` from `root` (`level_of` is usize::MAX on the piece's
    // nodes not yet reached): its nodes in level order, and where each level starts.
    let levels = |root: usize, id: usize, piece: &[usize], level_of: &mut [usize], size: usize| {
        let mut nodes = Vec::with_capacity(size);
        let mut starts = vec![0];
        nodes.push(root);
        level_of[root] = 0;
        let mut head = 0;
        while head < nodes.len() {
            let u = nodes[head];
            head += 1;
            let l = level_of[u];
            for &v in &adj[u] {
                if piece[v] == id && level_of[v] == usize::MAX {
                    level_of[v] = l + 1;
                    if starts.len() == l + 1 {
                        starts.push(nodes.len());
                    }
                    nodes.push(v);
                }
            }
        }
        starts.push(nodes.len());
        (nodes, starts)
    };
    while let Some((nodes, at)) = work.pop() {
        let size = nodes.len();
        if size <= DISSECTION_LEAF {
            order[at..at + size].copy_from_slice(&nodes);
            continue;
        }
        let id = piece[nodes[0]];
        // A far node: repeatedly the least-degree node of the last level, while the depth
        // grows.
        let mut root = nodes[0];
        let mut best = (0usize, Vec::new(), Vec::new());
        for _ in 0..4 {
            for &u in &nodes {
                level_of[u] = usize::MAX;
            }
            let (lv, starts) = levels(root, id, &piece, &mut level_of, size);
            let depth = starts.len() - 1;
            let better = depth > best.0;
            let last = &lv[starts[depth - 1]..];
            let next = *last.iter().min_by_key(|&&u| (adj[u].len(), u)).unwrap();
            if better {
                best = (depth, lv, starts);
            }
            if !better || next == root {
                break;
            }
            root = next;
        }
        let (depth, lv, starts) = best;
        // Levels again as `level_of` marks, from the best search.
        for (l, w) in starts.windows(2).enumerate() {
            for &u in &lv[w[0]..w[1]] {
                level_of[u] = l;
            }
        }
        if depth < 3 {
            order[at..at + size].copy_from_slice(&lv);
            continue;
        }
        // The separating level: the smallest with at least a quarter of the piece on each
        // side, the middle one where none has.
        let mut pick = None;
        for l in 1..depth - 1 {
            let (before, here) = (starts[l], starts[l + 1] - starts[l]);
            let after = size - before - here;
            if 4 * before.min(after) >= size {
                let s = here;
                if pick.is_none_or(|(_, b)| s < b) {
                    pick = Some((l, s));
                }
            }
        }
        let l = pick.map_or_else(
            || {
                (1..depth - 1)
                    .find(|&l| 2 * starts[l + 1] >= size)
                    .unwrap_or(1)
            },
            |(l, _)| l,
        );
        // Only the level's nodes with a neighbour in the next level separate: the others
        // join the side before.
        let separator: Vec<usize> = lv[starts[l]..starts[l + 1]]
            .iter()
            .copied()
            .filter(|&u| {
                adj[u]
                    .iter()
                    .any(|&v| piece[v] == id && level_of[v] == l + 1)
            })
            .collect();
        let sep_id = pieces;
        pieces += 1;
        for &u in &separator {
            piece[u] = sep_id;
        }
        order[at + size - separator.len()..at + size].copy_from_slice(&separator);
        // The rest, split into its connected pieces, each a new piece to order.
        let mut next_at = at;
        let mut found = Vec::new();
        for &s in &lv {
            if piece[s] != id {
                continue;
            }
            let new_id = pieces;
            pieces += 1;
            piece[s] = new_id;
            let part = flood(adj, s, |v| {
                let claim = piece[v] == id;
                if claim {
                    piece[v] = new_id;
                }
                claim
            });
            let len = part.len();
            found.push((part, next_at));
            next_at += len;
        }
        debug_assert_eq!(next_at + separator.len(), at + size);
        work.extend(found.into_iter().rev());
    }
    order
}

/// The nodes reached breadth-first from `start` through `adj`, in the order reached, where
/// `claim(v)` says whether an unreached neighbour `v` joins (and marks it reached).
fn flood(adj: &[Vec<usize>], start: usize, mut claim: impl FnMut(usize) -> bool) -> Vec<usize> {
    let mut nodes = vec![start];
    let mut head = 0;
    while head < nodes.len() {
        let u = nodes[head];
        head += 1;
        for &v in &adj[u] {
            if claim(v) {
                nodes.push(v);
            }
        }
    }
    nodes
}
