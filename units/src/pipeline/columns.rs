//! Input rows of one path, stored as the program's columns.
//!
//! The compiled program reads one slice per input port ([`Compiled`]'s
//! `run`). [`Rows`](super::Rows) keeps a frame's rows row-major and is
//! transposed before a run; [`Columns`] writes each row's codes straight
//! into their columns, as `i64` lanes, for a fixed number of rows (a
//! renderer's chunk). Most of a pipeline top's inputs are per frame or per
//! triangle (the set-up ports of [`super::rtl::setup_groups`]): within a
//! run of rows of one triangle only the per-pixel columns are written row
//! by row, and the others are filled from the run's first row when the run
//! ends ([`Columns::end_run`]).
//!
//! [`Compiled`]: crate::datapath::Compiled

/// Up to `cap` rows of `varying.len()` input codes each, column-major: the
/// live rows' codes of column `k` are `codes[k * cap..k * cap + live]`.
/// Skipped rows take no lane; [`Columns::is_live`] says which rows were.
#[derive(Clone, Debug)]
pub struct Columns {
    cap: usize,
    codes: Vec<i64>,
    /// Per column: whether it may change between rows of one run.
    varying: Vec<bool>,
    /// The columns that may change, and those that may not.
    pixel: Vec<usize>,
    constant: Vec<usize>,
    /// Live rows so far (the lanes written).
    lanes: usize,
    /// Every row, live or skipped.
    live: Vec<bool>,
    /// The first lane of the open run.
    run: usize,
    scratch: Vec<i128>,
}

impl Columns {
    /// Room for `cap` rows, one column per entry of `varying`: `true` for
    /// a column that changes from row to row, `false` for one that holds
    /// the same code on every row of a run.
    pub fn new(varying: Vec<bool>, cap: usize) -> Columns {
        let (pixel, constant) = (0..varying.len()).partition(|&k| varying[k]);
        Columns {
            cap,
            codes: vec![0; varying.len() * cap],
            scratch: Vec::with_capacity(varying.len()),
            varying,
            pixel,
            constant,
            lanes: 0,
            live: Vec::with_capacity(cap),
            run: 0,
        }
    }

    /// Codes per row.
    pub fn width(&self) -> usize {
        self.varying.len()
    }

    /// Rows, live and skipped.
    pub fn len(&self) -> usize {
        self.live.len()
    }

    /// Whether there is no row at all.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }

    /// Live rows (the lanes a run computes).
    pub fn lanes(&self) -> usize {
        self.lanes
    }

    /// Whether row `i` is live.
    ///
    /// # Panics
    ///
    /// If `i >= self.len()`.
    pub fn is_live(&self, i: usize) -> bool {
        self.live[i]
    }

    /// Append a live row written by `fill`, which appends its codes to an
    /// empty vector. The first live row of a run writes every column, the
    /// others only the varying ones.
    ///
    /// # Panics
    ///
    /// If `fill` does not append exactly [`Columns::width`] codes, if a code
    /// does not fit `i64`, or if `cap` rows are live already.
    pub fn push_with(&mut self, fill: impl FnOnce(&mut Vec<i128>)) {
        let mut row = std::mem::take(&mut self.scratch);
        row.clear();
        fill(&mut row);
        let width = self.width();
        assert_eq!(row.len(), width, "a row of {width} codes");
        let i = self.lanes;
        assert!(i < self.cap, "room for {} rows", self.cap);
        let first = i == self.run;
        for (k, &v) in row.iter().enumerate() {
            if first || self.varying[k] {
                self.codes[k * self.cap + i] = i64::try_from(v).expect("a code that fits i64");
            }
        }
        self.scratch = row;
        self.lanes += 1;
        self.live.push(true);
    }

    /// Whether a run is open: a live row was pushed since the last
    /// [`Columns::end_run`] (or [`Columns::clear`]).
    pub fn in_run(&self) -> bool {
        self.lanes > self.run
    }

    /// Append a live row of the open run given by its varying codes alone,
    /// in column order; its other codes are the run's first row's.
    ///
    /// # Panics
    ///
    /// If no run is open, if `pixel` does not hold one code per varying
    /// column, if a code does not fit `i64`, or if `cap` rows are live.
    pub fn push_pixel(&mut self, pixel: &[i128]) {
        assert!(self.in_run(), "a run opened by a whole row");
        assert_eq!(pixel.len(), self.pixel.len(), "one code per varying column");
        let i = self.lanes;
        assert!(i < self.cap, "room for {} rows", self.cap);
        for (&k, &v) in self.pixel.iter().zip(pixel) {
            self.codes[k * self.cap + i] = i64::try_from(v).expect("a code that fits i64");
        }
        self.lanes += 1;
        self.live.push(true);
    }

    /// Append `m` live rows within the open run by their varying codes:
    /// `pixels[k][t]` is row `t`'s code in varying column `k` (in column
    /// order), every slice `m` long. The same rows as `m` calls of
    /// [`Columns::push_pixel`].
    ///
    /// # Panics
    ///
    /// As [`Columns::push_pixel`]; and if the slices differ in length.
    pub fn push_pixels<T: Copy>(&mut self, pixels: &[&[T]])
    where
        i64: TryFrom<T>,
    {
        assert!(self.in_run(), "a run opened by a whole row");
        assert_eq!(
            pixels.len(),
            self.pixel.len(),
            "one slice per varying column"
        );
        let m = pixels.first().map_or(0, |p| p.len());
        assert!(pixels.iter().all(|p| p.len() == m), "slices of one length");
        let i = self.lanes;
        assert!(i + m <= self.cap, "room for {} rows", self.cap);
        for (&k, col) in self.pixel.iter().zip(pixels) {
            let dst = &mut self.codes[k * self.cap + i..k * self.cap + i + m];
            for (d, &v) in dst.iter_mut().zip(*col) {
                *d = i64::try_from(v).unwrap_or_else(|_| panic!("a code that fits i64"));
            }
        }
        self.lanes += m;
        self.live.resize(self.live.len() + m, true);
    }

    /// Append a live row: within an open run by its varying codes `pixel`
    /// alone ([`Columns::push_pixel`]), otherwise whole from `fill`
    /// ([`Columns::push_with`]), checking that `pixel` holds that row's
    /// varying codes, so a caller that lists them in another order than
    /// the columns is caught at the first row of every run.
    ///
    /// # Panics
    ///
    /// As [`Columns::push_pixel`] and [`Columns::push_with`], and if the
    /// row opening a run does not hold `pixel` in its varying columns.
    pub fn push_fragment(&mut self, pixel: &[i128], fill: impl FnOnce(&mut Vec<i128>)) {
        if self.in_run() {
            self.push_pixel(pixel);
            return;
        }
        self.push_with(fill);
        let i = self.lanes - 1;
        assert!(
            self.pixel.len() == pixel.len()
                && self
                    .pixel
                    .iter()
                    .zip(pixel)
                    .all(|(&k, &v)| i128::from(self.codes[k * self.cap + i]) == v),
            "the per-pixel codes given are the row's varying fields, in column order"
        );
    }

    /// Append a skipped row.
    pub fn push_skipped(&mut self) {
        self.live.push(false);
    }

    /// Close the open run: its constant columns get the run's first row's
    /// codes on every lane. The next live row opens a new run.
    pub fn end_run(&mut self) {
        let (start, end) = (self.run, self.lanes);
        if end > start + 1 {
            crate::datapath::Isa::current().run(FillRun {
                codes: &mut self.codes,
                constant: &self.constant,
                cap: self.cap,
                rows: start..end,
            });
        }
        self.run = end;
    }

    /// Column `k`'s codes, one per live row.
    ///
    /// # Panics
    ///
    /// If a run is open ([`Columns::end_run`] not called since the last
    /// row), or `k` is out of range.
    pub fn column(&self, k: usize) -> &[i64] {
        assert_eq!(self.run, self.lanes, "every run closed");
        &self.codes[k * self.cap..k * self.cap + self.lanes]
    }

    /// Remove every row, keeping the memory.
    pub fn clear(&mut self) {
        self.lanes = 0;
        self.run = 0;
        self.live.clear();
    }
}

/// [`Columns::end_run`]'s fills as a kernel compiled for the widest
/// instruction set ([`crate::datapath::Isa::run`]): each constant column's
/// rows `rows` set to the run's first row's code.
struct FillRun<'a> {
    codes: &'a mut [i64],
    constant: &'a [usize],
    cap: usize,
    rows: std::ops::Range<usize>,
}

impl crate::datapath::Kernel for FillRun<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let (start, end) = (self.rows.start, self.rows.end);
        for &k in self.constant {
            let col = &mut self.codes[k * self.cap + start..k * self.cap + end];
            let first = col[0];
            col[1..].fill(first);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Columns;

    /// Rows pushed in runs come out as the columns of the same rows
    /// written in full, skipped rows taking no lane, across a clear.
    #[test]
    fn columns_hold_the_rows_transposed() {
        let rows: [(u8, Option<[i128; 3]>); 7] = [
            (0, Some([7, 1, -3])),
            (0, Some([7, 2, -3])),
            (0, None),
            (0, Some([7, 4, -3])),
            (1, None),
            (2, Some([-9, 5, 1 << 40])),
            (2, Some([-9, 6, 1 << 40])),
        ];
        let mut c = Columns::new(vec![false, true, false], 8);
        for round in 0..2 {
            let mut last = None;
            for &(run, row) in &rows {
                if last != Some(run) {
                    c.end_run();
                    last = Some(run);
                }
                match row {
                    // A run's later rows give their varying code alone.
                    Some(r) if c.in_run() => c.push_pixel(&r[1..2]),
                    Some(r) => c.push_with(|v| v.extend_from_slice(&r)),
                    None => c.push_skipped(),
                }
            }
            c.end_run();
            let live: Vec<[i128; 3]> = rows.iter().filter_map(|r| r.1).collect();
            assert_eq!((c.len(), c.lanes()), (7, live.len()), "round {round}");
            for k in 0..3 {
                let want: Vec<i64> = live.iter().map(|r| i64::try_from(r[k]).unwrap()).collect();
                assert_eq!(c.column(k), &want[..], "column {k}");
            }
            let live_rows: Vec<bool> = (0..7).map(|i| c.is_live(i)).collect();
            let want: Vec<bool> = rows.iter().map(|r| r.1.is_some()).collect();
            assert_eq!(live_rows, want);
            c.clear();
            assert!(c.is_empty());
        }
    }

    /// The per-pixel codes of a run's first row must be its varying
    /// fields: given in another order, the row is refused.
    #[test]
    #[should_panic(expected = "the per-pixel codes given are the row's varying fields")]
    fn per_pixel_codes_out_of_order_are_refused() {
        let mut c = Columns::new(vec![false, true, true], 4);
        c.push_fragment(&[2, 3], |v| v.extend_from_slice(&[1, 2, 3]));
        c.push_fragment(&[4, 5], |v| v.extend_from_slice(&[1, 4, 5]));
        c.end_run();
        assert_eq!((c.column(1), c.column(2)), (&[2, 4][..], &[3, 5][..]));
        c.push_fragment(&[7, 6], |v| v.extend_from_slice(&[1, 6, 7]));
    }

    /// `push_pixels` makes the rows `push_pixel` makes one by one.
    #[test]
    fn pushing_pixels_at_once_is_pushing_them_one_by_one() {
        let (mut one, mut all) = (
            Columns::new(vec![true, false, true], 8),
            Columns::new(vec![true, false, true], 8),
        );
        for c in [&mut one, &mut all] {
            c.push_with(|v| v.extend_from_slice(&[1, 9, -1]));
        }
        let (a, b): (Vec<i128>, Vec<i128>) = ((2..6).collect(), (-6..-2).collect());
        for (x, y) in a.iter().zip(&b) {
            one.push_pixel(&[*x, *y]);
        }
        all.push_pixels(&[&a, &b]);
        all.push_pixels::<i128>(&[&[], &[]]);
        for c in [&mut one, &mut all] {
            c.end_run();
        }
        assert_eq!(all.len(), 5);
        for k in 0..3 {
            assert_eq!(one.column(k), all.column(k), "column {k}");
        }
        assert_eq!(all.column(2), &[-1, -6, -5, -4, -3][..]);
        assert_eq!(all.column(1), &[9; 5][..]);
    }

    #[test]
    #[should_panic(expected = "every run closed")]
    fn an_open_run_has_no_columns() {
        let mut c = Columns::new(vec![false, true], 4);
        c.push_with(|v| v.extend_from_slice(&[1, 2]));
        c.push_with(|v| v.extend_from_slice(&[1, 3]));
        let _ = c.column(0);
    }
}
