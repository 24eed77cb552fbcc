//! How the crate's WGSL modules are described: each module as the device compiles it
//! (`common.wgsl` prepended to the module's own file, as WGSL has no include), its entry
//! points and its uniform block. Each pass declares its own [`ShaderSource`] beside the Rust
//! struct it uploads; [`crate::ALL_SHADERS`] lists them all, so that a plain `cargo test` can
//! parse and validate every module with naga, no driver needed (`tests/shaders.rs`), and
//! compare the size of each uniform struct with its Rust twin.

/// One compute module.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    /// The module's file under `shaders/`.
    pub file: &'static str,
    /// The full source the device compiles.
    pub source: &'static str,
    /// The module's entry points: the crate creates pipelines for them, or for some of them
    /// where the module carries another module's file for its functions
    /// ([`Self::pipelines_of`]).
    pub entry_points: &'static [&'static str],
    /// The WGSL uniform struct of the module and the size of the Rust `#[repr(C)]` struct
    /// uploaded into it, bytes.
    pub uniform: (&'static str, usize),
}

impl ShaderSource {
    /// Compiles the module on `device` and creates one compute pipeline per entry point, in
    /// the order of [`Self::entry_points`] (layouts derived from the shader). Call inside an
    /// error scope ([`GpuContext::scoped`](crate::GpuContext::scoped)): wgpu reports a bad
    /// module there, not here.
    pub(crate) fn pipelines(&self, device: &wgpu::Device) -> Vec<wgpu::ComputePipeline> {
        self.pipelines_of(device, self.entry_points)
    }

    /// [`Self::pipelines`] for the entry points `entries` only, in their order.
    pub(crate) fn pipelines_of(
        &self,
        device: &wgpu::Device,
        entries: &[&str],
    ) -> Vec<wgpu::ComputePipeline> {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(self.file),
            source: wgpu::ShaderSource::Wgsl(self.source.into()),
        });
        entries
            .iter()
            .map(|&entry| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: None,
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect()
    }
}

/// Workgroup size of every compute entry point (`WORKGROUP_SIZE` in `common.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;

/// The shared helpers, prepended to every module.
pub const COMMON_FILE: &str = "common.wgsl";
