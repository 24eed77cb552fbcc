//! Every WGSL module of the crate parses and validates with naga (the shader compiler wgpu
//! itself uses), its entry points are the ones the Rust side creates pipelines for, with the
//! workgroup size the Rust side dispatches with, and its uniform block has the size of the
//! Rust struct uploaded into it. No GPU and no driver needed.

use fovea_gpu::shaders::{ShaderSource, COMMON_FILE, WORKGROUP_SIZE};
use fovea_gpu::ALL_SHADERS as ALL;

fn validate(shader: &ShaderSource) -> (naga::Module, naga::valid::ModuleInfo) {
    let module = naga::front::wgsl::parse_str(shader.source).unwrap_or_else(|e| {
        panic!(
            "{} does not parse:\n{}",
            shader.file,
            e.emit_to_string(shader.source)
        )
    });
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .unwrap_or_else(|e| {
        panic!(
            "{} does not validate:\n{}",
            shader.file,
            e.emit_to_string(shader.source)
        )
    });
    (module, info)
}

#[test]
fn every_module_parses_and_validates() {
    assert!(!ALL.is_empty());
    for shader in ALL {
        validate(shader);
    }
}

#[test]
fn entry_points_are_the_dispatched_ones() {
    for shader in ALL {
        let (module, _) = validate(shader);
        let mut names: Vec<&str> = module
            .entry_points
            .iter()
            .map(|e| e.name.as_str())
            .collect();
        names.sort_unstable();
        let mut want = shader.entry_points.to_vec();
        want.sort_unstable();
        assert_eq!(names, want, "{}", shader.file);
        for e in &module.entry_points {
            assert_eq!(
                e.stage,
                naga::ShaderStage::Compute,
                "{}::{}",
                shader.file,
                e.name
            );
            assert_eq!(
                e.workgroup_size,
                [WORKGROUP_SIZE, 1, 1],
                "{}::{}: the Rust side dispatches ceil(n / {WORKGROUP_SIZE}) workgroups",
                shader.file,
                e.name
            );
        }
    }
}

#[test]
fn uniform_blocks_match_their_rust_structs() {
    for shader in ALL {
        let (name, rust_size) = shader.uniform;
        let span = struct_span(shader, name);
        assert_eq!(
            span, rust_size,
            "{}: WGSL {name} is {span} bytes, its Rust twin {rust_size}",
            shader.file
        );
    }
}

#[test]
fn the_polar_table_segment_matches_its_rust_struct() {
    // The segment table is read as an array of `TableSegment`: a size mismatch would shift
    // every segment after the first.
    let shader = fovea_gpu::mapping::polar_table::SHADER;
    let (name, rust_size) = fovea_gpu::mapping::polar_table::SEGMENT_STRUCT;
    assert_eq!(
        struct_span(&shader, name),
        rust_size,
        "{}: WGSL {name}",
        shader.file
    );
}

/// The size in bytes of WGSL struct `name` of `shader`'s module, as naga lays it out.
/// Each `(name, size)`: the WGSL struct `name` of `shader` spans the Rust twin's `size` bytes.
fn assert_struct_sizes(shader: &ShaderSource, structs: &[(&str, usize)]) {
    for &(name, rust_size) in structs {
        assert_eq!(
            struct_span(shader, name),
            rust_size,
            "{}: WGSL {name}",
            shader.file
        );
    }
}

fn struct_span(shader: &ShaderSource, name: &str) -> usize {
    let (module, _) = validate(shader);
    let ty = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("{}: no struct {name}", shader.file))
        .1;
    let naga::TypeInner::Struct { span, .. } = &ty.inner else {
        panic!("{}: {name} is not a struct", shader.file)
    };
    *span as usize
}

#[test]
fn the_ray_generation_records_match_their_rust_structs() {
    // The camera block and the per-ray records of `ray_generation.wgsl` (appended to the trace
    // module): a size mismatch would misread every field or every ray after the first.
    let shader = fovea_gpu::trace::SHADER;
    assert_struct_sizes(
        &shader,
        &[
            (
                "RayGenCamera",
                std::mem::size_of::<fovea_gpu::RayGenCamera>(),
            ),
            ("PolarRay", std::mem::size_of::<fovea_gpu::GpuPolarRay>()),
            ("ScreenRay", std::mem::size_of::<fovea_gpu::GpuScreenRay>()),
            fovea_gpu::ray_generation::GENERATED_HIT_STRUCT,
        ],
    );
}

#[test]
fn the_surface_records_match_their_rust_structs() {
    // The surface pass's per-ray, per-triangle, per-vertex, per-material, per-level and
    // per-record structs: a size mismatch would misread every element after the first.
    assert_struct_sizes(
        &fovea_gpu::surface::SHADER,
        &fovea_gpu::surface::RECORD_STRUCTS,
    );
}

#[test]
fn the_pull_push_block_matches_its_rust_struct() {
    // One block per dispatch of `pull_push.wgsl`: a size mismatch would misread the levels.
    assert_struct_sizes(
        &fovea_gpu::pull_push::SHADER,
        &[(
            "PullPushParams",
            std::mem::size_of::<fovea_gpu::pull_push::PullPushUniform>(),
        )],
    );
}

#[test]
fn the_environment_light_records_match_their_rust_structs() {
    // The environment's block and the surface samples of `environment_light.wgsl` and
    // `direct_light.wgsl` (appended to the trace module).
    let shader = fovea_gpu::trace::SHADER;
    assert_struct_sizes(
        &shader,
        &[
            (
                "EnvParams",
                std::mem::size_of::<fovea_gpu::environment_light::EnvUniform>(),
            ),
            ("Surface", std::mem::size_of::<fovea_gpu::GpuSurface>()),
        ],
    );
}

#[test]
fn every_wgsl_file_is_compiled_by_some_module() {
    // A shader file on disk that no module includes would escape validation: each file is
    // a module's own or appended to one (`direct_light.wgsl` and `ray_generation.wgsl` to the
    // trace module), its whole
    // text in the module's source.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().into_string().unwrap();
        if !name.ends_with(".wgsl") {
            continue;
        }
        seen += 1;
        let text = std::fs::read_to_string(entry.path()).unwrap();
        assert!(
            name == COMMON_FILE || ALL.iter().any(|s| s.source.contains(text.as_str())),
            "shaders/{name} is in no module of fovea_gpu::ALL_SHADERS"
        );
    }
    // Every module's own file (surface.wgsl is the surface module's), common.wgsl, the
    // appended direct_light.wgsl, ray_generation.wgsl, environment_light.wgsl and
    // frame_shade_layers.wgsl, the AA modules' shared sample_grid.wgsl, frame_sparse.wgsl
    // (the shade and Weier mask modules') and frame_compact.wgsl (the shade module's list of
    // shaded texels).
    assert_eq!(seen, ALL.len() + 7 + 1);
}

#[test]
fn a_broken_shader_is_caught() {
    // The check above can fail: a type error in a copy of a module is reported.
    let broken = ShaderSource {
        source: Box::leak(
            ALL[0]
                .source
                .replacen("let r = length(d);", "let r: u32 = length(d);", 1)
                .into_boxed_str(),
        ),
        ..ALL[0]
    };
    assert_ne!(broken.source, ALL[0].source);
    let module = naga::front::wgsl::parse_str(broken.source);
    let failed = match module {
        Err(_) => true,
        Ok(m) => naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&m)
        .is_err(),
    };
    assert!(failed);
}

#[test]
fn the_resident_frame_records_match_their_rust_structs() {
    assert_struct_sizes(
        &fovea_gpu::frame::shade::SHADER,
        &fovea_gpu::frame::shade::RECORD_STRUCTS,
    );
    assert_struct_sizes(
        &fovea_gpu::frame::shade::SHADER,
        &fovea_gpu::frame::layers::SHADE_RECORD_STRUCTS,
    );
    assert_struct_sizes(
        &fovea_gpu::frame::layers::SHADER,
        &fovea_gpu::frame::layers::RECORD_STRUCTS,
    );
}
