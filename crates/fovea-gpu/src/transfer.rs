//! Moving bytes to and from the device without wgpu's panicking conveniences: uploads with
//! `create_buffer` + `Queue::write_buffer` (wgpu's `create_buffer_init` panics on a lost
//! device), readbacks that turn every failure into a [`GpuError`](crate::GpuError).

use crate::device::GpuContext;
use crate::error::Result;
use crate::timestamps::PassTimer;

/// A buffer holding `contents` (a multiple of 4 bytes). Unlike wgpu's `create_buffer_init`,
/// which panics when the device is lost, a failure here is an error of the enclosing scope.
pub(crate) fn upload(
    ctx: &GpuContext,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let buffer = ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: contents.len() as u64,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.write_buffer(&buffer, 0, contents);
    buffer
}

/// An uninitialised buffer of `size` bytes (at least 4: wgpu refuses empty bindings), for
/// passes to write.
pub(crate) fn empty(
    ctx: &GpuContext,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(4),
        usage,
        mapped_at_creation: false,
    })
}

/// A bind group of group 0 of `pipeline` with each buffer of `entries` bound whole at its
/// binding.
pub(crate) fn bind_group(
    ctx: &GpuContext,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|&(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    ctx.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// Records into `encoder` a copy of the first `bytes` of each of `sources` into a fresh
/// MAP_READ staging buffer of that size (labelled `label`, counted as every buffer), and
/// returns the staging buffers in order, for [`read_buffers`] once the encoder is submitted.
/// Call inside the caller's error scope.
pub(crate) fn stage(
    ctx: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    sources: &[(&wgpu::Buffer, u64)],
    label: &str,
) -> Vec<wgpu::Buffer> {
    sources
        .iter()
        .map(|&(source, bytes)| {
            let to = ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            encoder.copy_buffer_to_buffer(source, 0, &to, 0, bytes);
            to
        })
        .collect()
}

/// Copies `bytes` from the start of each of `sources` into a fresh MAP_READ staging buffer
/// ([`stage`]; one submission, inside an error scope named `what`) and reads them back as
/// [`read_buffers`] does: `read(index, bytes)` in the order given. Blocking and counted: for
/// tests and for an image asked for, never on the frame path.
pub(crate) fn read_back(
    ctx: &GpuContext,
    sources: &[(&wgpu::Buffer, u64)],
    what: &str,
    read: impl FnMut(usize, &[u8]),
) -> Result<()> {
    let staging = ctx.scoped(what, || {
        let mut encoder = ctx
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(what) });
        let staging = stage(ctx, &mut encoder, sources, what);
        ctx.submit([encoder.finish()]);
        staging
    })?;
    let refs: Vec<&wgpu::Buffer> = staging.iter().collect();
    read_buffers(ctx, &refs, what, read)
}

/// Maps every buffer of `buffers` (MAP_READ), waits for the queue once, and hands each
/// buffer's bytes to `read(index, bytes)` in order, unmapping it after.
pub(crate) fn read_buffers(
    ctx: &GpuContext,
    buffers: &[&wgpu::Buffer],
    what: &str,
    mut read: impl FnMut(usize, &[u8]),
) -> Result<()> {
    let mut pending = Vec::with_capacity(buffers.len());
    for buffer in buffers {
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        pending.push(rx);
    }
    ctx.wait_idle(what)?;
    for (k, (buffer, rx)) in buffers.iter().zip(pending).enumerate() {
        let mapped = rx.recv().map_err(|_| crate::GpuError::DeviceLost {
            reason: format!("the readback of {what} never completed"),
        })?;
        mapped.map_err(|e| crate::GpuError::DeviceLost {
            reason: format!("reading back {what}: {e}"),
        })?;
        let done = ctx.scoped(what, || {
            buffer.get_mapped_range(..).map(|view| {
                ctx.traffic_counters().read_back(view.len() as u64);
                read(k, &view)
            })
        })?;
        done.map_err(|e| crate::GpuError::Validation {
            what: what.to_string(),
            message: crate::error::one_line(&e.to_string()),
        })?;
        buffer.unmap();
    }
    Ok(())
}

/// Runs `pipeline` once per item over `n` items (one invocation each, in workgroups of
/// [`WORKGROUP_SIZE`](crate::shaders::WORKGROUP_SIZE) along x) with `inputs` bound at
/// bindings `0..k` of group 0 and a fresh output buffer of `out_bytes` per item at binding `k`,
/// and returns the output as 4-byte words (`out_bytes` is a multiple of 4). Everything runs
/// inside an error scope named `what`.
/// With `timed`, also the compute pass's own milliseconds from the device's timestamps
/// ([`PassTimer`]; `None` untimed or on a device without them).
pub(crate) fn run_1d(
    ctx: &GpuContext,
    what: &str,
    pipeline: &wgpu::ComputePipeline,
    inputs: &[wgpu::BindingResource<'_>],
    n: u64,
    out_bytes: u64,
    timed: bool,
) -> Result<(Vec<u32>, Option<f64>)> {
    let numbered: Vec<(u32, wgpu::BindingResource<'_>)> = inputs
        .iter()
        .cloned()
        .enumerate()
        .map(|(k, r)| (k as u32, r))
        .collect();
    run_1d_at(
        ctx,
        what,
        pipeline,
        &numbered,
        inputs.len() as u32,
        n,
        out_bytes,
        timed,
    )
}

/// [`run_1d`] with the inputs at the given bindings and the output at `out_binding`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_1d_at(
    ctx: &GpuContext,
    what: &str,
    pipeline: &wgpu::ComputePipeline,
    inputs: &[(u32, wgpu::BindingResource<'_>)],
    out_binding: u32,
    n: u64,
    out_bytes: u64,
    timed: bool,
) -> Result<(Vec<u32>, Option<f64>)> {
    let device = ctx.device();
    let size = n.max(1) * out_bytes;
    let (readback, timer) = ctx.scoped(what, || {
        let timer = timed.then(|| PassTimer::new(ctx, what)).flatten();
        let output = ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("output"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let entries: Vec<wgpu::BindGroupEntry> = inputs
            .iter()
            .cloned()
            .chain([(out_binding, output.as_entire_binding())])
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
            .collect();
        let bind = ctx.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(what),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(what) });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(what),
                timestamp_writes: timer.as_ref().map(PassTimer::writes),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(
                n.max(1).div_ceil(crate::shaders::WORKGROUP_SIZE as u64) as u32,
                1,
                1,
            );
        }
        let readback = stage(ctx, &mut encoder, &[(&output, size)], "readback").remove(0);
        if let Some(timer) = &timer {
            timer.resolve(&mut encoder);
        }
        ctx.submit([encoder.finish()]);
        (readback, timer)
    })?;
    let mut buffers = vec![&readback];
    buffers.extend(timer.as_ref().map(PassTimer::readback));
    let (mut out, mut ms) = (Vec::new(), None);
    read_buffers(ctx, &buffers, what, |k, bytes| {
        if k == 0 {
            // Copied into 4-byte words, so the callers' casts to their 4-byte-aligned
            // records hold whatever alignment the mapped range had.
            out = bytemuck::pod_collect_to_vec::<u8, u32>(bytes);
        } else {
            ms = Some(PassTimer::ms(ctx, bytes));
        }
    })?;
    Ok((out, ms))
}

/// How many items of a one-dimensional pass fit one dispatch: the largest binding divided by
/// `bytes_per_item` (the largest per-item buffer), the workgroups per dispatch times
/// [`WORKGROUP_SIZE`](crate::shaders::WORKGROUP_SIZE), and at most 2²² (at least 1).
pub(crate) fn batch_len(ctx: &GpuContext, bytes_per_item: u64) -> usize {
    let limits = ctx.limits();
    let by_binding = ctx.max_binding_bytes() / bytes_per_item.max(1);
    let by_dispatch =
        limits.max_compute_workgroups_per_dimension as u64 * crate::shaders::WORKGROUP_SIZE as u64;
    by_binding.min(by_dispatch).clamp(1, 1 << 22) as usize
}
