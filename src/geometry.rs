//! Contact detection between rectangular blocks and the ground.
//!
//! Sign conventions (used everywhere else): a contact point belongs to a pair (A, B) where A
//! owns the face (A may be the ground) and B the other body; the unit normal `n` points from A
//! into B; the tangent is `t = (n_z, -n_x)`; the signed gap is positive when open.
//!
//! Block-block pairs: the reference face is the face (of either block) with the largest
//! separation (separating-axis test); ties within a relative 1e-9 go to the lower-indexed
//! block, then the lower face index, so a corner-corner tie is broken deterministically. The
//! contact points are the two ends of the overlap of the reference face and the most
//! anti-parallel face of the other block: a vertex of one body against a face of the other.

/// A body's pose: centroid and rotation (counter-clockwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub x: f64,
    pub z: f64,
    pub phi: f64,
}

/// A rectangle of half-width `b` and half-height `h`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    pub b: f64,
    pub h: f64,
}

impl Rect {
    /// Vertices in counter-clockwise order: bottom-left, bottom-right, top-right, top-left.
    pub fn vertices(&self, p: &Pose) -> [(f64, f64); 4] {
        let (s, c) = p.phi.sin_cos();
        let local = [
            (-self.b, -self.h),
            (self.b, -self.h),
            (self.b, self.h),
            (-self.b, self.h),
        ];
        local.map(|(lx, lz)| (p.x + c * lx - s * lz, p.z + s * lx + c * lz))
    }
    pub fn min_dim(&self) -> f64 {
        2.0 * self.b.min(self.h)
    }
}

/// A rectangle at a pose: its vertices (as [`Rect::vertices`]) and, once a block pair asks for
/// them, the outward unit normals of its faces; computed once per detection, not once per pair.
#[derive(Debug, Clone)]
pub struct Placed {
    pub rect: Rect,
    pub vertices: [(f64, f64); 4],
    normals: std::cell::OnceCell<[(f64, f64); 4]>,
}

impl Placed {
    pub fn new(rect: &Rect, pose: &Pose) -> Self {
        Placed {
            rect: *rect,
            vertices: rect.vertices(pose),
            normals: std::cell::OnceCell::new(),
        }
    }

    /// Outward unit normals of the faces (face k from vertex k to k+1).
    pub fn normals(&self) -> [(f64, f64); 4] {
        *self
            .normals
            .get_or_init(|| [0, 1, 2, 3].map(|k| face_normal(&self.vertices, k)))
    }
}

/// One contact point.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactPoint {
    /// Body owning the face (`None`: the ground).
    pub a: Option<usize>,
    /// The other body.
    pub b: usize,
    /// Location, m.
    pub point: (f64, f64),
    /// Unit normal from A into B.
    pub normal: (f64, f64),
    /// Signed gap, m (> 0 open).
    pub gap: f64,
    /// Which feature pair makes the point (stable from step to step while the configuration
    /// persists): for the ground, the block's vertex; for blocks, the reference owner, face
    /// and end. Used to warm-start solvers.
    pub feature: u16,
}

/// Axis-aligned bounding box of a placed rectangle.
fn aabb(block: &Placed) -> (f64, f64, f64, f64) {
    let mut bb = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, z) in &block.vertices {
        bb.0 = bb.0.min(x);
        bb.1 = bb.1.max(x);
        bb.2 = bb.2.min(z);
        bb.3 = bb.3.max(z);
    }
    bb
}

/// Up to this many blocks the broad phase tests every pair (cheaper than building the grid).
pub const ALL_PAIRS_UP_TO: usize = 8;

/// Candidate block pairs whose bounding boxes, enlarged by `margin(i)`, overlap (closed
/// intervals on both axes), sorted.
///
/// A uniform grid, no all-pairs search: with cells a little larger than the largest box, two
/// boxes can overlap only if the cells of their lower-left corners are neighbours, so each box
/// is tested against the boxes of nine cells. For blocks of similar size (walls, columns) the
/// cost is linear in the number of blocks; a sweep along one axis would test every block of a
/// column against every other.
pub fn broad_phase(blocks: &[Placed], margin: &dyn Fn(usize) -> f64) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    BroadPhase::default().pairs_into(blocks, margin, &mut pairs);
    pairs
}

/// A box: `(x_min, x_max, z_min, z_max)`.
type Box4 = (f64, f64, f64, f64);

/// [`broad_phase`] with its working storage kept from one call to the next. The grid's order of
/// the blocks starts from the last call's, which is still sorted where every block stayed in
/// its cell (a wall at rest; the sort then only checks it), and the pairs are sorted by buckets
/// of their first block: the same pairs in the same order as [`broad_phase`], in time linear in
/// the blocks and pairs.
#[derive(Debug, Default)]
pub struct BroadPhase {
    boxes: Vec<Box4>,
    /// Each block's grid cell and index, sorted.
    order: Vec<((i64, i64), usize)>,
    /// Where each first block's pairs start in `sorted`, then the next free place.
    starts: Vec<usize>,
    sorted: Vec<(usize, usize)>,
}

impl BroadPhase {
    /// [`broad_phase`] into `pairs`.
    pub fn pairs_into(
        &mut self,
        blocks: &[Placed],
        margin: &dyn Fn(usize) -> f64,
        pairs: &mut Vec<(usize, usize)>,
    ) {
        pairs.clear();
        let enlarged = |i: usize| {
            let m = margin(i);
            let b = aabb(&blocks[i]);
            (b.0 - m, b.1 + m, b.2 - m, b.3 + m)
        };
        let overlaps = |a: &Box4, b: &Box4| a.0 <= b.1 && b.0 <= a.1 && a.2 <= b.3 && b.2 <= a.3;
        if blocks.len() <= ALL_PAIRS_UP_TO {
            // A few blocks: every pair (cheaper than the grid; the boxes stay on the stack).
            let mut few = [(0.0, 0.0, 0.0, 0.0); ALL_PAIRS_UP_TO];
            for (i, b) in few.iter_mut().enumerate().take(blocks.len()) {
                *b = enlarged(i);
            }
            for i in 0..blocks.len() {
                for j in i + 1..blocks.len() {
                    if overlaps(&few[i], &few[j]) {
                        pairs.push((i, j));
                    }
                }
            }
            return;
        }
        let boxes = &mut self.boxes;
        boxes.clear();
        boxes.extend((0..blocks.len()).map(enlarged));
        let largest = boxes
            .iter()
            .map(|b| (b.1 - b.0).max(b.3 - b.2))
            .fold(0.0f64, f64::max);
        let x0 = boxes.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
        let z0 = boxes.iter().map(|b| b.2).fold(f64::INFINITY, f64::min);
        if !(largest.is_finite() && largest > 0.0 && x0.is_finite() && z0.is_finite()) {
            // Degenerate boxes: test every pair.
            for i in 0..boxes.len() {
                for j in i + 1..boxes.len() {
                    if overlaps(&boxes[i], &boxes[j]) {
                        pairs.push((i, j));
                    }
                }
            }
            return;
        }
        // The margin keeps corner cells of overlapping boxes neighbours despite rounding.
        let cell = largest * (1.0 + 1e-9);
        let key = |b: &Box4| {
            (
                ((b.0 - x0) / cell).floor() as i64,
                ((b.2 - z0) / cell).floor() as i64,
            )
        };
        // The last call's order is a permutation of the same blocks when their number is the
        // same; the keys are distinct (the index is part of them), so the sorted order is the
        // same whatever order the sort starts from.
        let order = &mut self.order;
        if order.len() == boxes.len() {
            for e in order.iter_mut() {
                e.0 = key(&boxes[e.1]);
            }
        } else {
            order.clear();
            order.extend(boxes.iter().enumerate().map(|(i, b)| (key(b), i)));
        }
        order.sort_unstable();
        let mut test = |i: usize, j: usize| {
            if overlaps(&boxes[i], &boxes[j]) {
                pairs.push((i.min(j), i.max(j)));
            }
        };
        // Each pair once: the boxes after this one in its own cell and the cell above, then
        // the three cells of the next column (contiguous in the sorted order).
        for (a, &((cx, cz), i)) in order.iter().enumerate() {
            for &(k, j) in &order[a + 1..] {
                if k.0 != cx || k.1 > cz + 1 {
                    break;
                }
                test(i, j);
            }
            let from = order.partition_point(|e| e.0 < (cx + 1, cz - 1));
            for &(k, j) in &order[from..] {
                if k > (cx + 1, cz + 1) {
                    break;
                }
                test(i, j);
            }
        }
        sort_pairs(boxes.len(), pairs, &mut self.starts, &mut self.sorted);
    }
}

/// Sorts `pairs` (distinct, first block below the second, both below `n`): a counting sort by
/// the first block, then each block's few pairs by the second; `starts` and `sorted` are
/// working storage.
fn sort_pairs(
    n: usize,
    pairs: &mut Vec<(usize, usize)>,
    starts: &mut Vec<usize>,
    sorted: &mut Vec<(usize, usize)>,
) {
    starts.clear();
    starts.resize(n + 1, 0);
    for &(i, _) in pairs.iter() {
        starts[i + 1] += 1;
    }
    for i in 0..n {
        starts[i + 1] += starts[i];
    }
    sorted.clear();
    sorted.resize(pairs.len(), (0, 0));
    for &p in pairs.iter() {
        sorted[starts[p.0]] = p;
        starts[p.0] += 1;
    }
    // `starts[i]` is now where block i's pairs end, which is where block i + 1's start.
    let mut from = 0;
    for &to in &starts[..n] {
        sorted[from..to].sort_unstable();
        from = to;
    }
    std::mem::swap(pairs, sorted);
}

/// Contacts of block `i` with the flat ground at height `ground_z`: every vertex whose gap is
/// below `reach`.
pub fn ground_contacts(
    i: usize,
    block: &Placed,
    ground_z: f64,
    reach: &dyn Fn((f64, f64), f64) -> bool,
    out: &mut Vec<ContactPoint>,
) {
    for (k, &v) in block.vertices.iter().enumerate() {
        let gap = v.1 - ground_z;
        if reach(v, gap) {
            out.push(ContactPoint {
                a: None,
                b: i,
                point: v,
                normal: (0.0, 1.0),
                gap,
                feature: k as u16,
            });
        }
    }
}

fn cross(a: (f64, f64), b: (f64, f64)) -> f64 {
    a.0 * b.1 - a.1 * b.0
}
fn dot(a: (f64, f64), b: (f64, f64)) -> f64 {
    a.0 * b.0 + a.1 * b.1
}
fn sub(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 - b.0, a.1 - b.1)
}

/// Outward unit normal of face k (from vertex k to k+1) of a counter-clockwise polygon.
fn face_normal(v: &[(f64, f64); 4], k: usize) -> (f64, f64) {
    let d = sub(v[(k + 1) % 4], v[k]);
    let l = d.0.hypot(d.1);
    (d.1 / l, -d.0 / l)
}

/// Contact points between blocks `i < j`. `reach(point, gap)` decides which candidates are kept.
pub fn block_contacts(
    (i, bi): (usize, &Placed),
    (j, bj): (usize, &Placed),
    reach: &dyn Fn((f64, f64), f64) -> bool,
    out: &mut Vec<ContactPoint>,
) {
    let (vi, ni) = (bi.vertices, bi.normals());
    let (vj, nj) = (bj.vertices, bj.normals());
    let scale = bi.rect.b + bi.rect.h + bj.rect.b + bj.rect.h;
    // Reference face: the largest separation over the faces of both blocks.
    let mut best: Option<(f64, usize, usize)> = None; // (separation, owner 0|1, face)
    for (owner, (va, na, vb)) in [(&vi, &ni, &vj), (&vj, &nj, &vi)].into_iter().enumerate() {
        for k in 0..4 {
            let n = na[k];
            let sep = vb
                .iter()
                .map(|&v| dot(n, sub(v, va[k])))
                .fold(f64::INFINITY, f64::min);
            let better = match best {
                None => true,
                Some((s, _, _)) => sep > s + 1e-9 * scale,
            };
            if better {
                best = Some((sep, owner, k));
            }
        }
    }
    let (_, owner, k) = best.expect("rectangles have faces");
    let (a, va, b, vb, nb) = if owner == 0 {
        (i, &vi, j, &vj, &nj)
    } else {
        (j, &vj, i, &vi, &ni)
    };
    let n = if owner == 0 { ni[k] } else { nj[k] };
    let (p0, p1) = (va[k], va[(k + 1) % 4]);
    // Incident face of B: most anti-parallel to n.
    let m = (0..4)
        .min_by(|&x, &y| dot(nb[x], n).total_cmp(&dot(nb[y], n)))
        .unwrap();
    let (q0, q1) = (vb[m], vb[(m + 1) % 4]);
    let tan = sub(p1, p0);
    let len2 = dot(tan, tan);
    let tol = 1e-9;
    let before = out.len();
    // Feature ids: reference owner, reference face, incident face, end (0, 1: B's vertices on
    // A's face; 2, 3: A's vertices on B's face).
    let base = (owner * 256 + k * 64 + m * 8) as u16;
    // Which ends of A's face a vertex of B covers (within `tol` of it along the face).
    let mut covered = [false; 2];
    // B's vertices over A's face.
    for (e, q) in [q0, q1].into_iter().enumerate() {
        let s = dot(sub(q, p0), tan) / len2;
        if (-tol..=1.0 + tol).contains(&s) {
            let gap = dot(n, sub(q, p0));
            if reach(q, gap) {
                covered[0] |= s <= tol;
                covered[1] |= s >= 1.0 - tol;
                out.push(ContactPoint {
                    a: Some(a),
                    b,
                    point: q,
                    normal: n,
                    gap,
                    feature: base + e as u16,
                });
            }
        }
    }
    // A's face ends under B's face: each is a vertex of A on B's incident face, and is made one
    // (B the face owner, B's face normal, the vertex's distance from B's face line), so that its
    // gap is that distance however the bodies move (`native::material`). Measured along A's
    // normal, as the end of A's face, it is the distance only while the faces are parallel.
    let d = sub(q1, q0);
    let denom = cross(n, d);
    // |cross(n, d)| > 1e-12 |d|, squared (no square root per pair).
    if denom * denom > 1e-24 * dot(d, d) {
        let nm = nb[m];
        for (e, p) in [p0, p1].into_iter().enumerate() {
            let lam = cross(sub(q0, p), d) / denom; // p + lam n lies on the line q0-q1
            let hit = (p.0 + lam * n.0, p.1 + lam * n.1);
            let s = dot(sub(hit, q0), d) / dot(d, d);
            // Within `tol` of an end of B's face, the two faces end together to round-off: the
            // end is A's vertex unless a vertex of B already covers it. (Left out there, such an
            // end was missed by both windows where the corners were 1.6e-10 to 3.2e-10 m apart
            // on faces of 0.16 and 0.32 m, the ends of a running-bond wall's courses.)
            let inside = s > tol && s < 1.0 - tol;
            if inside || ((-tol..=1.0 + tol).contains(&s) && !covered[e]) {
                let dup = out[before..]
                    .iter()
                    .any(|c| (c.point.0 - p.0).abs() + (c.point.1 - p.1).abs() < 1e-9 * scale);
                let gap = dot(nm, sub(p, q0));
                if !dup && reach(p, gap) {
                    out.push(ContactPoint {
                        a: Some(b),
                        b: a,
                        point: p,
                        normal: nm,
                        gap,
                        feature: base + 2 + e as u16,
                    });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn narrower_block_on_wider_gives_its_two_bottom_corners() {
        let lower = Rect { b: 0.625, h: 0.625 };
        let upper = Rect { b: 0.5, h: 1.25 };
        let pl = Pose {
            x: 0.0,
            z: 0.625,
            phi: 0.0,
        };
        let pu = Pose {
            x: 0.0,
            z: 1.25 + 1.25,
            phi: 0.0,
        };
        let mut out = Vec::new();
        block_contacts(
            (0, &Placed::new(&lower, &pl)),
            (1, &Placed::new(&upper, &pu)),
            &|_, g| g < 0.1,
            &mut out,
        );
        assert_eq!(out.len(), 2);
        for c in &out {
            assert_eq!(c.a, Some(0));
            assert!((c.normal.1 - 1.0).abs() < 1e-12);
            assert!(c.gap.abs() < 1e-12);
            assert!((c.point.0.abs() - 0.5).abs() < 1e-12);
        }
    }

    #[test]
    fn wider_block_on_narrower_uses_the_lower_corners() {
        let lower = Rect { b: 0.5, h: 0.5 };
        let upper = Rect { b: 1.0, h: 0.5 };
        let pl = Pose {
            x: 0.0,
            z: 0.5,
            phi: 0.0,
        };
        let pu = Pose {
            x: 0.0,
            z: 1.5 + 1e-3,
            phi: 0.0,
        };
        let mut out = Vec::new();
        block_contacts(
            (0, &Placed::new(&lower, &pl)),
            (1, &Placed::new(&upper, &pu)),
            &|_, g| g < 0.1,
            &mut out,
        );
        assert_eq!(out.len(), 2, "{out:?}");
        for c in &out {
            assert!((c.point.0.abs() - 0.5).abs() < 1e-12, "{c:?}");
            assert!((c.gap - 1e-3).abs() < 1e-12);
        }
        each_is_a_vertex_on_a_face(&out, &[Placed::new(&lower, &pl), Placed::new(&upper, &pu)]);
    }

    /// Every point is a vertex of block `b` on a face of block `a`: its normal is that face's
    /// outward normal and its gap the vertex's distance from the face line.
    fn each_is_a_vertex_on_a_face(out: &[ContactPoint], placed: &[Placed]) {
        for c in out {
            let (a, b) = (&placed[c.a.unwrap()], &placed[c.b]);
            let at = |p: (f64, f64), q: (f64, f64)| (p.0 - q.0).abs() + (p.1 - q.1).abs() < 1e-12;
            assert!(b.vertices.iter().any(|&v| at(v, c.point)), "{c:?}");
            let k = (0..4)
                .find(|&k| at(a.normals()[k], c.normal))
                .unwrap_or_else(|| panic!("not a face normal of a: {c:?}"));
            let gap = dot(c.normal, sub(c.point, a.vertices[k]));
            assert!((c.gap - gap).abs() < 1e-15, "{c:?}: {gap:e}");
        }
    }

    /// A block turned 0.014 rad, overhanging the left end of the block below, whose top-left
    /// corner touches its bottom face; its own bottom-right corner is 1.3 mm over the lower
    /// block's top face. The reference face is the upper block's (the lower block's would have
    /// the overhanging corner below its line), and its right end is a vertex of the upper block
    /// over the lower block's face: it is made one, with that face's normal and the distance
    /// from its line (as the end of the upper block's face it was measured along the upper
    /// block's normal, and the impact stepper held the wrong distance as the corner slid).
    #[test]
    fn an_overlap_end_of_the_reference_face_is_a_vertex_on_the_other_face() {
        let lower = Rect { b: 0.0875, h: 0.24 };
        let upper = Rect {
            b: 0.0565,
            h: 0.131,
        };
        let alpha: f64 = 0.014;
        let (s, c) = alpha.sin_cos();
        // The upper block's bottom face passes the lower block's top-left corner (-0.0875,
        // 0.48), its bottom-left corner 0.02 m further left.
        let corner = (-0.1075, 0.48 - 0.02 * s / c);
        let (x, z) = (
            corner.0 + c * upper.b - s * upper.h,
            corner.1 + s * upper.b + c * upper.h,
        );
        let placed = [
            Placed::new(
                &lower,
                &Pose {
                    x: 0.0,
                    z: 0.24,
                    phi: 0.0,
                },
            ),
            Placed::new(&upper, &Pose { x, z, phi: alpha }),
        ];
        let mut out = Vec::new();
        block_contacts((0, &placed[0]), (1, &placed[1]), &|_, g| g < 0.1, &mut out);
        assert_eq!(out.len(), 2, "{out:?}");
        each_is_a_vertex_on_a_face(&out, &placed);
        let right = out
            .iter()
            .find(|c| c.b == 1)
            .expect("the upper block's corner");
        let over = corner.1 + 2.0 * upper.b * s - 0.48;
        assert!(over > 1e-3, "{over:e}");
        assert!((right.gap - over).abs() < 1e-15, "{right:?}: {over:e}");
        assert_eq!(right.normal, (0.0, 1.0));
    }

    /// The end of a running-bond wall's course: a whole block (face 0.32 m) on a half block
    /// (face 0.16 m), their right faces flush to round-off, `delta` the upper corner's overhang.
    /// Each end of the bed joint must give one point, a vertex on a face, whatever `delta`: with
    /// the upper corner 1.67e-10 m past the lower one, found by `tests/proptest_assemblies.rs`,
    /// neither corner was kept (the lower face's window reached 1.6e-10 m past its end, the
    /// upper's stopped 3.2e-10 m short of its own), and the upper block sank 3.2e-6 m into the
    /// half block in the next step.
    #[test]
    fn faces_ending_together_to_round_off_keep_their_end() {
        let half = Rect {
            b: 0.0789,
            h: 0.149,
        };
        let whole = Rect {
            b: 0.1578,
            h: 0.149,
        };
        for delta in [
            -5e-10, -3e-10, -1.67e-10, -1e-10, 0.0, 1e-10, 1.67e-10, 2.5e-10, 3e-10, 5e-10,
        ] {
            let placed = [
                Placed::new(
                    &half,
                    &Pose {
                        x: 5.285,
                        z: 1.64,
                        phi: 0.0,
                    },
                ),
                Placed::new(
                    &whole,
                    &Pose {
                        x: 5.285 + half.b - whole.b + delta,
                        z: 1.64 + half.h + whole.h,
                        phi: 0.0,
                    },
                ),
            ];
            let mut out = Vec::new();
            block_contacts((0, &placed[0]), (1, &placed[1]), &|_, g| g < 0.1, &mut out);
            assert_eq!(out.len(), 2, "delta {delta:e}: {out:?}");
            each_is_a_vertex_on_a_face(&out, &placed);
            let right_end = 5.285 + half.b;
            assert!(
                out.iter()
                    .any(|c| (c.point.0 - right_end).abs() <= delta.abs() + 1e-15),
                "delta {delta:e}: no point at the right end: {out:?}"
            );
        }
    }

    #[test]
    fn broad_phase_finds_only_touching_pairs() {
        let r = Rect { b: 0.5, h: 0.5 };
        let poses: Vec<Pose> = (0..5)
            .map(|k| Pose {
                x: 3.0 * k as f64,
                z: 0.5,
                phi: 0.0,
            })
            .chain(std::iter::once(Pose {
                x: 0.0,
                z: 1.5,
                phi: 0.0,
            }))
            .collect();
        let rects = vec![r; poses.len()];
        let placed: Vec<Placed> = rects
            .iter()
            .zip(&poses)
            .map(|(r, p)| Placed::new(r, p))
            .collect();
        let pairs = broad_phase(&placed, &|_| 0.01);
        assert_eq!(pairs, vec![(0, 5)]);
    }

    /// Every pair whose enlarged boxes overlap, by testing all of them.
    fn all_overlapping_pairs(blocks: &[Placed], margin: f64) -> Vec<(usize, usize)> {
        let boxes: Vec<_> = blocks
            .iter()
            .map(|b| {
                let a = aabb(b);
                (a.0 - margin, a.1 + margin, a.2 - margin, a.3 + margin)
            })
            .collect();
        let mut pairs = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (boxes[i], boxes[j]);
                if a.0 <= b.1 && b.0 <= a.1 && a.2 <= b.3 && b.2 <= a.3 {
                    pairs.push((i, j));
                }
            }
        }
        pairs
    }

    /// The grid broad phase finds exactly the pairs an all-pairs test finds: random layouts of
    /// few and many blocks of similar and of very different sizes, and a running-bond wall whose
    /// blocks touch exactly (closed intervals).
    #[test]
    fn broad_phase_equals_all_pairs() {
        let mut rnd = crate::test_random::uniform(12345);
        let mut layouts: Vec<(Vec<Rect>, Vec<Pose>)> = Vec::new();
        for case in 0..80 {
            let n = [5, 30, 200][case % 3];
            let spread = if case % 2 == 0 { 1.0 } else { 8.0 };
            let rects: Vec<Rect> = (0..n)
                .map(|_| Rect {
                    b: 0.05 + spread * rnd() * rnd(),
                    h: 0.05 + spread * rnd() * rnd(),
                })
                .collect();
            let poses: Vec<Pose> = (0..n)
                .map(|_| Pose {
                    x: 20.0 * rnd(),
                    z: 5.0 * rnd(),
                    phi: rnd() - 0.5,
                })
                .collect();
            layouts.push((rects, poses));
        }
        let (mut rects, mut poses) = (Vec::new(), Vec::new());
        for c in 0..12 {
            for i in 0..15 {
                rects.push(Rect { b: 0.6, h: 0.25 });
                let shift = if c % 2 == 1 { 0.3 } else { 0.0 };
                poses.push(Pose {
                    x: 0.3 + 0.6 * i as f64 + shift,
                    z: 0.125 + 0.25 * c as f64,
                    phi: 0.0,
                });
            }
        }
        layouts.push((rects, poses));
        for (rects, poses) in &layouts {
            let n = rects.len();
            let margin = |_: usize| 0.05;
            let placed: Vec<Placed> = rects
                .iter()
                .zip(poses)
                .map(|(r, p)| Placed::new(r, p))
                .collect();
            let got = broad_phase(&placed, &margin);
            let bb = |i: usize| {
                let v = rects[i].vertices(&poses[i]);
                let xs = v.iter().map(|p| p.0);
                let zs = v.iter().map(|p| p.1);
                (
                    xs.clone().fold(f64::INFINITY, f64::min) - 0.05,
                    xs.fold(f64::NEG_INFINITY, f64::max) + 0.05,
                    zs.clone().fold(f64::INFINITY, f64::min) - 0.05,
                    zs.fold(f64::NEG_INFINITY, f64::max) + 0.05,
                )
            };
            let mut want = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    let (a, b) = (bb(i), bb(j));
                    if a.0 <= b.1 && b.0 <= a.1 && a.2 <= b.3 && b.2 <= a.3 {
                        want.push((i, j));
                    }
                }
            }
            assert!(!want.is_empty() || n < 10);
            assert_eq!(got, want, "{n} blocks");
        }
    }

    #[test]
    fn a_kept_broad_phase_finds_every_overlapping_pair_in_order_call_after_call() {
        // Blocks of two sizes on a jittered grid, moved, reshuffled and changed in number from
        // one call to the next, as a wall's blocks are from step to step; a linear congruential
        // generator keeps the case reproducible.
        let mut uniform = crate::test_random::uniform(12345);
        let mut kept = BroadPhase::default();
        let mut pairs = Vec::new();
        let mut checked = 0;
        for (call, n) in [40usize, 40, 40, 63, 63, 9, 40].into_iter().enumerate() {
            let placed: Vec<Placed> = (0..n)
                .map(|k| {
                    let rect = if k % 3 == 0 {
                        Rect { b: 0.3, h: 0.125 }
                    } else {
                        Rect { b: 0.15, h: 0.125 }
                    };
                    // Each call places the blocks in other slots (17 is prime to every n).
                    let slot = (17 * k + 5 * call) % n;
                    let pose = Pose {
                        x: 0.55 * (slot % 8) as f64 + 0.1 * uniform() + 0.01 * call as f64,
                        z: 0.26 * (slot / 8) as f64 + 0.02 * uniform(),
                        phi: 0.3 * (uniform() - 0.5),
                    };
                    Placed::new(&rect, &pose)
                })
                .collect();
            kept.pairs_into(&placed, &|_| 0.01, &mut pairs);
            let expected = all_overlapping_pairs(&placed, 0.01);
            assert_eq!(pairs, expected, "call {call}, {n} blocks");
            assert_eq!(broad_phase(&placed, &|_| 0.01), expected);
            checked += expected.len();
        }
        // The case tests something: touching neighbours in every call.
        assert!(checked > 100, "{checked} pairs");
    }
}
