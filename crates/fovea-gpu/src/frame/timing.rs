//! Asynchronous GPU statistics for the resident frame (issue 37, item 5): each recorded frame
//! writes a timestamp at the start and end of each of its passes into one slot of a small ring;
//! the slot is resolved into a buffer and copied to that slot's readback buffer inside the
//! frame's own command encoder, mapped with `map_async` once the caller has submitted, and
//! read when a later [`FrameTimer::poll`] (which polls the device without waiting) finds the
//! mapping done — one or more frames late, never blocking the render thread. A frame that finds
//! every slot still in flight is simply not timed.
//!
//! What is read back is counted like every readback ([`crate::traffic`]): 16 bytes a pass a
//! timed frame.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};

/// Bytes of one pass's two stamps.
const PASS_STAMP_BYTES: u64 = 16;

/// A slot's state: free for a frame, recorded into a frame not yet submitted, its readback
/// being mapped, mapped and ready to read (or failed).
const FREE: u8 = 0;
const RECORDED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;
const FAILED: u8 = 4;

struct Slot {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    state: Arc<AtomicU8>,
    /// The frame it timed and the passes it wrote (bit k: pass k).
    frame: u64,
    written: u32,
}

/// One timed frame's passes, from the device's timestamps.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameGpuTimes {
    /// The frame's index ([`FrameTimer::begin_frame`] counts them from 0).
    pub frame: u64,
    /// Each pass's name and milliseconds (`None` when the frame did not run it).
    pub passes: Vec<(&'static str, Option<f64>)>,
}

impl FrameGpuTimes {
    /// The passes that ran, summed, ms.
    pub fn total_ms(&self) -> f64 {
        self.passes.iter().filter_map(|p| p.1).sum()
    }
}

/// A ring of timestamp query sets and their readback buffers (see the module).
pub struct FrameTimer {
    ctx: GpuContext,
    passes: Vec<&'static str>,
    slots: Vec<Slot>,
    /// The slot of the frame being recorded or just recorded, until [`Self::submitted`].
    current: Option<usize>,
    next_frame: u64,
    untimed: u64,
}

impl FrameTimer {
    /// A ring of `ring` slots (at least 2) timing `passes` (at most 32) per frame; `None` when
    /// the device has no timestamp queries. Creates everything once: per slot one query set,
    /// one resolve buffer and one readback buffer.
    pub fn new(ctx: &GpuContext, passes: &[&'static str], ring: usize) -> Result<Option<Self>> {
        if !ctx.has_timestamps() {
            return Ok(None);
        }
        if passes.is_empty() || passes.len() > 32 {
            return Err(GpuError::Input(format!(
                "a frame timer of {} passes (1 to 32)",
                passes.len()
            )));
        }
        let bytes = passes.len() as u64 * PASS_STAMP_BYTES;
        let slots = ctx.scoped("creating the frame timer", || {
            (0..ring.max(2))
                .map(|_| Slot {
                    set: ctx.device().create_query_set(&wgpu::QuerySetDescriptor {
                        label: Some("frame timestamps"),
                        ty: wgpu::QueryType::Timestamp,
                        count: 2 * passes.len() as u32,
                    }),
                    resolve: ctx.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("frame timestamps resolved"),
                        size: bytes,
                        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    }),
                    read: ctx.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("frame timestamps readback"),
                        size: bytes,
                        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                        mapped_at_creation: false,
                    }),
                    state: Arc::new(AtomicU8::new(FREE)),
                    frame: 0,
                    written: 0,
                })
                .collect()
        })?;
        Ok(Some(Self {
            ctx: ctx.clone(),
            passes: passes.to_vec(),
            slots,
            current: None,
            next_frame: 0,
            untimed: 0,
        }))
    }

    /// The passes it times, in order.
    pub fn passes(&self) -> &[&'static str] {
        &self.passes
    }

    /// Frames that found no free slot and went untimed.
    pub fn untimed_frames(&self) -> u64 {
        self.untimed
    }

    /// Starts a frame: takes a free slot, or leaves the frame untimed when every slot is still
    /// in flight. Returns the frame's index.
    pub fn begin_frame(&mut self) -> u64 {
        let frame = self.next_frame;
        self.next_frame += 1;
        self.current = self
            .slots
            .iter()
            .position(|s| s.state.load(Ordering::Acquire) == FREE);
        match self.current {
            Some(k) => {
                let slot = &mut self.slots[k];
                slot.frame = frame;
                slot.written = 0;
                slot.state.store(RECORDED, Ordering::Release);
            }
            None => self.untimed += 1,
        }
        frame
    }

    /// The `timestamp_writes` of pass `pass` (its index in [`Self::passes`]) of the current
    /// frame, or `None` when the frame is untimed.
    pub fn writes(&mut self, pass: usize) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let k = self.current?;
        if pass >= self.passes.len() {
            return None;
        }
        let slot = &mut self.slots[k];
        slot.written |= 1 << pass;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &slot.set,
            beginning_of_pass_write_index: Some(2 * pass as u32),
            end_of_pass_write_index: Some(2 * pass as u32 + 1),
        })
    }

    /// Records the resolve and the copy into the slot's readback (after the frame's passes,
    /// into the same encoder): only the span from the first to the last pass the frame wrote,
    /// so a timer whose passes did not run this frame (the denoiser off, no history) reads
    /// nothing back.
    pub fn end_frame(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(k) = self.current else {
            return;
        };
        let slot = &self.slots[k];
        let Some(span) = written_span(slot.written) else {
            return;
        };
        let queries = 2 * span.start as u32..2 * span.end as u32;
        encoder.resolve_query_set(&slot.set, queries, &slot.resolve, 0);
        let bytes = span.len() as u64 * PASS_STAMP_BYTES;
        encoder.copy_buffer_to_buffer(&slot.resolve, 0, &slot.read, 0, bytes);
    }

    /// After the caller submitted the frame's encoder: starts mapping the slot's readback (the
    /// written span's stamps). Does not wait; a frame that wrote no pass is ready at once.
    pub fn submitted(&mut self) {
        let Some(k) = self.current.take() else {
            return;
        };
        let slot = &self.slots[k];
        let Some(span) = written_span(slot.written) else {
            slot.state.store(MAPPED, Ordering::Release);
            return;
        };
        slot.state.store(MAPPING, Ordering::Release);
        let state = slot.state.clone();
        let bytes = span.len() as u64 * PASS_STAMP_BYTES;
        slot.read
            .map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
                state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
    }

    /// The frames whose timestamps have arrived since the last call, oldest first. Polls the
    /// device once without waiting (`PollType::Poll`); never blocks.
    pub fn poll(&mut self) -> Result<Vec<FrameGpuTimes>> {
        let _ = self.ctx.device().poll(wgpu::PollType::Poll);
        let period_ns = f64::from(self.ctx.queue().get_timestamp_period());
        let mut done = Vec::new();
        for slot in &mut self.slots {
            match slot.state.load(Ordering::Acquire) {
                MAPPED => {
                    let span = written_span(slot.written).unwrap_or(0..0);
                    let stamps: Option<Vec<u64>> = if span.is_empty() {
                        Some(Vec::new())
                    } else {
                        let bytes = span.len() as u64 * PASS_STAMP_BYTES;
                        let stamps = slot.read.get_mapped_range(0..bytes).ok().map(|view| {
                            self.ctx.traffic_counters().read_back(view.len() as u64);
                            bytemuck::pod_collect_to_vec::<u8, u64>(&view)
                        });
                        slot.read.unmap();
                        stamps
                    };
                    slot.state.store(FREE, Ordering::Release);
                    let Some(stamps) = stamps.filter(|s| s.len() >= 2 * span.len()) else {
                        continue;
                    };
                    let passes = self
                        .passes
                        .iter()
                        .enumerate()
                        .map(|(p, &name)| {
                            let ran = slot.written & (1 << p) != 0;
                            let ms = ran.then(|| {
                                let q = 2 * (p - span.start);
                                stamps[q + 1].saturating_sub(stamps[q]) as f64 * period_ns * 1e-6
                            });
                            (name, ms)
                        })
                        .collect();
                    done.push(FrameGpuTimes {
                        frame: slot.frame,
                        passes,
                    });
                }
                FAILED => slot.state.store(FREE, Ordering::Release),
                _ => {}
            }
        }
        done.sort_by_key(|t| t.frame);
        Ok(done)
    }
}

/// The passes from the first to the last one `written` (bit k: pass k) names, or `None` when
/// it names none.
fn written_span(written: u32) -> Option<std::ops::Range<usize>> {
    (written != 0).then(|| written.trailing_zeros() as usize..32 - written.leading_zeros() as usize)
}

#[cfg(test)]
mod tests {
    use super::written_span;

    #[test]
    fn the_written_span_runs_from_the_first_to_the_last_written_pass() {
        assert_eq!(written_span(0), None);
        assert_eq!(written_span(0b1), Some(0..1));
        assert_eq!(written_span(0b1011_0100), Some(2..8));
        assert_eq!(written_span(1 << 31), Some(31..32));
        assert_eq!(written_span(u32::MAX), Some(0..32));
    }
}
