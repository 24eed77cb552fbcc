//! The records both sides share, checked field by field (issue 37, item 9): every
//! `#[repr(C)]` struct the crate uploads into a WGSL struct, or reads back from one, against
//! that struct as naga lays it out (WGSL's own alignment rules, `naga::proc::Layouter`),
//! member by member — name, byte offset and size — in every module that declares it. The
//! Rust side stays the one declaration a record is written from; these tests make a drifted
//! WGSL twin (a member moved, resized, renamed or added) fail `cargo test` by name, no GPU
//! needed. A struct a module binds as a uniform or storage buffer (or one nested in such a
//! struct) that is missing from [`records`] fails too, so a new record cannot escape.
//!
//! Padding members (`_pad…`, `pad…`) carry nothing and are matched only through the
//! struct's total size and the offsets of the members around them.

#![cfg(test)]

use std::mem::{offset_of, size_of, size_of_val};

use crate::shaders::ShaderSource;
use crate::ALL_SHADERS;

/// A WGSL member and the Rust field (or array element) it is read from.
#[derive(Debug)]
struct Field {
    wgsl: &'static str,
    rust: &'static str,
    offset: usize,
    size: usize,
}

/// A Rust record and the WGSL struct it is laid over.
struct Record {
    rust: &'static str,
    wgsl: &'static str,
    /// Every module that declares the struct (a file appended to several modules is checked
    /// in each).
    modules: Vec<ShaderSource>,
    size: usize,
    fields: Vec<Field>,
}

macro_rules! field {
    ($z:ident, $ty:ty, $m:ident) => {
        field!($z, $ty, $m = $m)
    };
    ($z:ident, $ty:ty, $m:ident = $($p:ident).+ [$i:literal]) => {
        Field {
            wgsl: stringify!($m),
            rust: concat!(stringify!($($p).+), "[", stringify!($i), "]"),
            offset: offset_of!($ty, $($p).+) + $i * size_of_val(&$z.$($p).+[0]),
            size: size_of_val(&$z.$($p).+[0]),
        }
    };
    ($z:ident, $ty:ty, $m:ident = $($p:ident).+) => {
        Field {
            wgsl: stringify!($m),
            rust: stringify!($($p).+),
            offset: offset_of!($ty, $($p).+),
            size: size_of_val(&$z.$($p).+),
        }
    };
}

/// `record!(RustType => "WgslStruct" in [modules] { member, member = rust.path, member =
/// array[i], .. })`: a member without `=` is the Rust field of the same name.
macro_rules! record {
    ($ty:ty => $wgsl:literal in [$($module:expr),+ $(,)?] {
        $($m:ident $(= $($p:ident).+ $([$i:literal])?)?),* $(,)?
    }) => {{
        let z: $ty = bytemuck::Zeroable::zeroed();
        Record {
            rust: stringify!($ty),
            wgsl: $wgsl,
            modules: vec![$($module),+],
            size: size_of::<$ty>(),
            fields: vec![$(field!(z, $ty, $m $(= $($p).+ $([$i])?)?)),*],
        }
    }};
}

/// Every record the crate shares with its shaders.
fn records() -> Vec<Record> {
    use crate::{denoise as dn, frame};
    use crate::{dof, environment_light as env, mapping, pull_push, reconstruct, sample_aa};
    use crate::{surface, tonemap, trace};
    let (tr, sf, fs) = (trace::SHADER, surface::SHADER, frame::shade::SHADER);
    // The bounce kernels' module is the shade module's files with frame_bounce.wgsl appended.
    let bo = frame::bounce::SHADER;
    vec![
        record!(trace::TraceUniform => "TraceParams" in [tr, sf, fs, bo] {
            ray_count, light_count, pi = model.pi, offset_per_t = model.offset_per_t,
            offset_t_cap = model.offset_t_cap, shadow_shorten = model.shadow_shorten,
            min_light_distance = model.min_light_distance,
            spot_min_width = model.spot_min_width, min_nv = model.min_nv,
            d_floor = model.d_floor, vis_floor = model.vis_floor, max_distance,
        }),
        record!(trace::NodeGpu => "Node" in [tr, sf, fs, bo] { min, prim_count, max, first_index }),
        record!(trace::TriGpu => "Tri" in [tr, sf, fs, bo] { v0, v1, v2 }),
        record!(trace::GpuRay => "Ray" in [tr, sf, fs, bo] { origin, t_min, dir, t_max }),
        record!(trace::HitGpu => "Hit" in [tr, sf, fs, bo] { t, prim, u, v }),
        record!(crate::RayGenCamera => "RayGenCamera" in [tr, sf, fs, bo] {
            origin, fx, forward, fy, right, rad_per_turn, up, px_per_q, centre, centre_lo,
        }),
        record!(crate::GpuPolarRay => "PolarRay" in [tr, sf, fs, bo] { offset_q }),
        record!(crate::GpuScreenRay => "ScreenRay" in [tr, sf, fs, bo] { x_px, y_px }),
        record!(crate::ray_generation::GeneratedHitGpu => "GeneratedHit" in [tr, sf, fs, bo] {
            hit, dir,
        }),
        record!(crate::GpuSurface => "Surface" in [tr, fs, bo] {
            position, t, normal, metallic, face_normal, roughness, to_eye, key_lo, albedo,
            key_hi, specular,
        }),
        record!(crate::GpuLight => "Light" in [tr, fs, bo] {
            position, kind, direction, range, intensity, cos_inner, cos_outer,
        }),
        record!(env::EnvUniform => "EnvParams" in [tr, fs, bo] {
            samples, n_map, n_brdf, kind, salt, mix_increment, mix_mul0, mix_mul1, mix_shifts,
            r2_a1, r2_a2, r2_half, width, height, luminance, constant, map_from_world,
            world_from_map, tau, below_one, x_max, turns_per_rad, off_marginal_cdf,
            off_marginal_func, off_cond_cdf, off_cond_func, off_cond_int, off_cos_edge,
            marginal_int, frame_mask_hi,
        }),
        record!(crate::GpuSurfaceRay => "SurfaceRay" in [sf, fs, bo] { a, b, spread }),
        record!(surface::SurfaceTriGpu => "SurfaceTri" in [sf, fs, bo] {
            v0 = v[0], v1 = v[1], v2 = v[2], material, slot, uv_per_metre, flags,
        }),
        record!(surface::SurfaceVertexGpu => "SurfaceVertex" in [sf, fs, bo] {
            normal, u, tangent, color, v,
        }),
        record!(surface::SurfaceMaterialGpu => "SurfaceMaterial" in [sf, fs, bo] {
            base_color, metallic, specular, roughness, emissive, normal_scale,
            base_mip = base[0], base_levels = base[1],
            mr_mip = metallic_roughness[0], mr_levels = metallic_roughness[1],
            normal_mip = normal_map[0], normal_levels = normal_map[1],
        }),
        record!(surface::MipGpu => "Mip" in [sf, fs, bo] { offset, width, height }),
        record!(surface::SurfaceModelGpu => "SurfaceModel" in [sf, fs, bo] {
            min_cos, min_footprint_texels, trilinear_min_fraction, min_roughness,
            tangent_det_floor,
        }),
        record!(surface::GRecordGpu => "GRecord" in [sf, fs, bo] {
            position, t, normal, metallic, face_normal, roughness, to_eye, material, albedo,
            specular, emissive,
        }),
        record!(dof::CocUniform => "DofCocParams" in [dof::COC_SHADER] {
            width, height, form, lut_max_k, a, b, max_coc_px, no_hit_coc_px, max_radius_px,
            lut_steps_per_px,
        }),
        record!(dof::GatherUniform => "GatherParams" in [dof::GATHER_SHADER] {
            width, height, tiles_x, tiles_y, tile_px, span, n_offsets, flags, near_factor,
            far_factor,
        }),
        record!(dof::OffsetGpu => "Offset" in [dof::GATHER_SHADER] { dx, dy, d }),
        record!(mapping::kfr::KfrUniform => "KfrParams" in [mapping::kfr::SHADER] {
            gaze_hi, gaze_lo, ln_l, r_max_px, l_px, width, height, alpha, inv_alpha,
            rad_per_turn, turns_per_rad,
        }),
        record!(mapping::lafr::LafrUniform => "LafrParams" in [mapping::lafr::SHADER] {
            gaze_hi, gaze_lo, ln_l, r_max_px, l_px, width, height, f, inv_f, ln_one_minus_f,
            inv_one_minus_f, z_ef, one_minus_z_ef, u_ef, one_minus_u_ef, k, inv_k,
            four_over_pi, eighth_turn, rad_per_turn, turns_per_rad,
        }),
        record!(mapping::vafr::VafrUniform => "VafrParams" in [mapping::vafr::SHADER] {
            gaze_hi, gaze_lo, c_r, r_max_px, u_max, deg_per_rad, rad_per_deg, deg_per_turn,
            rad_per_turn, turns_per_rad, n_segments, n_tangential, segments, segments_ext,
            tangential,
        }),
        record!(mapping::polar_table::PolarTableUniform => "PolarTableParams"
            in [mapping::polar_table::SHADER] {
            gaze_hi, gaze_lo, r_max, u_max, rad_per_turn, turns_per_rad,
        }),
        record!(mapping::polar_table::TableSegment => "TableSegment"
            in [mapping::polar_table::SHADER] { r, u, ext }),
        record!(reconstruct::ReconstructUniform => "ReconstructParams" in [reconstruct::SHADER] {
            pole_hi, pole_lo, width, row0, band_rows, lut_max_k, inv_step, cols_end, last,
            miss_depth_bits, footprint, turns_per_rad, rad_per_turn,
        }),
        record!(reconstruct::GpuColumn => "Column" in [reconstruct::SHADER] {
            base, rows, period, texels_per_px,
        }),
        record!(pull_push::PullPushUniform => "PullPushParams" in [pull_push::SHADER] {
            fine_w, fine_h, fine_off, fine_level, coarse_w, coarse_h, coarse_off,
            coarse_wt_off, fine_wt_off, n, max_radius, miss_depth_bits,
        }),
        record!(sample_aa::SampleAaUniform => "SampleAaParams"
            in [sample_aa::FXAA_SHADER, sample_aa::GAUSSIAN_SHADER] {
            width, height, polar, search_steps, edge_threshold, edge_threshold_min, subpix,
        }),
        record!(tonemap::ToneUniform => "ToneParams" in [tonemap::SHADER] {
            n_values, n_words, scale, curve,
        }),
        record!(frame::shade::FrameLayerGpu => "FrameLayer" in [fs, bo] {
            offset, width, height, key_hi,
        }),
        record!(frame::shade::FrameUniform => "FrameParams" in [fs, bo] {
            texels, kind, inf_bits, unshadowed, layer, offset, pixel_spread, row_invocations,
            ambient, rank, guides, listed,
        }),
        record!(frame::shade::FrameColumnGpu => "FrameColumn" in [fs, bo] {
            r_px, period, spread, runs,
        }),
        record!(frame::layers::ShadeLayerGpu => "FrameScreenLayer" in [fs, bo] {
            origin, scale, steps, shaded, gaze, c_r, floor_rad, max_rad, pad0 = pad[0],
            pad1 = pad[1], pad2 = pad[2], step_r, step_scale,
        }),
        record!(frame::bounce::BounceUniform => "BounceParams" in [bo] {
            bounces, unit_bits, roulette_max, spread, first_salt, later_salt, env_keys,
        }),
        record!(frame::layers::LayerRecordGpu => "LayerRecord" in [frame::layers::SHADER] {
            origin, size, disc, rect, scale, offset, width, pad,
        }),
        record!(frame::layers::LayersUniform => "LayersParams" in [frame::layers::SHADER] {
            width, height, count, inf_bits, inset, strip, pad0 = pad[0], pad1 = pad[1],
            pad2 = pad[2], layers,
        }),
        record!(frame::pull_push::MaskUniform => "MaskParams"
            in [frame::pull_push::MASK_SHADER] { pixels, width, words, pad }),
        record!(frame::reconstruct::PadUniform => "PadParams" in [frame::reconstruct::PAD_SHADER] {
            offset, width, n_columns, stored_max, aa,
        }),
        record!(frame::reconstruct::FrameColumn => "PadColumn"
            in [frame::reconstruct::PAD_SHADER] { base, rows, period, texels_per_px }),
        record!(frame::screen::SplitUniform => "SplitParams" in [frame::screen::SPLIT_SHADER] {
            offset, width, height,
        }),
        record!(frame::screen::PresentUniform => "PresentParams"
            in [frame::screen::PRESENT_SHADER] { width, height, row_words }),
        record!(frame::temporal::TemporalCameraGpu => "TemporalCamera"
            in [frame::temporal::SHADER] { origin, fx, forward, fy, right, cx, up, cy }),
        record!(frame::temporal::TemporalViewGpu => "TemporalView"
            in [frame::temporal::SHADER] {
            camera, gaze, offset, width, height, kind, columns, table, spacing, spacing_len,
            steps_per_deg,
        }),
        record!(frame::temporal::TemporalUniform => "TemporalParams"
            in [frame::temporal::SHADER] {
            cur, prev, screen, alpha_min, tau, c_r, clamp, history, row_invocations, inf_bits,
            guides, moments, albedo_floor,
        }),
        record!(dn::DenoiseUniform => "DenoiseParams" in [dn::SHADER] {
            texels, layer_count, atrous_step, taps, sigma_l, sigma_z, sigma_n, firefly_k,
            same_normal, listed, layers,
        }),
    ]
}

/// Structs written and read on the device only (no Rust twin): each module that declares
/// one must lay it out alike, and `bytes` is what the Rust side allocates per element.
/// None today: the depth of field's `Plane` became three scalar planes (issue 37).
fn device_only() -> Vec<(&'static str, Vec<ShaderSource>, usize)> {
    Vec::new()
}

/// A WGSL struct member as naga lays it out: name, offset, size.
type Member = (String, usize, usize);

/// A parsed module and its layouts.
struct Parsed {
    file: &'static str,
    module: naga::Module,
    layouter: naga::proc::Layouter,
}

fn parse(shader: &ShaderSource) -> Parsed {
    let module = naga::front::wgsl::parse_str(shader.source)
        .unwrap_or_else(|e| panic!("{}: {}", shader.file, e.emit_to_string(shader.source)));
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .unwrap_or_else(|e| panic!("{}: layout: {e:?}", shader.file));
    Parsed {
        file: shader.file,
        module,
        layouter,
    }
}

impl Parsed {
    /// The struct `name`'s span and members, if the module declares it.
    fn struct_layout(&self, name: &str) -> Option<(usize, Vec<Member>)> {
        let (_, ty) = self
            .module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))?;
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            return None;
        };
        let members = members
            .iter()
            .map(|m| {
                let name = m.name.clone().unwrap_or_default();
                (name, m.offset as usize, self.layouter[m.ty].size as usize)
            })
            .collect();
        Some((*span as usize, members))
    }

    /// The struct types the module binds as uniform or storage buffers (directly or as an
    /// array's element), and every struct nested in those.
    fn bound_structs(&self) -> Vec<String> {
        let types = &self.module.types;
        let mut todo: Vec<naga::Handle<naga::Type>> = self
            .module
            .global_variables
            .iter()
            .filter(|(_, g)| {
                matches!(
                    g.space,
                    naga::AddressSpace::Uniform | naga::AddressSpace::Storage { .. }
                )
            })
            .map(|(_, g)| g.ty)
            .collect();
        let mut out = Vec::new();
        while let Some(h) = todo.pop() {
            match &types[h].inner {
                naga::TypeInner::Array { base, .. }
                | naga::TypeInner::BindingArray { base, .. } => todo.push(*base),
                naga::TypeInner::Struct { members, .. } => {
                    let name = types[h].name.clone().unwrap_or_default();
                    if !out.contains(&name) {
                        out.push(name);
                        todo.extend(members.iter().map(|m| m.ty));
                    }
                }
                _ => {}
            }
        }
        out
    }
}

/// Whether a member is padding.
fn is_padding(name: &str) -> bool {
    name.starts_with('_')
        || name
            .strip_prefix("pad")
            .is_some_and(|rest| rest.chars().all(|c| c.is_ascii_digit()))
}

/// Every difference between `record` and its WGSL struct in `parsed`, one line each.
fn mismatches(record: &Record, parsed: &Parsed) -> Vec<String> {
    let at = format!("{} `{}` ({})", parsed.file, record.wgsl, record.rust);
    let Some((span, members)) = parsed.struct_layout(record.wgsl) else {
        return vec![format!("{at}: no such struct in the module")];
    };
    let mut out = Vec::new();
    if span != record.size {
        out.push(format!(
            "{at}: WGSL spans {span} bytes, Rust {}",
            record.size
        ));
    }
    for f in &record.fields {
        match members.iter().find(|(n, _, _)| n == f.wgsl) {
            None => out.push(format!(
                "{at}: Rust `{}` has no WGSL member `{}`",
                f.rust, f.wgsl
            )),
            Some((_, offset, size)) => {
                if (*offset, *size) != (f.offset, f.size) {
                    out.push(format!(
                        "{at}: member `{}` is at byte {offset} ({size} bytes) in WGSL, Rust `{}` \
                         at byte {} ({} bytes)",
                        f.wgsl, f.rust, f.offset, f.size
                    ));
                }
            }
        }
    }
    for (name, offset, _) in &members {
        if !is_padding(name) && !record.fields.iter().any(|f| f.wgsl == name) {
            out.push(format!(
                "{at}: WGSL member `{name}` (byte {offset}) has no Rust field"
            ));
        }
    }
    out
}

/// Parses each module of `ALL_SHADERS` once.
fn parse_all() -> Vec<Parsed> {
    ALL_SHADERS.iter().map(parse).collect()
}

#[test]
fn every_shared_record_matches_its_wgsl_struct_member_by_member() {
    let parsed = parse_all();
    let mut errors = Vec::new();
    let mut checked = 0;
    for record in records() {
        assert!(!record.fields.is_empty(), "{}", record.rust);
        for module in &record.modules {
            let p = parsed
                .iter()
                .find(|p| p.file == module.file)
                .unwrap_or_else(|| panic!("{} is not in ALL_SHADERS", module.file));
            errors.extend(mismatches(&record, p));
            checked += 1;
        }
    }
    assert!(errors.is_empty(), "{}", errors.join("\n"));
    assert!(checked >= records().len());
}

#[test]
fn device_only_structs_agree_across_modules() {
    let parsed = parse_all();
    for (name, modules, bytes) in device_only() {
        let layouts: Vec<(usize, Vec<Member>)> = modules
            .iter()
            .map(|m| {
                let p = parsed.iter().find(|p| p.file == m.file).unwrap();
                p.struct_layout(name)
                    .unwrap_or_else(|| panic!("{}: no struct {name}", m.file))
            })
            .collect();
        for (m, l) in modules.iter().zip(&layouts) {
            assert_eq!(
                l, &layouts[0],
                "{}: {name} differs from {}",
                m.file, modules[0].file
            );
            assert_eq!(
                l.0, bytes,
                "{}: {name} spans {} bytes, Rust allocates {bytes}",
                m.file, l.0
            );
        }
    }
}

#[test]
fn every_bound_struct_is_a_checked_record() {
    // A struct a module binds (or nests in a bound one) is either a record above, in that
    // module, or a device-only struct: nothing bound escapes the field-by-field check.
    let records = records();
    let device = device_only();
    let mut missing = Vec::new();
    let mut seen = 0;
    for p in parse_all() {
        for name in p.bound_structs() {
            seen += 1;
            let known = records
                .iter()
                .any(|r| r.wgsl == name && r.modules.iter().any(|m| m.file == p.file))
                || device
                    .iter()
                    .any(|(n, ms, _)| *n == name && ms.iter().any(|m| m.file == p.file));
            if !known {
                missing.push(format!("{}: `{name}`", p.file));
            }
        }
    }
    assert!(seen > 30, "{seen} bound structs: the walk found too few");
    assert!(
        missing.is_empty(),
        "bound WGSL structs with no Rust record in fovea_gpu::records: {}",
        missing.join(", ")
    );
}

#[test]
fn a_moved_member_is_named() {
    // The check can fail: swapping two members of a copy of a module is reported, naming
    // the members.
    let shader = crate::trace::SHADER;
    let moved = shader.source.replacen(
        "struct RayGenCamera {\n    // Eye position, world space.\n    origin: vec3<f32>,\n    // Focal length along x, pixels.\n    fx: f32,",
        "struct RayGenCamera {\n    fx: f32,\n    origin: vec3<f32>,",
        1,
    );
    assert_ne!(moved, shader.source, "the test's edit no longer applies");
    let moved = ShaderSource {
        source: Box::leak(moved.into_boxed_str()),
        ..shader
    };
    let record = records()
        .into_iter()
        .find(|r| r.wgsl == "RayGenCamera")
        .unwrap();
    let errors = mismatches(&record, &parse(&moved));
    assert!(
        errors.iter().any(|e| e.contains("`origin`")) && errors.iter().any(|e| e.contains("`fx`")),
        "{errors:?}"
    );
    // And an extra member, or a missing one.
    let extra = shader
        .source
        .replacen("    y_px: f32,\n}", "    y_px: f32,\n    w: f32,\n}", 1);
    let extra = ShaderSource {
        source: Box::leak(extra.into_boxed_str()),
        ..shader
    };
    let record = records()
        .into_iter()
        .find(|r| r.wgsl == "ScreenRay")
        .unwrap();
    let errors = mismatches(&record, &parse(&extra));
    assert!(
        errors
            .iter()
            .any(|e| e.contains("`w`") && e.contains("no Rust field"))
            && errors.iter().any(|e| e.contains("spans 12 bytes")),
        "{errors:?}"
    );
}
