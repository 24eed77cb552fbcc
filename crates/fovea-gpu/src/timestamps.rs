//! A compute pass's own time from the device's timestamps (`wgpu::Features::TIMESTAMP_QUERY`,
//! which lavapipe has): a query set of two stamps written at the pass's start and end,
//! resolved into a buffer the caller reads back with its other readbacks. Used by the
//! reconstructor's pass and the tracer's passes.

/// Two timestamps around one compute pass, and the buffers that bring them back.
pub(crate) struct PassTimer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
}

/// Bytes of the two resolved stamps.
const STAMP_BYTES: u64 = 16;

impl PassTimer {
    /// A timer for the pass named `label`, or `None` when the device has no timestamps.
    /// Call inside the caller's error scope (it creates a query set and two buffers).
    pub(crate) fn new(ctx: &crate::device::GpuContext, label: &str) -> Option<Self> {
        if !ctx.has_timestamps() {
            return None;
        }
        let device = ctx.device();
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some(label),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let resolve = ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps resolved"),
            size: STAMP_BYTES,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read = ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps readback"),
            size: STAMP_BYTES,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Some(Self { set, resolve, read })
    }

    /// The pass descriptor's `timestamp_writes`: stamp 0 at its start, 1 at its end.
    pub(crate) fn writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// For a timed span of several passes: the first pass's `timestamp_writes` (stamp 0 at
    /// its start).
    pub(crate) fn begin_writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: None,
        }
    }

    /// … and the last pass's (stamp 1 at its end).
    pub(crate) fn end_writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: None,
            end_of_pass_write_index: Some(1),
        }
    }

    /// Records the copy of the stamps into the readback buffer (after the pass, before the
    /// encoder is finished).
    pub(crate) fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.set, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, STAMP_BYTES);
    }

    /// The buffer to map and read after submission (hand its bytes to [`Self::ms`]).
    pub(crate) fn readback(&self) -> &wgpu::Buffer {
        &self.read
    }

    /// The pass's milliseconds from the readback's bytes (0 for a short or garbled read).
    pub(crate) fn ms(ctx: &crate::device::GpuContext, bytes: &[u8]) -> f64 {
        let stamp = |i: usize| {
            bytes
                .get(8 * i..8 * i + 8)
                .and_then(|b| b.try_into().ok())
                .map_or(0, u64::from_le_bytes)
        };
        let period_ns = f64::from(ctx.queue().get_timestamp_period());
        stamp(1).saturating_sub(stamp(0)) as f64 * period_ns * 1e-6
    }
}
