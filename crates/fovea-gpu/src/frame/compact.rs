//! The resident frame's list of shaded texels (issue 37): before the shade kernels of
//! [`super::shade`] run on a polar buffer, `frame_compact` (`shaders/frame_compact.wgsl`) walks
//! the layer in 8×8 tiles, writes what an unshaded texel holds (black at +∞ depth, state
//! unshaded, empty guides) and appends every shaded texel to a list on the device — stream
//! compaction by an atomic append (Harris, Sengupta & Owens, GPU Gems 3 ch. 39, §39.3.1). The
//! three shade kernels and the bounce kernels ([`super::bounce`]) then run over the listed
//! texels only: no invocation for a texel the plan does not shade, no lane of a workgroup idle
//! beside a traced one (a polar buffer holds many such texels: VaFR's rings for any gaze,
//! `--vafr-rings eq3-any-gaze`, reach the screen's diagonal, and the arcs off the screen are
//! not shaded). Nothing more goes up or comes back per frame, and it is all in the eye's one
//! compute pass (after one `clear_buffer` of the 4-byte counter).
//!
//! The count stays on the device; the kernels' dispatch is sized on the host from an upper
//! bound of it, [`shaded_bound`]: the rows of every column's runs of shaded rows (the tables
//! the frame uploads anyway). Invocations past the device's count return at once. (An indirect
//! dispatch sized from the count itself would need no bound, but wgpu 30's validation of
//! indirect arguments aborts lavapipe 22.3 with "stack smashing detected"; the bound is exact
//! but for the few texels whose ray falls off its ring's period.)
//!
//! Which texels are shaded is `frame_point`'s decision (the shade kernels' own function), so
//! the list holds exactly the texels the kernels shade without it, and each texel's result
//! depends on its own `(i, j)` only: the samples are the same bits as before, in whatever
//! order the device lists them. Only polar buffers are listed ([`lists`]): a full-resolution
//! buffer shades every texel, so its list would be the tile walk plus a pass; Guenter's layers
//! and Weier's sparse pattern keep their own dispatches. [`EyeList::read`] reads a frame's
//! list back for tests (`tests/frame_compact.rs` checks it against the CPU mapping).

use std::sync::atomic::{AtomicU32, Ordering};

use super::shade::RayLayout;
use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::WORKGROUP_SIZE;

/// The list's kernel (an entry point of the shade module, `frame_shade.wgsl` with
/// `frame_compact.wgsl` appended).
pub const ENTRY_POINT: &str = "frame_compact";

/// The bindings the list adds to the shade and bounce kernels' group 0: `(binding, uniform,
/// read-only)`, as [`super::shade::BINDINGS`] declares them: the list and its count (after
/// the bounce kernels' 31–34).
pub const BINDINGS: [(u32, bool, bool); 2] = [(35, false, false), (36, false, false)];

/// Bytes of the count (`frame_count`).
const COUNT_BYTES: u64 = 4;

/// Whether the kernels of a buffer laid out as `layout` run over a list of its shaded texels:
/// a polar buffer's (module header).
pub fn lists(layout: RayLayout) -> bool {
    layout == RayLayout::Polar
}

/// An upper bound of the texels a polar layer's kernels list: the rows of its columns' runs
/// of shaded rows (`[start, end)` each), at most `texels`.
pub fn shaded_bound(runs: &[[u32; 2]], texels: u64) -> u32 {
    let rows: u64 = runs
        .iter()
        .map(|r| u64::from(r[1].saturating_sub(r[0])))
        .sum();
    rows.min(texels).min(u64::from(u32::MAX)) as u32
}

/// The dispatch over `bound` listed texels: ⌈bound / 64⌉ workgroups in rows of at most
/// `groups[0]` (the tile walk's rows, the stride `frame_listed` reads them by); `None` for
/// none.
pub fn listed_groups(bound: u32, groups: [u32; 2]) -> Option<[u32; 2]> {
    let listed = bound.div_ceil(WORKGROUP_SIZE);
    if listed == 0 {
        return None;
    }
    let x = listed.min(groups[0].max(1));
    Some([x, listed.div_ceil(x)])
}

/// One eye's list: the shaded texels (4 bytes each, room for the eye's texel capacity), the
/// count, and the bound the next recording sizes the kernels' dispatch by.
pub struct EyeList {
    list: wgpu::Buffer,
    count: wgpu::Buffer,
    bound: AtomicU32,
}

impl EyeList {
    /// Whether a list of `capacity` texels fits a binding ([`GpuError::AdapterTooSmall`]
    /// otherwise).
    pub(crate) fn check(ctx: &GpuContext, capacity: u64) -> Result<()> {
        ctx.check_storage_binding("the frame's list of shaded texels", capacity.max(1) * 4)
    }

    /// The buffers, room for `capacity` texels (16 bytes for a layout without a list). Call
    /// inside an error scope, after [`Self::check`].
    pub(crate) fn new(ctx: &GpuContext, capacity: u64) -> Self {
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let list = ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame shaded texels"),
            size: (capacity.max(1) * 4).max(16),
            usage: storage,
            mapped_at_creation: false,
        });
        let count = ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame shaded texel count"),
            size: 16,
            usage: storage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            list,
            count,
            bound: AtomicU32::new(0),
        }
    }

    /// The buffers group 0 binds: `(binding, buffer)` for [`BINDINGS`].
    pub(crate) fn bindings(&self) -> [(u32, &wgpu::Buffer); 2] {
        [(BINDINGS[0].0, &self.list), (BINDINGS[1].0, &self.count)]
    }

    /// Sets the bound of this frame's count ([`shaded_bound`]) the next recording sizes the
    /// kernels' dispatch by.
    pub(crate) fn set_bound(&self, texels: u32) {
        self.bound.store(texels, Ordering::Relaxed);
    }

    /// The bound of this frame's count.
    pub fn bound(&self) -> u32 {
        self.bound.load(Ordering::Relaxed)
    }

    /// Zeroes the count: record before the eye's pass.
    pub(crate) fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.count, 0, None);
    }

    /// Records the list's kernel into `pass` (group 0 already set: the eye's bind group), over
    /// `groups` workgroups (the layer's 8×8 tiles), and returns the grid the kernels then run
    /// over the list with ([`listed_groups`]; `None`: nothing listed can be shaded).
    pub(crate) fn record(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        compact: &wgpu::ComputePipeline,
        groups: [u32; 2],
    ) -> Option<[u32; 2]> {
        pass.set_pipeline(compact);
        pass.dispatch_workgroups(groups[0], groups[1], 1);
        listed_groups(self.bound(), groups)
    }

    /// The last frame's listed texels (`j · width + i` of the layer, in the device's order),
    /// read back (blocking, counted): for tests, never on the frame path.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        let what = "the frame's list of shaded texels";
        let (mut count, mut list) = (0usize, Vec::new());
        let sources = [(&self.count, COUNT_BYTES), (&self.list, self.list.size())];
        crate::transfer::read_back(ctx, &sources, what, |k, bytes| {
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
            match k {
                0 => count = words.first().copied().unwrap_or(0) as usize,
                _ => list = words,
            }
        })?;
        if count > list.len() {
            return Err(GpuError::Input(format!(
                "{what}: {count} listed, room for {}",
                list.len()
            )));
        }
        list.truncate(count);
        Ok(list)
    }
}

// An 8×8 tile is one workgroup (`frame_tile_texel`).
const _: () = assert!(WORKGROUP_SIZE == 64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_sums_the_runs_rows() {
        assert_eq!(shaded_bound(&[[0, 10], [20, 25], [7, 7]], 1000), 15);
        assert_eq!(shaded_bound(&[[0, 10], [20, 25]], 12), 12);
        // A run the wrong way round counts nothing.
        assert_eq!(shaded_bound(&[[9, 3]], 100), 0);
    }

    #[test]
    fn the_listed_grid_covers_the_bound_in_the_tile_walks_rows() {
        assert_eq!(listed_groups(0, [100, 1]), None);
        assert_eq!(listed_groups(1, [100, 1]), Some([1, 1]));
        assert_eq!(listed_groups(64 * 100, [100, 1]), Some([100, 1]));
        assert_eq!(listed_groups(64 * 100 + 1, [100, 2]), Some([100, 2]));
        // Every bound: enough invocations, rows no wider than the tile walk's.
        for bound in [1u32, 63, 64, 65, 6399, 6400, 6401, 1 << 20] {
            let [x, y] = listed_groups(bound, [100, 200]).unwrap();
            assert!(x <= 100);
            assert!(u64::from(x) * u64::from(y) * 64 >= u64::from(bound));
            assert!(u64::from(x) * u64::from(y - 1) * 64 < u64::from(bound));
        }
    }
}
