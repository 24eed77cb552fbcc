//! Neighbourhoods in sample buffers.
//!
//! A filter that runs inside a sample buffer needs "the pixel one step away along each axis".
//! On a screen-aligned buffer that is the usual grid, clamped at the border. In a polar buffer
//! (column `i` = a ring at one radius, row `j` = an angle) two things differ: rows wrap (row
//! `rows[i] − 1` is next to row 0, the angular seam), and columns hold different numbers of
//! rows (VaFR's `l(e)`), so the neighbour of `(i, j)` in column `i ± 1` is the row at the
//! same angle, `j' = (j + ½)·period[i±1]/period[i] − ½`, not row `j`.

use fovea_core::mapping::PolarLayout;
use rayon::prelude::*;

/// Buffer topology for neighbour lookups.
#[derive(Clone, Debug)]
pub enum Grid {
    /// A `width × height` rectangle, clamped at the border.
    Rect {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// A polar buffer: columns of `rows[i]` samples wrapping after `period[i]`.
    Polar {
        /// Shaded rows per column.
        rows: Vec<u32>,
        /// Rows per full turn per column.
        period: Vec<f64>,
    },
}

impl Grid {
    /// The grid of a polar layout.
    pub fn polar(layout: &PolarLayout) -> Self {
        Grid::Polar {
            rows: layout.rows.clone(),
            period: layout.period.clone(),
        }
    }

    /// The grid of a sample layer `width` × `height` texels: the mapping's polar layout where
    /// it has one, else the rectangle.
    pub fn of_layer(polar: Option<&PolarLayout>, width: u32, height: u32) -> Self {
        match polar {
            Some(layout) => Self::polar(layout),
            None => Grid::Rect { width, height },
        }
    }

    /// Whether `(i, j)` holds a sample.
    #[inline]
    pub fn valid(&self, i: u32, j: u32) -> bool {
        match self {
            Grid::Rect { width, height } => i < *width && j < *height,
            Grid::Polar { rows, .. } => rows.get(i as usize).is_some_and(|&r| j < r),
        }
    }

    /// The pixel reached from `(i, j)` by `di` columns (at the same angle) then `dj` rows.
    /// Rect: clamped. Polar: rows wrap; columns past either end, or empty, stay at `i`.
    #[inline]
    pub fn step(&self, i: u32, j: u32, di: i32, dj: i32) -> (u32, u32) {
        match self {
            Grid::Rect { width, height } => (
                (i as i64 + di as i64).clamp(0, *width as i64 - 1) as u32,
                (j as i64 + dj as i64).clamp(0, *height as i64 - 1) as u32,
            ),
            Grid::Polar { rows, period } => {
                let (ci, cj) = Self::column(rows, period, i, j, di);
                (ci, wrap(cj + dj as i64, rows[ci as usize]))
            }
        }
    }

    /// The 3×3 neighbourhood of `(i, j)`: entry `[dj + 1][di + 1]` is
    /// [`step`](Self::step)`(i, j, di, dj)`, with one angle alignment per neighbouring
    /// column instead of one per neighbour (what FXAA reads for every texel).
    #[inline]
    pub fn neighbourhood(&self, i: u32, j: u32) -> [[(u32, u32); 3]; 3] {
        let mut out = [[(i, j); 3]; 3];
        for di in -1i32..=1 {
            match self {
                Grid::Rect { .. } => {
                    for dj in -1i32..=1 {
                        out[(dj + 1) as usize][(di + 1) as usize] = self.step(i, j, di, dj);
                    }
                }
                Grid::Polar { rows, period } => {
                    let (ci, cj) = Self::column(rows, period, i, j, di);
                    let r = rows[ci as usize];
                    for dj in -1i32..=1 {
                        out[(dj + 1) as usize][(di + 1) as usize] = (ci, wrap(cj + dj as i64, r));
                    }
                }
            }
        }
        out
    }

    /// For a polar grid in a buffer `width` texels wide and `height` high: for every texel
    /// `(i, j)` with a sample, at index `j·width + i`, the rows at its angle in the columns to
    /// its left and right, `step(i, j, −1, 0).1 | step(i, j, 1, 0).1 << 16`; 0 elsewhere
    /// (what a GPU executor's AA pass uploads, `fovea-gpu`'s `sample_aa`). Each column's
    /// scale to its neighbours is found once, not per texel, and the rows are filled in
    /// parallel: the same numbers as `step`, bit for bit (tested). `None` for a rectangle, a
    /// column longer than `height`, more columns than `width`, or rows past 65535.
    pub fn packed_alignment(&self, width: u32, height: u32) -> Option<Vec<u32>> {
        let Grid::Polar { rows, period } = self else {
            return None;
        };
        if rows.len() > width as usize
            || period.len() != rows.len()
            || height > u16::MAX as u32 + 1
            || rows.iter().any(|&r| r > height)
        {
            return None;
        }
        // Per column and side: the neighbour column and the scale to its rows (`None`: the
        // column itself, rows unchanged), exactly as `column` computes them.
        let side = |i: usize, di: i64| -> Option<(usize, f64)> {
            let ni = i as i64 + di;
            (ni >= 0 && (ni as usize) < rows.len() && rows[ni as usize] > 0).then(|| {
                let ni = ni as usize;
                (ni, period[ni] / period[i].max(1e-12))
            })
        };
        let sides: Vec<[Option<(usize, f64)>; 2]> =
            (0..rows.len()).map(|i| [side(i, -1), side(i, 1)]).collect();
        // The columns longest first: row `j` has samples in a prefix of them, so each row
        // visits its own texels only (a VaFR buffer from a corner gaze is 3× taller than most
        // of its columns).
        let mut longest: Vec<u32> = (0..rows.len() as u32).collect();
        longest.sort_unstable_by_key(|&i| std::cmp::Reverse(rows[i as usize]));
        let mut out = vec![0u32; width as usize * height as usize];
        out.par_chunks_mut(width.max(1) as usize)
            .enumerate()
            .for_each(|(j, line)| {
                let j = j as u32;
                let n = longest.partition_point(|&i| rows[i as usize] > j);
                for &i in &longest[..n] {
                    let i = i as usize;
                    let row = |s: Option<(usize, f64)>| match s {
                        Some((ni, scale)) => {
                            wrap(round_half_away((j as f64 + 0.5) * scale - 0.5), rows[ni])
                        }
                        None => wrap(j as i64, rows[i]),
                    };
                    line[i] = row(sides[i][0]) | (row(sides[i][1]) << 16);
                }
            });
        Some(out)
    }

    /// The column `i + di` (or `i` where that column is missing or empty) and, in it, the row
    /// at row `j`'s angle (before wrapping).
    #[inline]
    fn column(rows: &[u32], period: &[f64], i: u32, j: u32, di: i32) -> (u32, i64) {
        if di != 0 {
            let ni = i as i64 + di as i64;
            if ni >= 0 && (ni as usize) < rows.len() && rows[ni as usize] > 0 {
                let scale = period[ni as usize] / period[i as usize].max(1e-12);
                return (ni as u32, ((j as f64 + 0.5) * scale - 0.5).round() as i64);
            }
        }
        (i, j as i64)
    }
}

/// `x.round() as i64` (halves away from zero), without the library call `round` is on
/// targets without SSE4.1: the truncation and the exact remainder `x − trunc(x)` decide it.
#[inline]
fn round_half_away(x: f64) -> i64 {
    if x.abs() < (1u64 << 52) as f64 {
        let t = x as i64;
        let f = x - t as f64;
        t + i64::from(f >= 0.5) - i64::from(f <= -0.5)
    } else {
        x.round() as i64
    }
}

/// Row `j` wrapped into a column of `rows` rows (`rows = 0` counts as one), without a
/// division where it already lies inside.
#[inline]
fn wrap(j: i64, rows: u32) -> u32 {
    let r = rows.max(1) as i64;
    if (0..r).contains(&j) {
        j as u32
    } else {
        j.rem_euclid(r) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polar_rows_wrap_and_columns_align_by_angle() {
        let g = Grid::Polar {
            rows: vec![4, 8],
            period: vec![4.0, 8.0],
        };
        assert_eq!(g.step(0, 3, 0, 1), (0, 0));
        assert_eq!(g.step(0, 0, 0, -1), (0, 3));
        // Row 1 of column 0 (angle 135°) is row 2.5 → 3 (rounded) of column 1.
        assert_eq!(g.step(0, 1, 1, 0), (1, 3));
        assert_eq!(g.step(1, 7, -1, 0), (0, 3));
        // Past the last column: stay.
        assert_eq!(g.step(1, 2, 1, 0), (1, 2));
        let r = Grid::Rect {
            width: 3,
            height: 2,
        };
        assert_eq!(r.step(0, 0, -1, 5), (0, 1));
    }

    #[test]
    fn round_half_away_is_round() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -1.5,
            0.49999999999999994,
            -0.49999999999999994,
            4503599627370495.5,
            4503599627370497.0,
            -4503599627370495.5,
            1e300,
            -1e300,
        ];
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..100_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let m = (state >> 11) as f64 / (1u64 << 53) as f64;
            let e = (state % 40) as i32 - 8;
            xs.push((m - 0.5) * 2f64.powi(e));
            // Halves and their neighbours.
            let h = (state % 4096) as f64 + 0.5;
            xs.extend([h, -h, h.next_up(), h.next_down(), -h.next_up()]);
        }
        for x in xs {
            assert_eq!(round_half_away(x), x.round() as i64, "{x:e}");
        }
    }

    #[test]
    fn the_packed_alignment_is_every_texels_steps() {
        let g = Grid::Polar {
            rows: vec![5, 0, 7, 12, 12, 30, 3, 1],
            period: vec![5.2, 0.0, 7.4, 12.0, 12.3, 29.6, 3.1, 0.9],
        };
        let (w, h) = (10u32, 31u32);
        let a = g.packed_alignment(w, h).unwrap();
        assert_eq!(a.len(), (w * h) as usize);
        for j in 0..h {
            for i in 0..w {
                let want = if g.valid(i, j) {
                    g.step(i, j, -1, 0).1 | (g.step(i, j, 1, 0).1 << 16)
                } else {
                    0
                };
                assert_eq!(a[(j * w + i) as usize], want, "({i},{j})");
            }
        }
        assert!(g.packed_alignment(7, h).is_none());
        assert!(g.packed_alignment(w, 29).is_none());
        let r = Grid::Rect {
            width: 3,
            height: 2,
        };
        assert!(r.packed_alignment(3, 2).is_none());
        // A VaFR buffer (exact rings, a gaze near a corner): every texel.
        use fovea_core::display::DisplayProfile;
        use fovea_core::mapping::{FoveationMapping, Vafr, VafrParams};
        let d = DisplayProfile::with_vertical_fov("t", 320, 200, fovea_core::units::Degrees(100.0))
            .unwrap();
        let v = Vafr::new(&d, d.gaze(20.0, 170.0).unwrap(), VafrParams::default()).unwrap();
        let b = v.buffers()[0];
        let g = Grid::polar(&v.polar_layout().unwrap());
        let a = g.packed_alignment(b.width, b.height).unwrap();
        for j in 0..b.height {
            for i in 0..b.width {
                if g.valid(i, j) {
                    let want = g.step(i, j, -1, 0).1 | (g.step(i, j, 1, 0).1 << 16);
                    assert_eq!(a[(j * b.width + i) as usize], want, "({i},{j})");
                }
            }
        }
    }

    #[test]
    fn a_neighbourhood_is_its_nine_steps() {
        let polar = Grid::Polar {
            rows: vec![5, 0, 7, 12, 12, 30, 3],
            period: vec![5.2, 0.0, 7.4, 12.0, 12.3, 29.6, 3.1],
        };
        let rect = Grid::Rect {
            width: 6,
            height: 4,
        };
        for g in [polar, rect] {
            for i in 0..7u32 {
                for j in 0..31u32 {
                    if !g.valid(i, j) {
                        continue;
                    }
                    let n = g.neighbourhood(i, j);
                    for di in -1i32..=1 {
                        for dj in -1i32..=1 {
                            let got = n[(dj + 1) as usize][(di + 1) as usize];
                            assert_eq!(got, g.step(i, j, di, dj), "{g:?} ({i},{j}) {di},{dj}");
                        }
                    }
                }
            }
        }
    }
}
