//! The working sets an active-set search has met, to end a search that cycles.
//!
//! An active-set search (the dense back-end's, the Clarabel polish's) is deterministic: the
//! next move depends only on the working set, an ordered list of rows. A working set met again
//! means the search cycles and would run to its move limit, so it can end there with the
//! answer it would have given at the limit, or go on under Bland's rule, which cannot cycle.

/// Which row enters or leaves the working set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Rule {
    /// The most violated row enters; else the most negative multiplier leaves.
    MostViolated,
    /// The first violated row (in row order) enters; else the first negative multiplier
    /// leaves: Bland's rule, which cannot cycle; slower, so only after the other fails.
    Bland,
}

/// Working sets (ordered lists of rows) met by a search, kept in reused buffers: a set's hash,
/// and its rows in one arena.
#[derive(Default)]
pub(super) struct VisitedSets {
    hashes: Vec<u64>,
    starts: Vec<usize>,
    rows: Vec<usize>,
}

impl VisitedSets {
    pub(super) fn clear(&mut self) {
        self.hashes.clear();
        self.starts.clear();
        self.rows.clear();
    }

    /// Record `set`; false if it was met before.
    pub(super) fn insert(&mut self, set: &[usize]) -> bool {
        // FNV-1a over the rows.
        let hash = set.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &r| {
            (h ^ r as u64).wrapping_mul(0x0100_0000_01b3)
        });
        let met = (0..self.hashes.len()).any(|k| {
            let end = self.starts.get(k + 1).copied().unwrap_or(self.rows.len());
            self.hashes[k] == hash && self.rows[self.starts[k]..end] == *set
        });
        if !met {
            self.hashes.push(hash);
            self.starts.push(self.rows.len());
            self.rows.extend_from_slice(set);
        }
        !met
    }
}
