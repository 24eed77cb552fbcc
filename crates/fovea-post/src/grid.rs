//! Neighbourhoods in sample buffers.
//!
//! A filter that runs inside a sample buffer needs "the pixel one step away along each axis".
//! On a screen-aligned buffer that is the usual grid, clamped at the border. In a polar buffer
//! (column `i` = a ring at one radius, row `j` = an angle) two things differ: rows wrap (row
//! `rows[i] − 1` is next to row 0, the angular seam), and columns hold different numbers of
//! rows (VaFR's `l(e)`), so the neighbour of `(i, j)` in column `i ± 1` is the row at the
//! same angle, `j' = (j + ½)·period[i±1]/period[i] − ½`, not row `j`.

use fovea_core::mapping::PolarLayout;

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
