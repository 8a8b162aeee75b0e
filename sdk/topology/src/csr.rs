//! Compressed sparse rows: the flat list-of-lists used by every adjacency structure.

/// A list of lists of `u32` in compressed sparse row form: row `i` is
/// `items[offsets[i] as usize..offsets[i + 1] as usize]`.
///
/// Invariants (checked by [`Csr::from_parts`]): `offsets` is non-empty, starts at 0, never
/// decreases, and ends at `items.len()`. Both arrays are plain `Vec<u32>`, so they can be
/// handed to or received from the host as `list<u32>` without conversion.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Csr {
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl Default for Csr {
    /// No rows.
    fn default() -> Self {
        Self::empty(0)
    }
}

impl Csr {
    /// Wraps `offsets` and `items`, or returns `None` if they break the invariants. O(rows).
    pub fn from_parts(offsets: Vec<u32>, items: Vec<u32>) -> Option<Self> {
        let ok = offsets.first() == Some(&0)
            && offsets.last().map(|&l| l as usize) == Some(items.len())
            && offsets.windows(2).all(|w| w[0] <= w[1]);
        ok.then_some(Self { offsets, items })
    }

    /// Wraps parts the caller has built correctly (checked in debug builds only).
    pub(crate) fn from_parts_unchecked(offsets: Vec<u32>, items: Vec<u32>) -> Self {
        debug_assert!(Self::from_parts(offsets.clone(), items.clone()).is_some());
        Self { offsets, items }
    }

    /// An empty CSR with `rows` empty rows.
    pub fn empty(rows: usize) -> Self {
        Self { offsets: vec![0; rows + 1], items: Vec::new() }
    }

    /// The number of rows. O(1).
    #[inline]
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Whether there are no rows. O(1).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row `i`. O(1). Panics if `i >= self.len()`.
    #[inline]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Row `i`, or `None` if out of range. O(1).
    #[inline]
    pub fn get(&self, i: usize) -> Option<&[u32]> {
        (i < self.len()).then(|| self.row(i))
    }

    /// The length of row `i`. O(1). Panics if `i >= self.len()`.
    #[inline]
    pub fn row_len(&self, i: usize) -> usize {
        (self.offsets[i + 1] - self.offsets[i]) as usize
    }

    /// The offsets array (`len() + 1` entries).
    #[inline]
    pub fn offsets(&self) -> &[u32] {
        &self.offsets
    }

    /// All items, row after row.
    #[inline]
    pub fn items(&self) -> &[u32] {
        &self.items
    }

    /// Iterates over the rows in order.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.offsets.windows(2).map(|w| &self.items[w[0] as usize..w[1] as usize])
    }

    /// Gives back `(offsets, items)`.
    pub fn into_parts(self) -> (Vec<u32>, Vec<u32>) {
        (self.offsets, self.items)
    }
}

/// Calls `f(k, item)` for every item of a row in order, `k` counting from 0, four items per
/// loop turn and the last up to three without a loop. In the sandbox every loop turn checks
/// the run's deadline (wasmtime's epoch check); over rows of about six neighbours, one turn
/// per item cost Taubin smoothing half its time.
///
/// ```
/// let mut seen = Vec::new();
/// meshflow_topology::for_each_by_four(&[7, 8, 9, 10, 11], |k, item| seen.push((k, item)));
/// assert_eq!(seen, [(0, 7), (1, 8), (2, 9), (3, 10), (4, 11)]);
/// ```
#[inline(always)]
pub fn for_each_by_four(row: &[u32], mut f: impl FnMut(usize, u32)) {
    let mut quads = row.chunks_exact(4);
    let mut k = 0;
    for quad in &mut quads {
        f(k, quad[0]);
        f(k + 1, quad[1]);
        f(k + 2, quad[2]);
        f(k + 3, quad[3]);
        k += 4;
    }
    match *quads.remainder() {
        [a] => f(k, a),
        [a, b] => {
            f(k, a);
            f(k + 1, b);
        }
        [a, b, c] => {
            f(k, a);
            f(k + 1, b);
            f(k + 2, c);
        }
        _ => {}
    }
}
