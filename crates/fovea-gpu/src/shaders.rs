//! The WGSL sources of the crate, each module as the device compiles it: `common.wgsl`
//! prepended to the module's own file (WGSL has no include). The list is public so that a
//! plain `cargo test` can parse and validate every module with naga, no driver needed
//! (`tests/shaders.rs`), and compare the size of each uniform struct with its Rust twin.

/// One compute module.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    /// The module's file under `shaders/`.
    pub file: &'static str,
    /// The full source the device compiles.
    pub source: &'static str,
    /// The entry points the crate creates pipelines for.
    pub entry_points: &'static [&'static str],
    /// The WGSL uniform struct of the module and the size of the Rust `#[repr(C)]` struct
    /// uploaded into it, bytes.
    pub uniform: (&'static str, usize),
}

/// Workgroup size of every compute entry point (`WORKGROUP_SIZE` in `common.wgsl`).
pub const WORKGROUP_SIZE: u32 = 64;

/// The shared helpers, prepended to every module.
pub const COMMON_FILE: &str = "common.wgsl";

/// The VaFR mapping (forward, inverse).
pub const VAFR_MAPPING: ShaderSource = ShaderSource {
    file: "vafr_mapping.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/vafr_mapping.wgsl")
    ),
    entry_points: &["forward", "inverse"],
    uniform: (
        "VafrParams",
        std::mem::size_of::<crate::mapping::vafr::VafrUniform>(),
    ),
};

/// The KFR / LMFR mapping (forward, inverse).
pub const KFR_MAPPING: ShaderSource = ShaderSource {
    file: "kfr_mapping.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/kfr_mapping.wgsl")
    ),
    entry_points: &["forward", "inverse"],
    uniform: (
        "KfrParams",
        std::mem::size_of::<crate::mapping::kfr::KfrUniform>(),
    ),
};

/// Every module of the crate.
pub const ALL: &[ShaderSource] = &[VAFR_MAPPING, KFR_MAPPING];
