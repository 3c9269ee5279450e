//! Envelope (skyline) Cholesky factorisation for the sparse back-end.
//!
//! The matrices factorised here are `K = P + sum_i rho_i D_i' D_i` over the DOFs of an
//! assembly: P is diagonal and each row D_i couples the three DOFs of at most two blocks, so
//! K has a 3 x 3 block for every block and for every pair of blocks in contact. The blocks
//! are put in reverse Cuthill-McKee order (breadth first from a peripheral block, neighbours
//! by increasing degree, then reversed), which keeps the non-zeros of each row close to the
//! diagonal: for a long wall of `c` courses the envelope is about one column of courses wide.
//! On a wall taller than it is long RCM's breadth-first levels run diagonally and are wider
//! than a course; the input order (course by course, as `rockbench::walls` lays a wall out) is
//! kept instead wherever it makes the smaller factorisation (`sum_j w_j^2`): 40 courses of 21
//! blocks 75.2 -> 66.4 DOFs. Factorising costs O(n w^2) and a solve O(n w) for a mean width w.
//!
//! Row `j` of the lower factor L is stored from its first non-zero column `first[j]` to the
//! diagonal. The factorisation is the row-by-row (bordering) Cholesky algorithm:
//!
//! ```text
//! L_jk = (K_jk - sum_{l = max(first_j, first_k)}^{k-1} L_jl L_kl) / L_kk,   first_j <= k < j
//! L_jj = sqrt(K_jj - sum_{l = first_j}^{j-1} L_jl^2)
//! ```
//!
//! and fill-in stays inside the envelope.
//!
//! A factor of `K` becomes one of `K + sigma c c'` (a row entering or, `sigma < 0`, leaving
//! the Newton matrix) by the rank-one update of the factor (Gill, Golub, Murray and Saunders,
//! 1974), with `w = sqrt(|sigma|) c`: column `j` gets the rotation
//!
//! ```text
//! r = sqrt(L_jj^2 + sign(sigma) w_j^2),  c_j = r / L_jj,  s_j = w_j / L_jj,  L_jj <- r
//! ```
//!
//! and each entry below it, with `w_i` as the columns left of `j` left it,
//!
//! ```text
//! L_ij <- (L_ij + sign(sigma) s_j w_i) / c_j,   w_i <- (w_i - s_j L_ij) / c_j   (the old L_ij)
//! ```
//!
//! A column whose `w_j` is zero keeps the identity, and `w_i` becomes non-zero only where
//! `L_ij` is, so the update stays inside the envelope too. It is taken row by row (a row meets
//! the rotations of its columns in order, then makes its own column's), a block's three rows
//! side by side; it costs the entries of the rows below the first non-zero of `c`, about
//! `n w / 2` against `n w^2 / 2` for a factorisation. Measured (a probe on the running-bond
//! walls of `random_wall_matrix`, 400 updates of penalty 1e4): 1.5 / 2.9 / 19 / 66 / 153 us an
//! update against 10 / 21 / 250 / 960 / 2360 us a factorisation at 3 x 8 / 5 x 8 / 10 x 21 /
//! 20 x 21 / 40 x 21 blocks (mean widths 11.7 / 16.6 / 31.5 / 55.9 / 66.4 DOFs): 7 to 15
//! updates cost one factorisation (column by column, reading each column across the rows'
//! storage, 5 to 6).

/// DOFs per block: (x, z, phi).
const DOFS: usize = 3;

/// A symmetric positive definite matrix over `3 n_blocks` DOFs with a fixed envelope, its
/// values, and (after [`Envelope::factor`]) its Cholesky factor in place.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct Envelope {
    /// Elimination position of each DOF.
    pos: Vec<usize>,
    /// First stored column of each row (elimination indices).
    first: Vec<usize>,
    /// Offset of each row's first stored entry in `val`.
    start: Vec<usize>,
    val: Vec<f64>,
    /// Original diagonal, for the pivot test.
    diag: Vec<f64>,
    work: Vec<f64>,
    /// The vector of a rank-one update (zero between updates).
    sweep: Vec<f64>,
    /// Each column's rotation in a rank-one update: `(1 / c_j, sign(sigma) s_j, s_j)`.
    rotation: Vec<(f64, f64, f64)>,
}

/// A downdate whose pivot keeps less than this fraction of its square is refused: the factor
/// would have lost more than twelve of its digits there (see [`Envelope::update`]).
const DOWNDATE_FLOOR: f64 = 1e-12;

/// A row's entries `row` of a rank-one update meet the rotations of their columns, in order,
/// with the row's `w` (see the module's text); returns `w` as they leave it.
#[inline(always)]
fn meet_rotations(row: &mut [f64], rotations: &[(f64, f64, f64)], mut w: f64) -> f64 {
    for (l, &(ic, sig_s, s)) in row.iter_mut().zip(rotations) {
        let old = *l;
        *l = ic * (old + sig_s * w);
        w = ic * (w - s * old);
    }
    w
}

/// `sum_l a_l b_l` over slices of equal length, in four interleaved partial sums: the
/// factorisation's and the solves' inner loop, which one running sum would hold to the latency
/// of an addition per term. With `AVX` the four sums are one AVX register (the caller has
/// checked that the processor has AVX); without fused multiply-adds each product and sum is
/// rounded as in the portable loop, so the result is the same to the bit.
#[inline(always)]
fn dot<const AVX: bool>(a: &[f64], b: &[f64]) -> f64 {
    let [s] = partial_sums::<AVX, 1>([a], b);
    let whole = b.len() - b.len() % 4;
    let tail: f64 = a[whole..].iter().zip(&b[whole..]).map(|(x, y)| x * y).sum();
    (s[0] + s[2]) + (s[1] + s[3]) + tail
}

/// Three inner products with the same `b`, each summed exactly as [`dot`] sums it.
#[inline(always)]
fn dot3<const AVX: bool>(a: [&[f64]; 3], b: &[f64]) -> [f64; 3] {
    let s = partial_sums::<AVX, 3>(a, b);
    let whole = b.len() - b.len() % 4;
    let mut out = [0.0; 3];
    for (t, at) in a.iter().enumerate() {
        let tail: f64 = at[whole..]
            .iter()
            .zip(&b[whole..])
            .map(|(x, y)| x * y)
            .sum();
        out[t] = (s[t][0] + s[t][2]) + (s[t][1] + s[t][3]) + tail;
    }
    out
}

/// The four partial sums `s_q = sum_i a[4i + q] b[4i + q]` of each `a[t]` with `b` over their
/// whole chunks of four (every slice as long as `b`).
#[inline(always)]
fn partial_sums<const AVX: bool, const T: usize>(a: [&[f64]; T], b: &[f64]) -> [[f64; 4]; T] {
    let whole = b.len() - b.len() % 4;
    for at in &a {
        assert_eq!(at.len(), b.len());
    }
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is set only where the processor has AVX, and every slice holds
        // `whole` entries (asserted above).
        return unsafe { partial_sums_avx(a, b, whole) };
    }
    let mut s = [[0.0f64; 4]; T];
    for i in (0..whole).step_by(4) {
        for (t, at) in a.iter().enumerate() {
            for q in 0..4 {
                s[t][q] += at[i + q] * b[i + q];
            }
        }
    }
    s
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn partial_sums_avx<const T: usize>(
    a: [&[f64]; T],
    b: &[f64],
    whole: usize,
) -> [[f64; 4]; T] {
    use std::arch::x86_64::{__m256d, _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd};
    use std::arch::x86_64::{_mm256_setzero_pd, _mm256_storeu_pd};
    let mut acc: [__m256d; T] = [_mm256_setzero_pd(); T];
    let mut i = 0;
    while i < whole {
        // SAFETY: i + 4 <= whole <= every slice's length.
        unsafe {
            let bv = _mm256_loadu_pd(b.as_ptr().add(i));
            for t in 0..T {
                let av = _mm256_loadu_pd(a[t].as_ptr().add(i));
                acc[t] = _mm256_add_pd(acc[t], _mm256_mul_pd(av, bv));
            }
        }
        i += 4;
    }
    let mut s = [[0.0f64; 4]; T];
    for t in 0..T {
        // SAFETY: `s[t]` holds four values.
        unsafe { _mm256_storeu_pd(s[t].as_mut_ptr(), acc[t]) };
    }
    s
}

/// The diagonal entry `row[m]` of a row whose entries left of it are done: false when the pivot
/// is not positive (relative to the matrix's diagonal `diag`).
#[inline(always)]
fn finish_row<const AVX: bool>(row: &mut [f64], m: usize, diag: f64) -> bool {
    let (off, pivot) = row.split_at_mut(m);
    let d = pivot[0] - dot::<AVX>(off, off);
    if d.is_nan() || d <= 1e-15 * diag {
        return false;
    }
    pivot[0] = d.sqrt();
    true
}

/// Reverse Cuthill-McKee order of `n` nodes with the given (deduplicated) adjacency lists.
fn reverse_cuthill_mckee(adj: &[Vec<usize>]) -> Vec<usize> {
    let n = adj.len();
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let bfs = |root: usize, seen: &mut Vec<bool>, out: &mut Vec<usize>| {
        let begin = out.len();
        seen[root] = true;
        out.push(root);
        let mut head = begin;
        while head < out.len() {
            let v = out[head];
            head += 1;
            let mut next: Vec<usize> = adj[v].iter().copied().filter(|&w| !seen[w]).collect();
            next.sort_by_key(|&w| (adj[w].len(), w));
            for w in next {
                seen[w] = true;
                out.push(w);
            }
        }
    };
    for root in 0..n {
        if seen[root] {
            continue;
        }
        // A peripheral start: the lowest-degree node of the last level of a search from the
        // lowest-degree node of this component.
        let mut trial = Vec::new();
        let mut scratch = seen.clone();
        bfs(root, &mut scratch, &mut trial);
        let start_node = *trial
            .iter()
            .min_by_key(|&&v| (adj[v].len(), v))
            .expect("component is not empty");
        let mut trial2 = Vec::new();
        let mut scratch2 = seen.clone();
        bfs(start_node, &mut scratch2, &mut trial2);
        let far = *trial2.last().expect("component is not empty");
        bfs(far, &mut seen, &mut order);
    }
    order.reverse();
    order
}

/// The rank of each node in an elimination order.
fn rank_of(order: &[usize]) -> Vec<usize> {
    let mut rank = vec![0; order.len()];
    for (k, &b) in order.iter().enumerate() {
        rank[b] = k;
    }
    rank
}

/// The lowest rank among block `b` and its neighbours: where its rows of the envelope start.
fn lowest_rank(adj: &[Vec<usize>], rank: &[usize], b: usize) -> usize {
    adj[b].iter().map(|&w| rank[w]).fold(rank[b], usize::min)
}

/// `sum_j w_j^2` over the blocks' rows of the envelope for the given ranks (`w_j` the distance
/// from a block to its lowest-ranked neighbour, plus one): proportional to the work of a
/// factorisation.
fn factorisation_work(adj: &[Vec<usize>], rank: &[usize]) -> u64 {
    (0..adj.len())
        .map(|b| {
            let w = (rank[b] - lowest_rank(adj, rank, b) + 1) as u64;
            w * w
        })
        .sum()
}

impl Envelope {
    /// The envelope of `n_blocks` blocks coupled by the given pairs of block indices.
    pub fn new(n_blocks: usize, pairs: &[(usize, usize)]) -> Self {
        let mut adj = vec![Vec::new(); n_blocks];
        for &(a, b) in pairs {
            if a != b {
                adj[a].push(b);
                adj[b].push(a);
            }
        }
        for l in &mut adj {
            l.sort_unstable();
            l.dedup();
        }
        // The input order when it makes the smaller factorisation (a wall laid out course by
        // course and taller than it is long: RCM's breadth-first levels run diagonally across
        // it and are wider than a course).
        let rcm = rank_of(&reverse_cuthill_mckee(&adj));
        let input: Vec<usize> = (0..n_blocks).collect();
        let rank = if factorisation_work(&adj, &input) < factorisation_work(&adj, &rcm) {
            input
        } else {
            rcm
        };
        let n = DOFS * n_blocks;
        let mut pos = vec![0; n];
        for b in 0..n_blocks {
            for d in 0..DOFS {
                pos[DOFS * b + d] = DOFS * rank[b] + d;
            }
        }
        let mut first = vec![0; n];
        for b in 0..n_blocks {
            let lowest = lowest_rank(&adj, &rank, b);
            for d in 0..DOFS {
                first[DOFS * rank[b] + d] = DOFS * lowest;
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut len = 0;
        for (j, &f) in first.iter().enumerate() {
            start.push(len);
            len += j - f + 1;
        }
        start.push(len);
        Envelope {
            pos,
            first,
            start,
            val: vec![0.0; len],
            diag: vec![0.0; n],
            work: vec![0.0; n],
            sweep: vec![0.0; n],
            rotation: vec![(1.0, 0.0, 0.0); n],
        }
    }

    /// Whether a restored envelope is the one [`Envelope::new`] builds for the blocks in
    /// contact `pairs`, with values of its sizes and no rank-one update under way: a saved
    /// state written again by hand would otherwise index outside its rows.
    pub fn check_built_from(&self, pairs: &[(usize, usize)]) -> Result<(), String> {
        let n = self.first.len();
        if !n.is_multiple_of(DOFS) {
            return Err(format!("the envelope: {n} DOFs, not {DOFS} a block"));
        }
        let n_blocks = n / DOFS;
        if let Some(&(a, b)) = pairs.iter().find(|&&(a, b)| a.max(b) >= n_blocks) {
            return Err(format!(
                "the envelope: blocks {a} and {b} in contact, of {n_blocks} blocks"
            ));
        }
        // A back-end that has not solved a problem yet holds the empty default.
        let built = if n == 0 && self.start.is_empty() {
            Envelope::default()
        } else {
            Envelope::new(n_blocks, pairs)
        };
        let sizes = [
            self.val.len() == built.val.len(),
            self.diag.len() == n,
            self.work.len() == n,
            self.sweep.len() == n,
            self.rotation.len() == n,
        ];
        if self.pos != built.pos
            || self.first != built.first
            || self.start != built.start
            || sizes.contains(&false)
        {
            return Err("the envelope: not the one its blocks in contact make".into());
        }
        if self.sweep.iter().any(|&w| w != 0.0) {
            return Err("the envelope: a rank-one update under way".into());
        }
        Ok(())
    }

    /// Number of DOFs.
    pub fn dofs(&self) -> usize {
        self.first.len()
    }

    /// Number of stored entries of the factor.
    pub fn stored(&self) -> usize {
        self.val.len()
    }

    /// Zero every value (the envelope stays).
    pub fn clear(&mut self) {
        self.val.iter_mut().for_each(|v| *v = 0.0);
    }

    /// `K_ii += v`.
    pub fn add_diagonal(&mut self, i: usize, v: f64) {
        let p = self.pos[i];
        self.val[self.start[p + 1] - 1] += v;
    }

    /// `K += a * c c'` for a sparse vector `c` given by DOF indices and coefficients; the DOFs
    /// must belong to blocks coupled in the envelope (or to one block).
    pub fn add_outer(&mut self, a: f64, idx: &[usize], coef: &[f64]) {
        if let Some(bases) = self.whole_blocks(idx) {
            self.add_blocks_outer(a, bases, coef);
        } else {
            self.add_outer_by_dof(a, idx, coef);
        }
    }

    /// [`Envelope::add_outer`] entry by entry, for any DOFs.
    fn add_outer_by_dof(&mut self, a: f64, idx: &[usize], coef: &[f64]) {
        for (x, (&i, &ci)) in idx.iter().zip(coef).enumerate() {
            for (y, (&j, &cj)) in idx.iter().zip(coef).enumerate().take(x + 1) {
                let (pi, pj) = (self.pos[i], self.pos[j]);
                let (hi, lo) = if pi >= pj { (pi, pj) } else { (pj, pi) };
                debug_assert!(lo >= self.first[hi], "entry outside the envelope");
                // Two entries on the same DOF add their cross term twice.
                let twice = if y != x && i == j { 2.0 } else { 1.0 };
                self.val[self.start[hi] + lo - self.first[hi]] += twice * a * ci * cj;
            }
        }
    }

    /// The elimination positions of the first DOF of each block of `idx` when it holds one or
    /// two distinct blocks whole (three consecutive DOFs each, as a contact row does).
    fn whole_blocks(&self, idx: &[usize]) -> Option<([usize; 2], usize)> {
        let whole = |b: &[usize]| b[0].is_multiple_of(DOFS) && b[1] == b[0] + 1 && b[2] == b[0] + 2;
        match idx.len() {
            3 if whole(idx) => Some(([self.pos[idx[0]], 0], 1)),
            6 if whole(&idx[..3]) && whole(&idx[3..]) && idx[0] != idx[3] => {
                Some(([self.pos[idx[0]], self.pos[idx[3]]], 2))
            }
            _ => None,
        }
    }

    /// [`Envelope::add_outer`] for whole blocks (see [`Envelope::whole_blocks`]): the same
    /// products added to the same entries, with each entry's place found from its blocks' rows
    /// (a block's three rows share their first column) instead of DOF by DOF.
    fn add_blocks_outer(&mut self, a: f64, (bases, blocks): ([usize; 2], usize), coef: &[f64]) {
        // `row[k][d] + column` is the place of (row bases[k] + d, column) in `val`: the row's
        // start less its first column (wrapping: the sum with a column of the row is in range).
        let mut row = [[0usize; DOFS]; 2];
        for k in 0..blocks {
            let first = self.first[bases[k]];
            for (d, place) in row[k].iter_mut().enumerate() {
                *place = self.start[bases[k] + d].wrapping_sub(first);
            }
        }
        // Each block's own lower triangle.
        for k in 0..blocks {
            for dx in 0..DOFS {
                let ax = a * coef[DOFS * k + dx];
                for dy in 0..=dx {
                    let at = row[k][dx].wrapping_add(bases[k] + dy);
                    self.val[at] += ax * coef[DOFS * k + dy];
                }
            }
        }
        if blocks == 2 {
            // The coupling of the second block's DOFs (x) with the first's (y), stored in the
            // rows of whichever block is eliminated later.
            let later = usize::from(bases[1] > bases[0]);
            for dx in 0..DOFS {
                let ax = a * coef[DOFS + dx];
                for dy in 0..DOFS {
                    let at = if later == 1 {
                        row[1][dx].wrapping_add(bases[0] + dy)
                    } else {
                        row[0][dy].wrapping_add(bases[1] + dx)
                    };
                    debug_assert!(
                        bases[1 - later] >= self.first[bases[later]],
                        "entry outside the envelope"
                    );
                    self.val[at] += ax * coef[dy];
                }
            }
        }
    }

    /// Factorise in place. False when a pivot is not positive (to relative 1e-15 of the
    /// original diagonal): the matrix is not numerically positive definite.
    pub fn factor(&mut self) -> bool {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the processor has AVX (checked just above).
            return unsafe { self.factor_avx() };
        }
        self.factor_any()
    }

    /// [`Envelope::factor`] compiled for AVX: the inner products' four partial sums in one
    /// register. Without fused multiply-adds every product and sum is rounded as in
    /// [`Envelope::factor_any`], so the factor is the same to the bit.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn factor_avx(&mut self) -> bool {
        self.factor_with::<true>()
    }

    fn factor_any(&mut self) -> bool {
        self.factor_with::<false>()
    }

    #[inline(always)]
    fn factor_with<const AVX: bool>(&mut self) -> bool {
        let n = self.first.len();
        for j in 0..n {
            self.diag[j] = self.val[self.start[j + 1] - 1];
        }
        // A block's three rows share their first column: their entries left of the block are
        // computed together, each row's inner products with the same row k (read once) in the
        // same order as row by row, so the factor is the row-by-row algorithm's to the bit.
        for j0 in (0..n).step_by(DOFS) {
            let fj = self.first[j0];
            let (done, rest) = self.val.split_at_mut(self.start[j0]);
            let (row0, rest) = rest.split_at_mut(j0 - fj + 1);
            let (row1, rest) = rest.split_at_mut(j0 - fj + 2);
            let row2 = &mut rest[..j0 - fj + 3];
            for k in fj..j0 {
                let fk = self.first[k];
                let l0 = fj.max(fk);
                let row_k = &done[self.start[k]..self.start[k + 1]];
                let (a, b) = (l0 - fj, k - fj);
                let sums = dot3::<AVX>(
                    [&row0[a..b], &row1[a..b], &row2[a..b]],
                    &row_k[l0 - fk..k - fk],
                );
                let pivot = row_k[k - fk];
                row0[b] = (row0[b] - sums[0]) / pivot;
                row1[b] = (row1[b] - sums[1]) / pivot;
                row2[b] = (row2[b] - sums[2]) / pivot;
            }
            // Within the block, row by row.
            let m = j0 - fj;
            if !finish_row::<AVX>(row0, m, self.diag[j0]) {
                return false;
            }
            row1[m] = (row1[m] - dot::<AVX>(&row1[..m], &row0[..m])) / row0[m];
            if !finish_row::<AVX>(row1, m + 1, self.diag[j0 + 1]) {
                return false;
            }
            row2[m] = (row2[m] - dot::<AVX>(&row2[..m], &row0[..m])) / row0[m];
            row2[m + 1] = (row2[m + 1] - dot::<AVX>(&row2[..m + 1], &row1[..m + 1])) / row1[m + 1];
            if !finish_row::<AVX>(row2, m + 2, self.diag[j0 + 2]) {
                return false;
            }
        }
        true
    }

    /// Make the factor of `K` (from [`Envelope::factor`]) one of `K + sigma c c'`, for a sparse
    /// `c` given as in [`Envelope::add_outer`] (the module's text). False when a downdate
    /// (`sigma < 0`) leaves a pivot below `DOWNDATE_FLOOR` of its square: the factor is then
    /// spoilt and must be computed again.
    ///
    /// The rotations are applied row by row (each row's entries in order, contiguous in `val`):
    /// row `i` meets the rotations of its columns `j < i`, already computed, with its own `w_i`,
    /// and then makes its column's rotation from its diagonal.
    pub fn update(&mut self, sigma: f64, idx: &[usize], coef: &[f64]) -> bool {
        if idx.is_empty() {
            return true;
        }
        let sign = if sigma < 0.0 { -1.0 } else { 1.0 };
        let scale = sigma.abs().sqrt();
        let n = self.first.len();
        let mut j0 = n;
        for (&i, &c) in idx.iter().zip(coef) {
            let p = self.pos[i];
            self.sweep[p] += scale * c;
            j0 = j0.min(p);
        }
        // Columns j0.. whose rotation is not the identity are all at or below `changed`.
        let mut changed: Option<usize> = None;
        let mut ok = true;
        let mut i = j0;
        'rows: while i < n {
            let fi = self.first[i];
            let lo = fi.max(j0);
            let quiet = |i: usize, changed: Option<usize>| {
                self.sweep[i] == 0.0 && changed.is_none_or(|c| lo > c)
            };
            if i.is_multiple_of(DOFS) && i + DOFS <= n && lo < i {
                // A block's three rows share their first column: their entries left of the
                // block meet the same rotations, three recurrences side by side.
                if (0..DOFS).all(|d| quiet(i + d, changed)) {
                    for d in 0..DOFS {
                        self.rotation[i + d] = (1.0, 0.0, 0.0);
                    }
                    i += DOFS;
                    continue;
                }
                let mut w = [0.0; DOFS];
                for (d, w) in w.iter_mut().enumerate() {
                    *w = std::mem::replace(&mut self.sweep[i + d], 0.0);
                }
                let (s0, s1, s2) = (self.start[i], self.start[i + 1], self.start[i + 2]);
                let (head, rest) = self.val.split_at_mut(s1);
                let (mid, tail) = rest.split_at_mut(s2 - s1);
                let rows = [
                    &mut head[s0 + lo - fi..s0 + i - fi],
                    &mut mid[lo - fi..i - fi],
                    &mut tail[lo - fi..i - fi],
                ];
                let [r0, r1, r2] = rows;
                for (k, &(ic, sig_s, s)) in self.rotation[lo..i].iter().enumerate() {
                    let (a, b, c) = (r0[k], r1[k], r2[k]);
                    r0[k] = ic * (a + sig_s * w[0]);
                    r1[k] = ic * (b + sig_s * w[1]);
                    r2[k] = ic * (c + sig_s * w[2]);
                    w[0] = ic * (w[0] - s * a);
                    w[1] = ic * (w[1] - s * b);
                    w[2] = ic * (w[2] - s * c);
                }
                // Within the block, row by row.
                for d in 0..DOFS {
                    let row = &mut self.val[self.start[i + d]..self.start[i + d + 1]];
                    let wd = meet_rotations(
                        &mut row[i - fi..i + d - fi],
                        &self.rotation[i..i + d],
                        w[d],
                    );
                    if !self.rotate(i + d, wd, sign, &mut changed) {
                        ok = false;
                        break 'rows;
                    }
                }
                i += DOFS;
                continue;
            }
            // One row alone (a row of `j0`'s block left of it, or a block at the diagonal).
            if quiet(i, changed) {
                self.rotation[i] = (1.0, 0.0, 0.0);
                i += 1;
                continue;
            }
            let mut w = std::mem::replace(&mut self.sweep[i], 0.0);
            if lo < i {
                let row = &mut self.val[self.start[i]..self.start[i + 1]];
                w = meet_rotations(&mut row[lo - fi..i - fi], &self.rotation[lo..i], w);
            }
            if !self.rotate(i, w, sign, &mut changed) {
                ok = false;
                break;
            }
            i += 1;
        }
        for &i in idx {
            self.sweep[self.pos[i]] = 0.0;
        }
        ok
    }

    /// The diagonal of row `i` in a rank-one update, whose `w_i` has met the rotations of the
    /// columns left of it: the column's rotation. False when a downdate is refused.
    fn rotate(&mut self, i: usize, w: f64, sign: f64, changed: &mut Option<usize>) -> bool {
        if w == 0.0 {
            self.rotation[i] = (1.0, 0.0, 0.0);
            return true;
        }
        let at = self.start[i + 1] - 1;
        let d = self.val[at];
        let r2 = d * d + sign * w * w;
        // (NaN is refused as well.)
        if r2.partial_cmp(&(DOWNDATE_FLOOR * d * d)) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let r = r2.sqrt();
        let (ic, s) = (d / r, w / d);
        self.val[at] = r;
        self.rotation[i] = (ic, sign * s, s);
        *changed = Some(i);
        true
    }

    /// Solve `K x = b` in place with the factor (original DOF indexing).
    pub fn solve(&mut self, b: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the processor has AVX (checked just above).
            return unsafe { self.solve_avx(b) };
        }
        self.solve_any(b)
    }

    /// [`Envelope::solve`] compiled for AVX (the same to the bit, as [`Envelope::factor_avx`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn solve_avx(&mut self, b: &mut [f64]) {
        self.solve_with::<true>(b)
    }

    fn solve_any(&mut self, b: &mut [f64]) {
        self.solve_with::<false>(b)
    }

    #[inline(always)]
    fn solve_with<const AVX: bool>(&mut self, b: &mut [f64]) {
        let n = self.first.len();
        let y = &mut self.work;
        for (i, &bi) in b.iter().enumerate() {
            y[self.pos[i]] = bi;
        }
        for j in 0..n {
            let fj = self.first[j];
            let row = &self.val[self.start[j]..self.start[j + 1]];
            y[j] = (y[j] - dot::<AVX>(&row[..j - fj], &y[fj..j])) / row[j - fj];
        }
        for j in (0..n).rev() {
            let fj = self.first[j];
            let row = &self.val[self.start[j]..self.start[j + 1]];
            let xj = y[j] / row[j - fj];
            y[j] = xj;
            for (yl, r) in y[fj..j].iter_mut().zip(&row[..j - fj]) {
                *yl -= r * xj;
            }
        }
        for (i, bi) in b.iter_mut().enumerate() {
            *bi = y[self.pos[i]];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_random::signed as sequence;
    use nalgebra::{DMatrix, DVector};

    /// `P + sum a c c'` over random rows coupling random pairs of blocks, factorised in the
    /// envelope, against nalgebra's dense Cholesky solve of the same matrix.
    #[test]
    fn envelope_solve_matches_a_dense_cholesky_solve() {
        let mut rnd = sequence(7);
        for n_blocks in [1usize, 2, 5, 17, 40] {
            let n = 3 * n_blocks;
            let mut pairs = Vec::new();
            for _ in 0..2 * n_blocks {
                let a = ((rnd() + 1.0) * 0.5 * n_blocks as f64) as usize % n_blocks;
                let b = ((rnd() + 1.0) * 0.5 * n_blocks as f64) as usize % n_blocks;
                pairs.push((a.min(b), a.max(b)));
            }
            let mut env = Envelope::new(n_blocks, &pairs);
            let mut dense = DMatrix::<f64>::zeros(n, n);
            for i in 0..n {
                let p = 1e-3 + (rnd() + 1.0);
                env.add_diagonal(i, p);
                dense[(i, i)] += p;
            }
            for &(a, b) in &pairs {
                let mut idx: Vec<usize> = (0..3).map(|d| 3 * a + d).collect();
                idx.extend((0..3).map(|d| 3 * b + d));
                if a == b {
                    // A repeated DOF must count its cross terms twice.
                    idx[4] = idx[1];
                }
                let coef: Vec<f64> = (0..6).map(|_| rnd()).collect();
                let w = 1e6 * (rnd() + 1.0);
                env.add_outer(w, &idx, &coef);
                for (x, &i) in idx.iter().enumerate() {
                    for (y, &j) in idx.iter().enumerate() {
                        dense[(i, j)] += w * coef[x] * coef[y];
                    }
                }
            }
            assert!(env.factor(), "{n_blocks} blocks: factorisation failed");
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut x = b.clone();
            env.solve(&mut x);
            let reference = dense
                .clone()
                .cholesky()
                .expect("positive definite")
                .solve(&DVector::from_vec(b.clone()));
            let scale = reference.amax();
            for i in 0..n {
                assert!(
                    (x[i] - reference[i]).abs() <= 1e-9 * scale,
                    "{n_blocks} blocks, DOF {i}: {} vs {}",
                    x[i],
                    reference[i]
                );
            }
            // And the residual of the envelope solution itself.
            let r = &dense * DVector::from_vec(x) - DVector::from_vec(b);
            assert!(r.amax() < 1e-6, "{n_blocks} blocks: residual {}", r.amax());
        }
    }

    /// Rows of whole blocks (one block, or two in either elimination order) are added by their
    /// blocks' rows: the same values, to the bit, as entry by entry.
    #[test]
    fn whole_block_rows_are_added_as_entry_by_entry() {
        let mut rnd = sequence(11);
        let n_blocks = 12;
        let pairs: Vec<(usize, usize)> = (0..n_blocks)
            .flat_map(|a| [(a, (a + 1) % n_blocks), (a, (a + 5) % n_blocks)])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        let mut by_blocks = Envelope::new(n_blocks, &pairs);
        let mut by_dof = by_blocks.clone();
        let mut fast = 0;
        for (k, &(a, b)) in pairs.iter().cycle().take(4 * pairs.len()).enumerate() {
            // Alternate which block comes first, and add single-block rows.
            let (a, b) = if k % 2 == 0 { (a, b) } else { (b, a) };
            let mut idx: Vec<usize> = (0..3).map(|d| 3 * a + d).collect();
            if k % 3 != 0 {
                idx.extend((0..3).map(|d| 3 * b + d));
            }
            let coef: Vec<f64> = idx.iter().map(|_| rnd()).collect();
            let w = 1e3 * (rnd() + 1.5);
            fast += usize::from(by_blocks.whole_blocks(&idx).is_some());
            by_blocks.add_outer(w, &idx, &coef);
            by_dof.add_outer_by_dof(w, &idx, &coef);
        }
        assert_eq!(fast, 4 * pairs.len(), "every row took the blocks' path");
        assert_eq!(by_blocks.val, by_dof.val);
        assert!(by_dof.val.iter().filter(|v| **v != 0.0).count() > 100);
    }

    /// The factorisation and the solves dispatched to the processor's kernels (AVX where it
    /// has it) give the portable loops' factor and solution to the bit.
    #[test]
    fn the_avx_kernels_give_the_portable_factor_to_the_bit() {
        let mut rnd = sequence(5);
        let mut env = random_wall_matrix(6, 9, &mut rnd);
        let n_blocks = env.dofs() / 3;
        let mut portable = env.clone();
        assert!(env.factor() && portable.factor_any());
        assert_eq!(env.val, portable.val);
        let b: Vec<f64> = (0..3 * n_blocks).map(|_| rnd()).collect();
        let (mut x, mut y) = (b.clone(), b);
        env.solve(&mut x);
        portable.solve_any(&mut y);
        assert_eq!(x, y);
        assert!(x.iter().all(|v| v.is_finite()) && x.iter().any(|v| *v != 0.0));
    }

    /// `P + sum rho c c'` on a running-bond wall of `courses` courses of `length` blocks: a
    /// random diagonal P and one random row on every pair of blocks in contact, with a random
    /// penalty `rho` of 5e3 to 2.5e4.
    fn random_wall_matrix(
        courses: usize,
        length: usize,
        rnd: &mut impl FnMut() -> f64,
    ) -> Envelope {
        let (n_blocks, pairs) = running_bond(courses, length);
        let mut env = Envelope::new(n_blocks, &pairs);
        for i in 0..3 * n_blocks {
            env.add_diagonal(i, 1.0 + rnd());
        }
        for &(a, b) in &pairs {
            let idx = [3 * a, 3 * a + 1, 3 * a + 2, 3 * b, 3 * b + 1, 3 * b + 2];
            let coef: Vec<f64> = (0..6).map(|_| rnd()).collect();
            env.add_outer(1e4 * (rnd() + 1.5), &idx, &coef);
        }
        env
    }

    /// A saved envelope is taken back only as the one its blocks in contact make: through
    /// CBOR, a factored wall's envelope is accepted and solves as before; one whose rows,
    /// order or sizes were changed, one with a block out of range, and one caught in a
    /// rank-one update are each refused, never indexed.
    #[test]
    fn a_restored_envelope_is_the_one_its_blocks_in_contact_make() {
        let mut rnd = sequence(11);
        let (n_blocks, pairs) = running_bond(3, 4);
        let mut env = random_wall_matrix(3, 4, &mut rnd);
        assert!(env.factor());
        let again: Envelope =
            crate::native::solver::from_bytes(&crate::native::solver::to_bytes(&env), "x").unwrap();
        assert_eq!(again.check_built_from(&pairs), Ok(()));
        assert_eq!(Envelope::default().check_built_from(&[]), Ok(()));
        assert!(Envelope::default().check_built_from(&pairs).is_err());
        let b: Vec<f64> = (0..3 * n_blocks).map(|_| rnd()).collect();
        let (mut x, mut y) = (b.clone(), b);
        env.solve(&mut x);
        again.clone().solve(&mut y);
        assert_eq!(x, y);

        let refused = |change: &dyn Fn(&mut Envelope), pairs: &[(usize, usize)], says: &str| {
            let mut e = again.clone();
            change(&mut e);
            let err = e.check_built_from(pairs).expect_err(says);
            assert!(err.contains(says), "{err}");
        };
        let built = "not the one its blocks in contact make";
        refused(&|e| e.start[5] += 1, &pairs, built);
        refused(&|e| e.first[7] += 1, &pairs, built);
        refused(&|e| e.pos.swap(0, 4), &pairs, built);
        refused(&|e| e.val.push(0.0), &pairs, built);
        refused(&|e| e.rotation.truncate(1), &pairs, built);
        // The envelope of other blocks in contact (here none).
        refused(&|_| {}, &[], built);
        refused(
            &|e| e.first.truncate(3 * n_blocks - 1),
            &pairs,
            "not 3 a block",
        );
        let mut beyond = pairs.clone();
        beyond.push((0, n_blocks));
        refused(&|_| {}, &beyond, "in contact, of");
        refused(&|e| e.sweep[2] = 1.0, &pairs, "a rank-one update under way");
    }

    /// The row-by-row (bordering) algorithm of the module's text, one entry at a time, each
    /// inner product by `dot`: the reference the factorisation must equal to the bit.
    fn factor_row_by_row(env: &mut Envelope) {
        let n = env.dofs();
        for j in 0..n {
            let fj = env.first[j];
            for k in fj..=j {
                let fk = env.first[k];
                let l0 = fj.max(fk);
                let (done, row_j) = env.val.split_at_mut(env.start[j]);
                let row_k: &[f64] = if k < j {
                    &done[env.start[k]..env.start[k + 1]]
                } else {
                    &row_j[..j - fj + 1]
                };
                let sum = dot::<false>(&row_j[l0 - fj..k - fj], &row_k[l0 - fk..k - fk]);
                if k < j {
                    let pivot = row_k[k - fk];
                    row_j[k - fj] = (row_j[k - fj] - sum) / pivot;
                } else {
                    row_j[j - fj] = (row_j[j - fj] - sum).sqrt();
                }
            }
        }
    }

    /// A row's rank-one update and downdate of the factor against the factor computed afresh:
    /// on running-bond walls, rows entering (`+rho c c'`) and leaving (`-rho c c'`, a row the
    /// matrix holds), the solves agree with the fresh factor's to the round-off a downdate
    /// keeps, `eps rho / p` relative (the entries it takes out are `rho / p` times the ones it
    /// leaves), and a downdate that would leave the matrix indefinite is refused.
    #[test]
    fn a_factor_updated_by_rows_solves_as_the_factor_computed_afresh() {
        let mut rnd = sequence(5);
        for ((courses, length), stiffness) in [(1, 3), (3, 8), (10, 21)]
            .into_iter()
            .flat_map(|wall| [(wall, 1e4), (wall, 1e7)])
        {
            let (n_blocks, pairs) = running_bond(courses, length);
            let base = random_wall_matrix(courses, length, &mut rnd);
            let n = base.dofs();
            let rows: Vec<([usize; 6], [f64; 6], f64)> = (0..6)
                .map(|k| {
                    let (a, b) = pairs[(k * 7919) % pairs.len()];
                    let idx = [3 * a, 3 * a + 1, 3 * a + 2, 3 * b, 3 * b + 1, 3 * b + 2];
                    let coef = [rnd(), rnd(), rnd(), rnd(), rnd(), rnd()];
                    (idx, coef, stiffness * (rnd() + 1.5))
                })
                .collect();
            // Rows 0-2 are in the matrix and leave; rows 3-5 enter.
            let mut before = base.clone();
            for (idx, coef, rho) in &rows[..3] {
                before.add_outer(*rho, idx, coef);
            }
            let mut after = base.clone();
            for (idx, coef, rho) in &rows[3..] {
                after.add_outer(*rho, idx, coef);
            }
            assert!(before.factor() && after.factor());
            let mut updated = before.clone();
            for (idx, coef, rho) in &rows[3..] {
                assert!(updated.update(*rho, idx, coef));
            }
            for (idx, coef, rho) in &rows[..3] {
                assert!(
                    updated.update(-rho, idx, coef),
                    "{courses} courses: downdate refused"
                );
            }
            assert!(updated.sweep.iter().all(|&w| w == 0.0));
            for _ in 0..3 {
                let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
                let (mut x, mut y) = (b.clone(), b.clone());
                updated.solve(&mut x);
                after.solve(&mut y);
                let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let err = x
                    .iter()
                    .zip(&y)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                let bound = 10.0 * f64::EPSILON * 2.5 * stiffness;
                assert!(
                    err <= bound * scale,
                    "{courses} x {length}: {err} of {scale}"
                );
            }
            // Taking out a row twice leaves `K - rho c c'`, indefinite: refused.
            let (idx, coef, rho) = &rows[0];
            let mut twice = before.clone();
            assert!(twice.update(-rho, idx, coef));
            assert!(
                !twice.update(-rho, idx, coef),
                "{n_blocks} blocks: indefinite accepted"
            );
            assert!(twice.sweep.iter().all(|&w| w == 0.0));
        }
    }

    /// The factorisation (a block's three rows at once, portable and AVX) against the row-by-row
    /// algorithm, on walls whose rows reach back 1 to 23 blocks.
    #[test]
    fn the_factor_is_the_row_by_row_factor_to_the_bit() {
        let mut rnd = sequence(11);
        for (courses, length) in [(1, 3), (2, 5), (3, 8), (6, 7), (10, 21)] {
            let mut env = random_wall_matrix(courses, length, &mut rnd);
            let mut reference = env.clone();
            factor_row_by_row(&mut reference);
            let mut portable = env.clone();
            assert!(env.factor() && portable.factor_any());
            assert_eq!(
                portable.val, reference.val,
                "{courses} x {length}, portable"
            );
            assert_eq!(env.val, reference.val, "{courses} x {length}");
        }
    }

    /// The reverse Cuthill-McKee order of a chain of blocks in scrambled numbering keeps every
    /// row within one block of the diagonal: the envelope of a column is 3 x 6 wide.
    #[test]
    fn a_column_in_any_numbering_gets_a_narrow_envelope() {
        let n_blocks = 30;
        let label = |k: usize| (k * 7) % n_blocks; // 7 and 30 are coprime
        let pairs: Vec<(usize, usize)> = (0..n_blocks - 1)
            .map(|k| (label(k), label(k + 1)))
            .collect();
        let env = Envelope::new(n_blocks, &pairs);
        // Rows of the first block hold 1..3 entries, every other row at most 6.
        assert!(env.stored() <= 6 * 3 * n_blocks, "stored {}", env.stored());
        assert_eq!(env.dofs(), 3 * n_blocks);
    }

    /// Pairs of a running-bond wall of `courses` courses numbered course by course: even
    /// courses of `length` unit blocks, odd ones with half blocks at their ends; a block touches
    /// its neighbours in its course and the blocks above it that it overlaps.
    fn running_bond(courses: usize, length: usize) -> (usize, Vec<(usize, usize)>) {
        let spans = |c: usize| -> Vec<(f64, f64)> {
            if c.is_multiple_of(2) {
                (0..length).map(|k| (k as f64, k as f64 + 1.0)).collect()
            } else {
                let mut edges = vec![0.0];
                edges.extend((0..length).map(|k| k as f64 + 0.5));
                edges.push(length as f64);
                edges.windows(2).map(|w| (w[0], w[1])).collect()
            }
        };
        let (mut pairs, mut first) = (Vec::new(), 0);
        for c in 0..courses {
            let (here, above) = (spans(c), spans(c + 1));
            for k in 0..here.len() {
                if k + 1 < here.len() {
                    pairs.push((first + k, first + k + 1));
                }
                for (j, s) in above.iter().enumerate() {
                    if c + 1 < courses && s.0 < here[k].1 && here[k].0 < s.1 {
                        pairs.push((first + k, first + here.len() + j));
                    }
                }
            }
            first += here.len();
        }
        (first, pairs)
    }

    /// A wall taller than it is long keeps its course-by-course order (rows about one course
    /// wide: 66.4 DOFs on 40 courses of 21, where RCM's diagonal levels give 75.2), and a long
    /// low wall gets RCM's order, about one column of courses wide (31.5 DOFs on 10 courses),
    /// which it keeps as it grows longer.
    #[test]
    fn a_wall_gets_the_narrower_of_its_course_order_and_rcm() {
        let mean_width = |courses: usize, length: usize| {
            let (n_blocks, pairs) = running_bond(courses, length);
            let env = Envelope::new(n_blocks, &pairs);
            env.stored() as f64 / env.dofs() as f64
        };
        let tall = mean_width(40, 21);
        // Odd courses hold 22 blocks: a block's row reaches back at most one course and one
        // block, 23 blocks.
        assert!(tall <= 3.0 * 23.0, "40 courses of 21: mean width {tall}");
        let low = mean_width(10, 21);
        assert!(low <= 3.0 * 12.0, "10 courses of 21: mean width {low}");
        // Grown along its length, the low wall keeps that width (33.9 DOFs on 10 courses of
        // 84), so its factorisation's work grows as its blocks do.
        let long = mean_width(10, 84);
        assert!(
            long <= 3.0 * 12.0 && long < 1.1 * low,
            "10 courses of 84: mean width {long}, against {low} on 10 courses of 21"
        );
    }

    #[test]
    fn a_singular_matrix_is_refused() {
        let mut env = Envelope::new(2, &[(0, 1)]);
        env.add_outer(1.0, &[0, 3], &[1.0, -1.0]);
        assert!(!env.factor());
    }
}
