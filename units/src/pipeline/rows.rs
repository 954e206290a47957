//! Input rows of one path, stored flat.
//!
//! A frame has tens of input codes per pixel and method. Kept as one heap
//! vector per pixel they cost an allocation and a free each, and the
//! transposition into the program's columns reads them scattered over the
//! heap. [`Rows`] keeps them in one row-major buffer of a fixed width, with
//! a mark per row for fragments that were skipped (their triangle could
//! not be set up).

/// Rows of `width` input codes each, row-major in one buffer: row `i` is
/// `codes[i * width..(i + 1) * width]`. A skipped row holds `width` zeros
/// and is not live ([`Rows::get`] gives `None` for it).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Rows {
    width: usize,
    codes: Vec<i128>,
    live: Vec<bool>,
    skipped: usize,
}

impl Rows {
    /// No rows yet, each to hold `width` codes.
    pub fn new(width: usize) -> Rows {
        Rows {
            width,
            ..Rows::default()
        }
    }

    /// [`Rows::new`] with room for `rows` rows.
    pub fn with_capacity(width: usize, rows: usize) -> Rows {
        Rows {
            width,
            codes: Vec::with_capacity(width * rows),
            live: Vec::with_capacity(rows),
            skipped: 0,
        }
    }

    /// Rows of the given vectors; an empty vector is a skipped row.
    ///
    /// # Panics
    ///
    /// If a non-empty vector does not hold `width` codes.
    pub fn from_vecs(width: usize, rows: &[Vec<i128>]) -> Rows {
        let mut r = Rows::with_capacity(width, rows.len());
        for v in rows {
            if v.is_empty() {
                r.push_skipped();
            } else {
                r.push(v);
            }
        }
        r
    }

    /// Codes per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows, live and skipped.
    pub fn len(&self) -> usize {
        self.live.len()
    }

    /// Whether there is no row at all.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }

    /// Skipped rows.
    pub fn skipped(&self) -> usize {
        self.skipped
    }

    /// Append a live row.
    ///
    /// # Panics
    ///
    /// If `row` does not hold [`Rows::width`] codes.
    pub fn push(&mut self, row: &[i128]) {
        assert_eq!(row.len(), self.width, "a row of {} codes", self.width);
        self.codes.extend_from_slice(row);
        self.live.push(true);
    }

    /// Append a live row written by `fill`, which appends its codes to the
    /// buffer (no vector of its own).
    ///
    /// # Panics
    ///
    /// If `fill` does not append exactly [`Rows::width`] codes.
    pub fn push_with(&mut self, fill: impl FnOnce(&mut Vec<i128>)) {
        let before = self.codes.len();
        fill(&mut self.codes);
        assert_eq!(
            self.codes.len() - before,
            self.width,
            "a row of {} codes",
            self.width
        );
        self.live.push(true);
    }

    /// Append a skipped row.
    pub fn push_skipped(&mut self) {
        self.codes.resize(self.codes.len() + self.width, 0);
        self.live.push(false);
        self.skipped += 1;
    }

    /// Row `i`, or `None` when it was skipped.
    ///
    /// # Panics
    ///
    /// If `i >= self.len()`.
    pub fn get(&self, i: usize) -> Option<&[i128]> {
        self.live[i].then(|| &self.codes[i * self.width..(i + 1) * self.width])
    }

    /// Whether row `i` is live.
    ///
    /// # Panics
    ///
    /// If `i >= self.len()`.
    pub fn is_live(&self, i: usize) -> bool {
        self.live[i]
    }

    /// Every row in order, `None` for a skipped one.
    pub fn iter(&self) -> impl Iterator<Item = Option<&[i128]>> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    /// The whole buffer, row-major (skipped rows as zeros).
    pub fn codes(&self) -> &[i128] {
        &self.codes
    }

    /// The live rows only, packed in order (a copy when rows were skipped,
    /// the buffer itself otherwise).
    pub fn live_codes(&self) -> std::borrow::Cow<'_, [i128]> {
        if self.skipped == 0 {
            return std::borrow::Cow::Borrowed(&self.codes);
        }
        let mut out = Vec::with_capacity(self.codes.len() - self.skipped * self.width);
        for r in self.iter().flatten() {
            out.extend_from_slice(r);
        }
        std::borrow::Cow::Owned(out)
    }

    /// The live rows as vectors of their own, in order (for consumers that
    /// take rows one by one, such as a vector set).
    pub fn live_vecs(&self) -> Vec<Vec<i128>> {
        self.iter().flatten().map(<[i128]>::to_vec).collect()
    }

    /// Every row as a vector, a skipped row as an empty one.
    pub fn to_vecs(&self) -> Vec<Vec<i128>> {
        self.iter()
            .map(|r| r.map_or_else(Vec::new, <[i128]>::to_vec))
            .collect()
    }

    /// Remove every row, keeping the buffers' memory.
    pub fn clear(&mut self) {
        self.codes.clear();
        self.live.clear();
        self.skipped = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::Rows;

    #[test]
    fn rows_keep_live_and_skipped_rows_in_order() {
        let mut r = Rows::new(3);
        r.push(&[1, 2, 3]);
        r.push_skipped();
        r.push_with(|c| c.extend_from_slice(&[7, 8, 9]));
        assert_eq!((r.len(), r.skipped(), r.width()), (3, 1, 3));
        assert_eq!(r.get(0), Some(&[1, 2, 3][..]));
        assert_eq!(r.get(1), None);
        assert_eq!(r.get(2), Some(&[7, 8, 9][..]));
        assert_eq!(&*r.live_codes(), &[1, 2, 3, 7, 8, 9]);
        assert_eq!(r.to_vecs(), vec![vec![1, 2, 3], vec![], vec![7, 8, 9]]);
        assert_eq!(Rows::from_vecs(3, &r.to_vecs()), r);
        r.clear();
        assert!(r.is_empty() && r.codes().is_empty() && r.skipped() == 0);
    }

    #[test]
    #[should_panic(expected = "a row of 3 codes")]
    fn a_row_of_the_wrong_width_is_refused() {
        Rows::new(3).push_with(|c| c.push(1));
    }
}
