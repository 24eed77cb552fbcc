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
                let mut ci = i;
                let mut cj = j as i64;
                if di != 0 {
                    let ni = i as i64 + di as i64;
                    if ni >= 0 && (ni as usize) < rows.len() && rows[ni as usize] > 0 {
                        let ni = ni as u32;
                        let scale = period[ni as usize] / period[i as usize].max(1e-12);
                        cj = ((j as f64 + 0.5) * scale - 0.5).round() as i64;
                        ci = ni;
                    }
                }
                let r = rows[ci as usize].max(1) as i64;
                (ci, (cj + dj as i64).rem_euclid(r) as u32)
            }
        }
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
}
