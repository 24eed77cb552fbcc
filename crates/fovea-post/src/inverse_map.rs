//! Inverse mapping: sample buffers back to screen pixels (VaFR Sec. 3.4 / Eq. 10–11, the
//! "reconstruct" stage of DESIGN.md).
//!
//! Every screen pixel centre is sent through the mapping's forward map and the buffer is read
//! there with a filtered lookup:
//!
//! * **Polar buffers** (VaFR, KFR, LaFR, visual-polar): the column comes from a lookup table of
//!   `u(r)` (sampled from the mapping's own forward map every ⅛ pixel of radius and
//!   interpolated linearly), the angle from `atan2`. Colour is bilinear across the two nearest
//!   columns, each read at its own angle (`v = θ/360°·period[i]`) with rows wrapping, so there is
//!   no seam at the angular wrap; pixels nearer the gaze than the first column's centre read
//!   column 0 around the full circle, so there is no hole at the gaze point. Pixels up to one
//!   texel past the last column's centre read the last column; pixels the mapping does not
//!   cover at all (past a fixed maximum eccentricity) have no sample and are black at infinite
//!   depth — never the outermost ring stretched over the rest of the screen.
//!   Where the buffer is denser than the screen (VaFR's and the other polar methods' fovea,
//!   up to ~9 texels per pixel radially at the gaze on a Vive Pro Eye), the default
//!   [`ReconstructFilter::Footprint`] averages every texel the pixel covers instead of reading
//!   the two nearest: a box of the pixel's width across columns (`du/dr` texels, from the
//!   lookup table's slope) and along each column (`period/(2πr)` rows, prefiltered once per
//!   frame). A bilinear lookup there point-samples an oversampled buffer: its extra rays are
//!   traced and then thrown away, and edges alias as in a one-ray full frame.
//! * **Screen-aligned layers** (Guenter, insets): the pixel's layer from the forward map,
//!   bilinear inside that layer, clamped to the layer's shaded rectangle.
//! * **Sparse screen masks** (Weier): see [`crate::pull_push`].
//! * **Full resolution**: the buffer is the screen.
//!
//! Depth is read with nearest-sample lookups (interpolating depth across an object boundary
//! would invent surfaces).

use rayon::prelude::*;

use fovea_core::display::DisplayProfile;
use fovea_core::mapping::{FoveationMapping, Method, SamplePoint};
use fovea_core::units::ScreenPoint;
use fovea_core::{FoveaError, Image, Result};

use crate::pull_push::pull_push;
use crate::{lerp3, Rgb};

mod kernel;

use kernel::PolarRows;
pub use kernel::{fast_atan2, PolarKernel};

/// Radius step of the `u(r)` lookup table, pixels.
pub const LUT_STEP_PX: f64 = 0.125;

/// How a polar buffer is read at a screen pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReconstructFilter {
    /// Bilinear at the pixel centre (VaFR Sec. 3.4): two columns, two rows each, wherever
    /// the pixel lies.
    Bilinear,
    /// The pixel's footprint: where the buffer holds more than one texel per pixel, a box
    /// over the texels the pixel covers (radially across columns, angularly along each
    /// column); bilinear elsewhere. The box meets the bilinear lookup continuously at one
    /// texel per pixel.
    #[default]
    Footprint,
}

/// Shaded sample buffers of one frame: colour and depth per layer, as the mapping's
/// `buffers()` lists them. Unshaded pixels may hold anything.
#[derive(Clone, Debug)]
pub struct SampleBuffers {
    /// Linear RGB per layer.
    pub color: Vec<Image<Rgb>>,
    /// Depth (metres along the view axis; `f32::INFINITY` for misses) per layer.
    pub depth: Vec<Image<f32>>,
}

impl SampleBuffers {
    /// Buffers of `mapping` with an independent pseudo-random colour in [0, 1) in every texel
    /// (xorshift from `seed`: the worst case for interpolation errors) and depth = the texel's
    /// index in its layer. Test and benchmark input for the reconstruction.
    pub fn random(mapping: &dyn FoveationMapping, seed: u64) -> Result<Self> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ seed.wrapping_mul(0x2545_f491_4f6c_dd1d);
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut color, mut depth) = (Vec::new(), Vec::new());
        for b in mapping.buffers() {
            let c: Vec<Rgb> = (0..b.pixels()).map(|_| [next(), next(), next()]).collect();
            color.push(Image::from_vec(b.width, b.height, c)?);
            let d: Vec<f32> = (0..b.pixels()).map(|k| k as f32).collect();
            depth.push(Image::from_vec(b.width, b.height, d)?);
        }
        Ok(Self { color, depth })
    }
}

/// The reconstructed screen image and depth.
#[derive(Clone, Debug)]
pub struct ScreenFrame {
    /// Linear RGB, display resolution.
    pub color: Image<Rgb>,
    /// Depth per pixel, metres.
    pub depth: Image<f32>,
}

/// Maps `buffers` back to the screen of `display` through `mapping`, into new images, with
/// the default [`ReconstructFilter`].
pub fn reconstruct(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: SampleBuffers,
) -> Result<ScreenFrame> {
    reconstruct_filtered(mapping, display, buffers, ReconstructFilter::default())
}

/// [`reconstruct`] with the polar lookup `filter`.
pub fn reconstruct_filtered(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: SampleBuffers,
    filter: ReconstructFilter,
) -> Result<ScreenFrame> {
    let (w, h) = (display.width_px, display.height_px);
    let n = w as usize * h as usize;
    let mut buffers = buffers;
    // Zeroed allocations: pages are faulted in where the reconstruction first writes them.
    let mut out = ScreenFrame {
        color: Image::from_vec(w, h, crate::alloc::zeroed::<[f32; 3]>(n))?,
        depth: Image::from_vec(w, h, crate::alloc::zeroed::<f32>(n))?,
    };
    reconstruct_into(
        mapping,
        display,
        &mut buffers,
        &mut out.color,
        &mut out.depth,
        filter,
    )?;
    Ok(out)
}

/// Maps `buffers` back to the screen of `display` through `mapping`, writing every pixel of
/// `color` and `depth` (both of the display's size), so a caller that keeps them from frame
/// to frame allocates nothing. Full resolution swaps its one buffer with the output (the
/// buffer is the screen); `buffers` then holds the old output, to be overwritten next frame.
/// `filter` decides how polar buffers are read; the other layouts ignore it.
pub fn reconstruct_into(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: &mut SampleBuffers,
    color: &mut Image<Rgb>,
    depth: &mut Image<f32>,
    filter: ReconstructFilter,
) -> Result<()> {
    let kernel = PolarKernel::detect();
    reconstruct_into_with_kernel(mapping, display, buffers, color, depth, filter, kernel)
}

/// [`reconstruct_into`] with the polar buffers' inner loops run by `kernel` (an error where
/// this processor lacks its instructions). Every kernel gives the same frame; this is for
/// measuring and testing them side by side.
pub fn reconstruct_into_with_kernel(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: &mut SampleBuffers,
    color: &mut Image<Rgb>,
    depth: &mut Image<f32>,
    filter: ReconstructFilter,
    kernel: PolarKernel,
) -> Result<()> {
    let (w, h) = (display.width_px, display.height_px);
    let sizes = mapping.buffers();
    if sizes.len() != buffers.color.len()
        || sizes.len() != buffers.depth.len()
        || sizes
            .iter()
            .zip(&buffers.color)
            .any(|(s, b)| s.width != b.width() || s.height != b.height())
    {
        return Err(FoveaError::invalid(
            "sample buffers",
            format!("{} colour layers", buffers.color.len()),
            format!("the mapping's {} buffer(s) {:?}", sizes.len(), sizes),
        ));
    }
    for (name, (iw, ih)) in [
        ("output colour", (color.width(), color.height())),
        ("output depth", (depth.width(), depth.height())),
    ] {
        if (iw, ih) != (w, h) {
            return Err(FoveaError::invalid(
                name,
                format!("{iw}x{ih}"),
                format!("the display's {w}x{h}"),
            ));
        }
    }
    let method = mapping.method();
    if method == Method::Full {
        std::mem::swap(&mut buffers.color[0], color);
        std::mem::swap(&mut buffers.depth[0], depth);
        return Ok(());
    }
    if method == Method::Weier {
        let mask = mask_of(mapping, w, h);
        *color = pull_push(&buffers.color[0], &mask)?;
        *depth = nearest_fill_depth(&buffers.depth[0], &mask)?;
        return Ok(());
    }
    if let Some(layout) = mapping.polar_layout() {
        let out = (color, depth);
        return polar(mapping, display, &layout, buffers, out, filter, kernel);
    }
    layered(mapping, display, buffers, color, depth)
}

/// The largest ring [`nearest_fill_depth`] searches, pixels.
pub const DEPTH_FILL_RADIUS_PX: u32 = 64;

/// Which screen pixels a sparse screen-space mapping shades.
pub fn mask_of(mapping: &dyn FoveationMapping, w: u32, h: u32) -> Image<bool> {
    let data: Vec<bool> = (0..h)
        .into_par_iter()
        .flat_map_iter(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| mapping.is_shaded(0, i, j))
        .collect();
    Image::from_vec(w, h, data).expect("size matches")
}

/// Everything the polar reconstruction derives from the mapping and the sample buffers
/// before it reads a pixel: the `u(r)` lookup table, the padded (and, with
/// [`ReconstructFilter::Footprint`], angularly prefiltered) columns and the pixel's radial
/// footprint per column. The CPU loop of this module reads them; `fovea-gpu` uploads the
/// same tables, so both executors reconstruct from identical numbers.
pub struct PolarTables {
    /// The pole (the gaze point), screen pixels.
    pub centre: ScreenPoint,
    /// Radius step of [`Self::lut`], pixels ([`LUT_STEP_PX`]).
    pub lut_step_px: f64,
    /// `u(r)` at `r = k · lut_step_px` from the centre (the column coordinate, texel centres
    /// at `i + ½`), from the mapping's own forward map along +x; `f32::INFINITY` where the
    /// mapping has no sample.
    pub lut: Vec<f32>,
    /// The last column with shaded rows.
    pub last: usize,
    /// The columns' texels, padded and prefiltered ([`PolarColumns`]).
    pub columns: PolarColumns,
    /// With [`ReconstructFilter::Footprint`]: columns per pixel radially (`du/dr`) at every
    /// column `0..=last`; `None` for [`ReconstructFilter::Bilinear`].
    pub texels_per_px: Option<Vec<f32>>,
}

impl PolarTables {
    /// The tables of `mapping` (a polar mapping) on `display` for `buffers` read with
    /// `filter`. Fails for a mapping without a polar layout, buffers of the wrong size or a
    /// buffer without shaded samples.
    pub fn new(
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        buffers: &SampleBuffers,
        filter: ReconstructFilter,
    ) -> Result<Self> {
        let Some(layout) = mapping.polar_layout() else {
            return Err(FoveaError::Unsupported(format!(
                "polar reconstruction tables for {} (not a polar mapping)",
                mapping.method()
            )));
        };
        let sizes = mapping.buffers();
        if sizes.len() != 1
            || buffers.color.len() != 1
            || buffers.depth.len() != 1
            || (buffers.color[0].width(), buffers.color[0].height())
                != (sizes[0].width, sizes[0].height)
            || (buffers.depth[0].width(), buffers.depth[0].height())
                != (sizes[0].width, sizes[0].height)
        {
            return Err(FoveaError::invalid(
                "sample buffers",
                format!("{} colour layers", buffers.color.len()),
                format!("the mapping's buffer {sizes:?}"),
            ));
        }
        Self::of_layout(mapping, display, &layout, buffers, filter)
    }

    fn of_layout(
        mapping: &dyn FoveationMapping,
        display: &DisplayProfile,
        layout: &fovea_core::mapping::PolarLayout,
        buffers: &SampleBuffers,
        filter: ReconstructFilter,
    ) -> Result<Self> {
        let (w, h) = (display.width_px, display.height_px);
        let c = layout.centre;
        let last = match layout.rows.iter().rposition(|&r| r > 0) {
            Some(l) => l,
            None => {
                return Err(FoveaError::Unsupported(
                    "a polar buffer without shaded samples".into(),
                ))
            }
        };
        let lut = polar_lut(mapping, c, w, h);
        // The pixel's footprint in every column: radial texels per pixel (`du/dr`) and rows
        // per pixel along the column (`period/(2πr)`), both at the column's centre radius.
        let footprint = match filter {
            ReconstructFilter::Bilinear => None,
            ReconstructFilter::Footprint => Some(column_footprints(&lut, layout, last)),
        };
        let columns = PolarColumns::new(
            &buffers.color[0],
            &buffers.depth[0],
            layout,
            footprint.as_ref().map(|f| f.rows_per_px.as_slice()),
        );
        Ok(Self {
            centre: c,
            lut_step_px: LUT_STEP_PX,
            lut,
            last,
            columns,
            texels_per_px: footprint.map(|f| f.texels_per_px),
        })
    }
}

/// The `u(r)` lookup table of [`PolarTables::lut`]: the polar `mapping`'s column coordinate
/// at `r = k · LUT_STEP_PX` from its pole `centre` (along +x, from its own forward map) out
/// to the farthest corner of a `w × h` screen plus 2 px; `f32::INFINITY` where the mapping
/// has no sample. Shared with executors that keep the columns on a device
/// (`fovea_gpu::frame`), so both build it from the same numbers.
pub fn polar_lut(mapping: &dyn FoveationMapping, centre: ScreenPoint, w: u32, h: u32) -> Vec<f32> {
    let c = centre;
    let corners = [
        (0.0, 0.0),
        (w as f64, 0.0),
        (0.0, h as f64),
        (w as f64, h as f64),
    ];
    let r_max = corners
        .iter()
        .map(|&(x, y)| (x - c.x_px).hypot(y - c.y_px))
        .fold(0.0, f64::max)
        + 2.0;
    polar_lut_to(mapping, centre, polar_lut_len(r_max))
}

/// Entries of a `u(r)` table reaching `r_max_px` ([`polar_lut`]'s length for that radius).
pub fn polar_lut_len(r_max_px: f64) -> usize {
    (r_max_px / LUT_STEP_PX).ceil() as usize + 2
}

/// [`polar_lut`] with `n` entries (`r = k · LUT_STEP_PX` for `k < n`), whatever the screen:
/// entry for entry the same numbers, so a table built once for the largest radius any gaze
/// reads serves a mapping whose `u(r)` does not depend on the gaze
/// (`FoveationMapping::layout_is_gaze_free`; at another pole the same to the rounding of a
/// point's radius from it).
pub fn polar_lut_to(mapping: &dyn FoveationMapping, centre: ScreenPoint, n: usize) -> Vec<f32> {
    let c = centre;
    (0..n)
        .into_par_iter()
        .map(|k| {
            let r = k as f64 * LUT_STEP_PX;
            match mapping.forward(ScreenPoint::new(c.x_px + r, c.y_px)) {
                Some(s) => s.u as f32,
                None => f32::INFINITY,
            }
        })
        .collect()
}

fn polar(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    layout: &fovea_core::mapping::PolarLayout,
    buffers: &SampleBuffers,
    (out_color, out_depth): (&mut Image<Rgb>, &mut Image<f32>),
    filter: ReconstructFilter,
    kernel: PolarKernel,
) -> Result<()> {
    kernel.check()?;
    let wu = display.width_px as usize;
    let PolarTables {
        centre: c,
        lut,
        last,
        columns,
        texels_per_px: radial,
        ..
    } = PolarTables::of_layout(mapping, display, layout, buffers, filter)?;
    let max_period = layout.period.iter().fold(1.0f64, |a, &b| a.max(b)) as f32;
    let dense_end = radial
        .as_ref()
        .map_or(0, |t| t.iter().rposition(|&v| v > 1.0).map_or(0, |i| i + 1));
    let rows = PolarRows {
        lut: &lut,
        cx: c.x_px as f32,
        cy: c.y_px as f32,
        inv_step: (1.0 / LUT_STEP_PX) as f32,
        cols_end: (last + 1) as f32,
        last,
        turn_tolerance: COORD_TOLERANCE_TEXELS / max_period,
        columns: &columns,
        radial: radial.as_deref(),
        dense_end,
        points: &kernel::span_points(wu),
    };
    out_color
        .data_mut()
        .par_chunks_mut(wu)
        .zip(out_depth.data_mut().par_chunks_mut(wu))
        .enumerate()
        .for_each_init(
            || rows.scratch(wu),
            |scratch, (y, (row_c, row_d))| rows.row(kernel, y, scratch, row_c, row_d),
        );
    Ok(())
}

/// The columns of a polar buffer whose texels are smaller than a screen pixel both radially
/// (the column's width, from the inverse map at its two edges) and tangentially (the circle at
/// its centre over its rows per turn): there every pixel holds more than one sample each way
/// and the reconstruction averages them over the pixel (see [`reconstruct_into`]), which is
/// anti-aliasing already when the filter is [`ReconstructFilter::Footprint`]. `None` for
/// mappings without a polar layout.
pub fn minified_columns(mapping: &dyn FoveationMapping) -> Option<Vec<bool>> {
    let layout = mapping.polar_layout()?;
    let c = layout.centre;
    let radius = |u: f64| {
        mapping
            .inverse(SamplePoint {
                layer: 0,
                u,
                v: 0.5,
            })
            .map(|p| (p.x_px - c.x_px).hypot(p.y_px - c.y_px))
    };
    Some(
        (0..layout.rows.len())
            .map(|i| {
                let (Some(r0), Some(r1), Some(rc)) = (
                    radius(i as f64),
                    radius(i as f64 + 1.0),
                    radius(i as f64 + 0.5),
                ) else {
                    return false;
                };
                let period = layout.period[i];
                layout.rows[i] > 0
                    && (r1 - r0).abs() < 1.0
                    && period > 0.0
                    && std::f64::consts::TAU * rc / period < 1.0
            })
            .collect(),
    )
}

/// Largest error, in texels, that pass 1 of the polar reconstruction may make in a pixel's
/// buffer coordinates by interpolating them linearly between exactly computed pixels.
pub const COORD_TOLERANCE_TEXELS: f32 = 1.0 / 64.0;

/// One column of a polar buffer: where its texels start in [`PolarColumns::texels`], how many
/// rows it has (they wrap) and its rows per full turn. `repr(C)`: the vector kernel gathers
/// the three fields as 32-bit words at a column's index × 3.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Column {
    /// Index of the column's first stored texel (its last row's copy) in
    /// [`PolarColumns::texels`]; row `j` is stored at `base + 1 + j`.
    pub base: u32,
    /// Stored rows (at least 1; a column without shaded rows has one black texel at infinite
    /// depth).
    pub rows: u32,
    /// Rows per full turn (0 for a column without shaded rows).
    pub period: f32,
}

/// A polar buffer's colour and depth as `[r, g, b, depth]`, column by column (the rows of a
/// column contiguous, so the two rows a lookup blends usually share a cache line). Each
/// column is stored with its last row copied before its first and its first after its last,
/// so a lookup never wraps. A column without shaded rows reads black at infinite depth.
pub struct PolarColumns {
    texels: Vec<[f32; 4]>,
    columns: Vec<Column>,
}

impl PolarColumns {
    /// Texels stored for a column of `rows` rows in a buffer `buffer_height` rows high: its
    /// rows (at least one, at most the buffer's) and the two copied rows around them.
    fn stored_rows(rows: u32, buffer_height: u32) -> u32 {
        rows.min(buffer_height).max(1) + 2
    }

    /// How many texels [`PolarTables::columns`] holds for a buffer of `layout` that is
    /// `buffer_height` rows high (what a GPU executor uploads; counted without the buffer).
    pub fn texel_count(layout: &fovea_core::mapping::PolarLayout, buffer_height: u32) -> u64 {
        layout
            .rows
            .iter()
            .map(|&rows| u64::from(Self::stored_rows(rows, buffer_height)))
            .sum()
    }

    /// The columns of `color` and `depth`; with `rows_per_px`, each column's colour boxed
    /// along its rows to the pixel's width first ([`box_along_column`]).
    fn new(
        color: &Image<Rgb>,
        depth: &Image<f32>,
        layout: &fovea_core::mapping::PolarLayout,
        rows_per_px: Option<&[f32]>,
    ) -> Self {
        let bh = color.height();
        let mut columns = Vec::with_capacity(layout.rows.len());
        let mut base = 0u32;
        for (&rows, &period) in layout.rows.iter().zip(&layout.period) {
            let rows = rows.min(bh);
            columns.push(Column {
                base,
                rows: rows.max(1),
                period: if rows == 0 { 0.0 } else { period as f32 },
            });
            base += Self::stored_rows(rows, bh);
        }
        // Zeroed by the operating system (lazily, page by page), then every texel written once.
        let mut texels = crate::alloc::zeroed::<[f32; 4]>(base as usize);
        // Blocks of neighbouring columns, each its slice of `texels`: reading the buffer's
        // rows a block wide keeps the reads contiguous while each column is written in order.
        const BLOCK: usize = 16;
        let mut parts: Vec<(usize, &mut [[f32; 4]])> = Vec::new();
        let mut rest = texels.as_mut_slice();
        for (b, block) in columns.chunks(BLOCK).enumerate() {
            let len: usize = block.iter().map(|c| c.rows as usize + 2).sum();
            let (head, tail) = rest.split_at_mut(len);
            rest = tail;
            parts.push((b * BLOCK, head));
        }
        parts.into_par_iter().for_each(|(first, dst)| {
            let n = BLOCK.min(columns.len() - first);
            let shaded = |c: usize| (layout.rows[first + c].min(bh)) as usize;
            let mut cols: Vec<&mut [[f32; 4]]> = Vec::with_capacity(n);
            let mut rest = dst;
            for c in 0..n {
                let (head, tail) = rest.split_at_mut(columns[first + c].rows as usize + 2);
                rest = tail;
                cols.push(head);
            }
            let max_rows = (0..n).map(shaded).max().unwrap_or(0);
            for j in 0..max_rows {
                let crow = &color.row(j as u32)[first..first + n];
                let drow = &depth.row(j as u32)[first..first + n];
                for (c, col) in cols.iter_mut().enumerate() {
                    if j < shaded(c) {
                        let [r, g, b] = crow[c];
                        col[1 + j] = [r, g, b, drow[c]];
                    }
                }
            }
            for (c, col) in cols.into_iter().enumerate() {
                let rows = shaded(c);
                if rows == 0 {
                    col.fill([0.0, 0.0, 0.0, f32::INFINITY]);
                    continue;
                }
                // Box width beyond the bilinear lookup's own one row (their convolution
                // spans the pixel).
                let i = first + c;
                let extra = rows_per_px.and_then(|r| r.get(i)).map_or(0.0, |&r| r - 1.0);
                if extra > 1e-3 {
                    box_along_column(&mut col[1..rows + 1], extra as f64);
                }
                col[0] = col[rows];
                col[rows + 1] = col[1];
            }
        });
        Self { texels, columns }
    }

    /// The texels `[r, g, b, depth]`, column after column, each column padded by one row
    /// on either side (see [`Column::base`]).
    pub fn texels(&self) -> &[[f32; 4]] {
        &self.texels
    }

    /// Where each column lies in [`Self::texels`].
    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    /// Column `i` at angle `turn` ∈ [0, 1): colour linear between the two rows around
    /// `v = turn·period` (wrapping), depth of the nearer.
    #[inline(always)]
    fn read(&self, i: usize, turn: f32) -> [f32; 4] {
        let col = self.columns[i];
        // Rows jf − 1 and jf around v + ½ (v ≥ 0, so truncation is a floor), stored at
        // jf and jf + 1; v < period ≤ rows + ½ keeps jf ≤ rows, and the clamp keeps any
        // rounding inside the column.
        let v = turn * col.period + 0.5;
        let jf = (v as u32).min(col.rows);
        let k = (col.base + jf) as usize;
        blend(self.texels[k], self.texels[k + 1], v - jf as f32)
    }
}

/// What one screen pixel covers of every column of a polar buffer.
pub struct ColumnFootprints {
    /// Columns per pixel radially, `du/dr` at the column's centre (1 where unknown).
    pub texels_per_px: Vec<f32>,
    /// Rows per pixel along the column, `period/(2π r)` at its centre radius (`+∞` at the
    /// pole).
    pub rows_per_px: Vec<f32>,
}

/// The footprint of a pixel in columns `0..=last` from the `u(r)` lookup table: each column's
/// centre radius `r_i` (where `u(r) = i + ½`, linear between table entries), the table's
/// slope there and the column's rows per turn over the circumference `2π r_i`. The
/// footprint filter's tables ([`ReconstructFilter::Footprint`]), public for executors that
/// prefilter the columns on a device.
pub fn column_footprints(
    lut: &[f32],
    layout: &fovea_core::mapping::PolarLayout,
    last: usize,
) -> ColumnFootprints {
    let step = LUT_STEP_PX as f32;
    let (mut texels_per_px, mut rows_per_px) = (vec![1.0; last + 1], vec![1.0; last + 1]);
    for i in 0..=last {
        let target = i as f32 + 0.5;
        let k = lut.partition_point(|&u| u < target);
        if k >= lut.len() || !lut[k].is_finite() {
            continue;
        }
        let (r, slope) = if k == 0 {
            (0.0, (lut[1] - lut[0]) / step)
        } else {
            let du = lut[k] - lut[k - 1];
            let f = if du > 0.0 {
                (target - lut[k - 1]) / du
            } else {
                1.0
            };
            ((k as f32 - 1.0 + f) * step, du / step)
        };
        if slope.is_finite() && slope > 0.0 {
            texels_per_px[i] = slope;
        }
        let period = layout.period[i] as f32;
        rows_per_px[i] = if r > 0.0 {
            period / (std::f32::consts::TAU * r)
        } else {
            f32::INFINITY
        };
    }
    ColumnFootprints {
        texels_per_px,
        rows_per_px,
    }
}

/// Replaces the colour of the cyclic sequence of texels `col` (rows wrap) by its mean over a
/// box `width` rows wide centred on each row, each texel standing for a unit interval
/// (fractional ends weighted by their overlap); depth is kept. A box as wide as the column
/// gives the column's mean.
fn box_along_column(col: &mut [[f32; 4]], width: f64) {
    let n = col.len();
    let mut prefix = vec![[0.0f64; 3]; n + 1];
    for (k, t) in col.iter().enumerate() {
        for c in 0..3 {
            prefix[k + 1][c] = prefix[k][c] + t[c] as f64;
        }
    }
    let total = prefix[n];
    if width >= n as f64 {
        let inv = 1.0 / n as f64;
        for t in col.iter_mut() {
            for c in 0..3 {
                t[c] = (total[c] * inv) as f32;
            }
        }
        return;
    }
    let src: Vec<[f32; 4]> = col.to_vec();
    // ∫ from −½ to x of the piecewise-constant sequence, continued periodically.
    let integral = |x: f64, c: usize| -> f64 {
        let y = x + 0.5;
        let q = (y / n as f64).floor();
        let y = y - q * n as f64;
        let m = (y as usize).min(n - 1);
        q * total[c] + prefix[m][c] + (y - m as f64) * src[m][c] as f64
    };
    let h = 0.5 * width;
    for (j, t) in col.iter_mut().enumerate() {
        for c in 0..3 {
            t[c] = ((integral(j as f64 + h, c) - integral(j as f64 - h, c)) / width) as f32;
        }
    }
}

/// The colour of a pixel at column coordinate `uc` (column centres at integers) and angle
/// `turn`, boxed over `width ≥ 1` columns: every column `i` in `[uc − width/2, uc + width/2]`
/// read at the angle and weighted by its overlap with `[i − ½, i + ½]`, columns past `0` or
/// `last` left out. At `width = 1` this is the bilinear lookup.
fn box_across_columns(columns: &PolarColumns, uc: f32, width: f32, last: usize, turn: f32) -> Rgb {
    let (lo, hi) = (uc - 0.5 * width, uc + 0.5 * width);
    let first = (lo + 0.5).floor().max(0.0) as usize;
    let end = ((hi + 0.5).floor().max(0.0) as usize).min(last);
    let (mut sum, mut weight) = ([0.0f32; 3], 0.0f32);
    for i in first..=end {
        let w = hi.min(i as f32 + 0.5) - lo.max(i as f32 - 0.5);
        if w <= 0.0 {
            continue;
        }
        let t = columns.read(i, turn);
        for c in 0..3 {
            sum[c] += w * t[c];
        }
        weight += w;
    }
    if weight > 0.0 {
        sum.map(|v| v / weight)
    } else {
        let t = columns.read(uc.round().clamp(0.0, last as f32) as usize, turn);
        [t[0], t[1], t[2]]
    }
}

/// `[r, g, b, depth]` texels `a` and `b` at `f` ∈ [0, 1]: colour linear, depth of the nearer.
#[inline(always)]
fn blend(a: [f32; 4], b: [f32; 4], f: f32) -> [f32; 4] {
    [
        a[0] + (b[0] - a[0]) * f,
        a[1] + (b[1] - a[1]) * f,
        a[2] + (b[2] - a[2]) * f,
        if f < 0.5 { a[3] } else { b[3] },
    ]
}

/// Shaded rectangle `[i0, i1] × [j0, j1]` of a screen-aligned layer.
fn shaded_rect(
    mapping: &dyn FoveationMapping,
    layer: u32,
    bw: u32,
    bh: u32,
) -> (u32, u32, u32, u32) {
    let mid_j = bh / 2;
    let mid_i = bw / 2;
    let i0 = (0..bw)
        .find(|&i| mapping.is_shaded(layer, i, mid_j))
        .unwrap_or(0);
    let i1 = (0..bw)
        .rev()
        .find(|&i| mapping.is_shaded(layer, i, mid_j))
        .unwrap_or(bw - 1);
    let j0 = (0..bh)
        .find(|&j| mapping.is_shaded(layer, mid_i, j))
        .unwrap_or(0);
    let j1 = (0..bh)
        .rev()
        .find(|&j| mapping.is_shaded(layer, mid_i, j))
        .unwrap_or(bh - 1);
    (i0, i1.max(i0), j0, j1.max(j0))
}

fn layered(
    mapping: &dyn FoveationMapping,
    display: &DisplayProfile,
    buffers: &SampleBuffers,
    out_c: &mut Image<Rgb>,
    out_d: &mut Image<f32>,
) -> Result<()> {
    let w = display.width_px;
    let rects: Vec<_> = buffers
        .color
        .iter()
        .enumerate()
        .map(|(k, b)| shaded_rect(mapping, k as u32, b.width(), b.height()))
        .collect();
    out_c.data_mut().fill([0.0f32; 3]);
    out_d.data_mut().fill(f32::INFINITY);
    out_c
        .data_mut()
        .par_chunks_mut(w as usize)
        .zip(out_d.data_mut().par_chunks_mut(w as usize))
        .enumerate()
        .for_each(|(y, (row_c, row_d))| {
            for x in 0..w as usize {
                let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
                let Some(SamplePoint { layer, u, v }) = mapping.forward(p) else {
                    continue;
                };
                let k = layer as usize;
                let (i0, i1, j0, j1) = rects[k];
                let img = &buffers.color[k];
                let fx = ((u - 0.5) as f32).clamp(i0 as f32, i1 as f32);
                let fy = ((v - 0.5) as f32).clamp(j0 as f32, j1 as f32);
                let (xa, ya) = (fx.floor() as u32, fy.floor() as u32);
                let (xb, yb) = ((xa + 1).min(i1), (ya + 1).min(j1));
                let (tx, ty) = (fx - xa as f32, fy - ya as f32);
                let top = lerp3(*img.get(xa, ya), *img.get(xb, ya), tx);
                let bot = lerp3(*img.get(xa, yb), *img.get(xb, yb), tx);
                row_c[x] = lerp3(top, bot, ty);
                let (nx, ny) = (fx.round() as u32, fy.round() as u32);
                row_d[x] = *buffers.depth[k].get(nx.min(i1), ny.min(j1));
            }
        });
    Ok(())
}

/// Fills unshaded depth pixels with the nearest shaded one found by a growing square search
/// (bounded at [`DEPTH_FILL_RADIUS_PX`]; beyond, infinity): rings of Chebyshev radius 1, 2, …,
/// each visited row by row (top to bottom) and left to right, the first shaded pixel winning.
/// Weier's reconstruction uses it for depth; `fovea-gpu` repeats the same order.
pub fn nearest_fill_depth(depth: &Image<f32>, mask: &Image<bool>) -> Result<Image<f32>> {
    let (w, h) = (depth.width(), depth.height());
    let mut out = depth.clone();
    out.data_mut()
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, d) in row.iter_mut().enumerate() {
                if *mask.get(x as u32, y as u32) {
                    continue;
                }
                *d = f32::INFINITY;
                'search: for rad in 1i64..=i64::from(DEPTH_FILL_RADIUS_PX) {
                    for dy in -rad..=rad {
                        for dx in -rad..=rad {
                            if dx.abs() != rad && dy.abs() != rad {
                                continue;
                            }
                            let (sx, sy) = (x as i64 + dx, y as i64 + dy);
                            if sx < 0 || sy < 0 || sx >= w as i64 || sy >= h as i64 {
                                continue;
                            }
                            if *mask.get(sx as u32, sy as u32) {
                                *d = *depth.get(sx as u32, sy as u32);
                                break 'search;
                            }
                        }
                    }
                }
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_atan2_matches_libm() {
        let mut worst = 0.0f32;
        for k in 0..20_000 {
            let a = k as f32 * 0.000_314_159_27 * 2.0;
            for r in [1e-3f32, 0.7, 123.0] {
                let (y, x) = (r * a.sin(), r * a.cos());
                worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 2e-5, "{worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }

    use fovea_core::mapping::{build, MappingConfig};

    fn random_buffers(mapping: &dyn FoveationMapping) -> SampleBuffers {
        SampleBuffers::random(mapping, 0).unwrap()
    }

    /// The polar reconstruction computed the slow way: every pixel's column through the
    /// mapping's own forward map and its angle by `f64::atan2`, then the same filter.
    fn reference_polar(
        mapping: &dyn FoveationMapping,
        buffers: &SampleBuffers,
        x: u32,
        y: u32,
    ) -> (Rgb, f32) {
        let layout = mapping.polar_layout().unwrap();
        let last = layout.rows.iter().rposition(|&r| r > 0).unwrap();
        let p = ScreenPoint::new(x as f64 + 0.5, y as f64 + 0.5);
        let u = mapping.forward(p).map_or((last + 1) as f64, |s| s.u);
        let (dx, dy) = (p.x_px - layout.centre.x_px, p.y_px - layout.centre.y_px);
        let turn = dy.atan2(dx).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
        let uc = (u - 0.5).clamp(0.0, last as f64);
        let i0 = uc as usize;
        let i1 = (i0 + 1).min(last);
        let fu = (uc - i0 as f64) as f32;
        let read = |i: usize| -> (Rgb, f32) {
            let rows = layout.rows[i] as i64;
            let v = turn * layout.period[i] - 0.5;
            let j = v.floor();
            let fv = (v - j) as f32;
            let ja = (j as i64).rem_euclid(rows) as u32;
            let jb = (j as i64 + 1).rem_euclid(rows) as u32;
            let (a, b) = (
                buffers.color[0].get(i as u32, ja),
                buffers.color[0].get(i as u32, jb),
            );
            let d = if fv < 0.5 { ja } else { jb };
            (lerp3(*a, *b, fv), *buffers.depth[0].get(i as u32, d))
        };
        let (a, da) = read(i0);
        let (b, db) = read(i1);
        (lerp3(a, b, fu), if fu < 0.5 { da } else { db })
    }

    /// Pass 1's interpolated coordinates stay within their tolerance of the exact ones (the
    /// seam, the pole and the outer edge included): on random texels, no pixel differs from
    /// the slow reference by more than the tolerance's share of the texel range (plus float
    /// rounding), and nearest-depth picks agree except where a pixel sits on a texel boundary.
    #[test]
    fn polar_reconstruction_matches_the_slow_reference() {
        for (method, preset, gx, gy) in [
            (Method::Vafr, "2k", 0.31, 0.62),
            (Method::Vafr, "vive-pro-eye", 0.5, 0.5),
            (Method::Kfr, "2k", 0.7, 0.4),
            (Method::VisualPolar, "2k", 0.45, 0.55),
        ] {
            let d = DisplayProfile::preset(preset).unwrap();
            let gaze = d
                .gaze(gx * d.width_px as f64, gy * d.height_px as f64)
                .unwrap();
            let m = build(method, &d, gaze, &MappingConfig::default()).unwrap();
            let bufs = random_buffers(m.as_ref());
            let out = reconstruct_with(m.as_ref(), &d, &bufs, ReconstructFilter::Bilinear);
            let (mut worst, mut depth_diff, mut n) = (0.0f32, 0usize, 0usize);
            // Every 7th row and column, plus the gaze row (the angular seam runs along it).
            let gy_px = gaze.point.y_px as u32;
            for y in (0..d.height_px).step_by(7).chain([gy_px, gy_px + 1]) {
                for x in (0..d.width_px).step_by(if y == gy_px || y == gy_px + 1 { 1 } else { 7 }) {
                    let (c, dep) = reference_polar(m.as_ref(), &bufs, x, y);
                    let got = out.color.get(x, y);
                    for k in 0..3 {
                        worst = worst.max((got[k] - c[k]).abs());
                    }
                    depth_diff += (*out.depth.get(x, y) != dep) as usize;
                    n += 1;
                }
            }
            println!("{method} {preset}: worst colour difference {worst:.4}, depth picks differing {depth_diff}/{n}");
            assert!(
                worst < 2.0 * COORD_TOLERANCE_TEXELS + 2e-3,
                "{method} {preset}: {worst}"
            );
            assert!(
                (depth_diff as f64) < 0.005 * n as f64,
                "{method} {preset}: {depth_diff}/{n}"
            );
        }
    }

    fn reconstruct_with(
        m: &dyn FoveationMapping,
        d: &DisplayProfile,
        bufs: &SampleBuffers,
        filter: ReconstructFilter,
    ) -> ScreenFrame {
        reconstruct_filtered(m, d, bufs.clone(), filter).unwrap()
    }

    /// The mean over a pixel of the buffer seen as piecewise constant (each texel its value
    /// over its unit cell): 24×24 points of the pixel through the forward map, each reading
    /// the texel it falls in. What a box-filtered supersampled pixel of the buffer's content
    /// would be.
    fn pixel_mean_brute_force(
        m: &dyn FoveationMapping,
        bufs: &SampleBuffers,
        x: u32,
        y: u32,
    ) -> Rgb {
        let layout = m.polar_layout().unwrap();
        let k = 24;
        let mut sum = [0.0f64; 3];
        let mut n = 0;
        for a in 0..k {
            for b in 0..k {
                let p = ScreenPoint::new(
                    x as f64 + (a as f64 + 0.5) / k as f64,
                    y as f64 + (b as f64 + 0.5) / k as f64,
                );
                let Some(s) = m.forward(p) else { continue };
                let i = (s.u.floor() as usize).min(layout.rows.len() - 1);
                let rows = layout.rows[i].max(1);
                let j = (s.v.floor() as i64).rem_euclid(rows as i64) as u32;
                let c = bufs.color[0].get(i as u32, j);
                for q in 0..3 {
                    sum[q] += c[q] as f64;
                }
                n += 1;
            }
        }
        sum.map(|v| (v / n.max(1) as f64) as f32)
    }

    /// The footprint filter on random texels (every texel independent: the worst aliasing):
    /// in VaFR's fovea on a Vive Pro Eye (up to 8 texels per pixel each way), each pixel comes
    /// within a small error of the brute-force mean of the texels it covers, where the paper's
    /// bilinear lookup (two columns, two rows) is far off; outside the dense region the two
    /// filters agree exactly; a constant buffer stays constant.
    #[test]
    fn footprint_filter_averages_the_texels_a_pixel_covers() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let gaze = d.gaze(700.0, 820.0).unwrap();
        let m = build(Method::Vafr, &d, gaze, &MappingConfig::default()).unwrap();
        let bufs = random_buffers(m.as_ref());
        let fp = reconstruct_with(m.as_ref(), &d, &bufs, ReconstructFilter::Footprint);
        let bl = reconstruct_with(m.as_ref(), &d, &bufs, ReconstructFilter::Bilinear);
        let (mut e_fp, mut e_bl, mut n) = (0.0f64, 0.0f64, 0usize);
        // Pixels 3 to 60 px from the gaze: 5 to 8 texels per pixel each way.
        for (dx, dy) in [
            (3, 0),
            (0, -7),
            (11, 5),
            (-17, 9),
            (25, -25),
            (-40, 2),
            (6, 60),
        ] {
            let (x, y) = ((700 + dx) as u32, (820 + dy) as u32);
            let want = pixel_mean_brute_force(m.as_ref(), &bufs, x, y);
            let (a, b) = (fp.color.get(x, y), bl.color.get(x, y));
            for q in 0..3 {
                e_fp += ((a[q] - want[q]) as f64).powi(2);
                e_bl += ((b[q] - want[q]) as f64).powi(2);
                n += 1;
            }
        }
        let (e_fp, e_bl) = ((e_fp / n as f64).sqrt(), (e_bl / n as f64).sqrt());
        println!("RMS against the pixel's texel mean: footprint {e_fp:.4}, bilinear {e_bl:.4}");
        // Random texels in [0, 1) have σ ≈ 0.29; a mean of ~50 of them, ~0.04.
        assert!(e_fp < 0.05, "footprint {e_fp}");
        assert!(e_bl > 0.15, "bilinear {e_bl}");
        // Far out (texels wider than a pixel) the filters are the same lookup.
        for (x, y) in [(5u32, 5u32), (1400, 1500), (100, 1200)] {
            assert_eq!(fp.color.get(x, y), bl.color.get(x, y), "({x}, {y})");
        }
        assert_eq!(fp.depth.data(), bl.depth.data());
        let mut flat = bufs.clone();
        flat.color
            .iter_mut()
            .for_each(|c| c.data_mut().fill([0.25, 0.5, 0.75]));
        let out = reconstruct_with(m.as_ref(), &d, &flat, ReconstructFilter::Footprint);
        for (k, c) in out.color.data().iter().enumerate() {
            for q in 0..3 {
                assert!(
                    (c[q] - [0.25, 0.5, 0.75][q]).abs() < 1e-5,
                    "pixel {k}: {c:?}"
                );
            }
        }
    }

    /// [`minified_columns`] against the screen distances between neighbouring texel centres:
    /// a column is minified when both the step to the next column and the chord to the next
    /// row are shorter than a pixel (columns within 2 % of either threshold are not judged,
    /// the column width at its edges and the chord at its centre differing slightly). At the
    /// Vive Pro Eye, visual-polar's fovea is minified, its first column (a disc 4 px wide
    /// around the gaze) and its periphery are not; full resolution has no polar layout.
    #[test]
    fn minified_columns_are_denser_than_the_screen_both_ways() {
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let gaze = d.centre_gaze();
        let full = build(Method::Full, &d, gaze, &MappingConfig::default()).unwrap();
        assert!(minified_columns(full.as_ref()).is_none());
        let m = build(Method::VisualPolar, &d, gaze, &MappingConfig::default()).unwrap();
        let keep = minified_columns(m.as_ref()).unwrap();
        let at = |u: f64, v: f64| m.inverse(SamplePoint { layer: 0, u, v }).unwrap();
        let (mut judged, mut minified) = (0, 0);
        for i in 0..keep.len() - 1 {
            let radial = at(i as f64 + 0.5, 0.5).distance(at(i as f64 + 1.5, 0.5));
            let tangential = at(i as f64 + 0.5, 0.5).distance(at(i as f64 + 0.5, 1.5));
            if [radial, tangential].iter().any(|s| (s - 1.0).abs() < 0.02) {
                continue;
            }
            judged += 1;
            minified += keep[i] as usize;
            assert_eq!(
                keep[i],
                radial < 1.0 && tangential < 1.0,
                "column {i}: {radial:.3} px to the next column, {tangential:.3} px to the next row"
            );
        }
        assert!(judged > keep.len() * 9 / 10, "{judged} of {}", keep.len());
        assert!(!keep[0] && !keep[keep.len() - 1]);
        let ring_50px = (0..keep.len())
            .find(|&i| at(i as f64 + 0.5, 0.5).distance(gaze.point) > 50.0)
            .unwrap();
        assert!(keep[ring_50px]);
        println!("{minified} of {} columns minified", keep.len());
    }
}
