//! The trace stage's ray casting on the GPU (issue 18): closest hits and occlusion of batches
//! of rays against a scene's triangles, through a binary BVH built here on the CPU by obvhs
//! (PLOC with reinsertion, `BvhBuildParams::medium_build`) and traversed in WGSL
//! (`shaders/trace.wgsl`) with a 64-entry stack, one invocation per ray.
//!
//! The ray/triangle test is the CPU's (`fovea_render::bvh::intersect_triangle`: Möller–Trumbore,
//! both faces, `t_min ≤ t ≤ t_max`), so a GPU hit is the CPU's hit up to f32 rounding
//! (`tests/trace.rs` compares them against brute force and against the CPU renderer's BVH on
//! the built-in scene). The tree's depth is checked against the shader's stack before upload
//! ([`GpuError::Input`] when deeper), so the traversal never drops a subtree.
//!
//! Here the caller hands whole rays in and gets hits back; [`crate::ray_generation`] builds
//! the primary rays on the device from their screen points instead.

use bytemuck::{Pod, Zeroable};
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::BvhBuildParams;

use crate::device::GpuContext;
use crate::error::{GpuError, Result};
use crate::shaders::ShaderSource;
use crate::transfer::{batch_len, run_1d, run_1d_at, upload};

/// The module: `closest_hit` and `any_hit`, `direct_light` (`shaders/direct_light.wgsl`,
/// appended: it walks the same BVH; see [`crate::direct_light`]), `closest_hit_polar` and
/// `closest_hit_screen` (`shaders/ray_generation.wgsl`, appended; see
/// [`crate::ray_generation`]), and `environment_light` and `mix64_check`
/// (`shaders/environment_light.wgsl`, appended; see [`crate::environment_light`]),
/// [`TraceUniform`] at binding 0.
pub const SHADER: ShaderSource = ShaderSource {
    file: "trace.wgsl",
    source: concat!(
        include_str!("../shaders/common.wgsl"),
        include_str!("../shaders/trace.wgsl"),
        include_str!("../shaders/direct_light.wgsl"),
        include_str!("../shaders/ray_generation.wgsl"),
        include_str!("../shaders/environment_light.wgsl")
    ),
    entry_points: &[
        "closest_hit",
        "any_hit",
        "direct_light",
        "closest_hit_polar",
        "closest_hit_screen",
        "environment_light",
        "mix64_check",
        // A probe of `closest_hit_polar`'s point (`GpuTracer::polar_points`), built on use.
        "polar_point_check",
    ],
    uniform: ("TraceParams", std::mem::size_of::<TraceUniform>()),
};

/// Bytes per triangle on the device (`Tri` in `trace.wgsl`: three `vec4<f32>`): the largest
/// binding a scene needs is its triangle count times this.
pub const TRIANGLE_BYTES: u64 = std::mem::size_of::<TriGpu>() as u64;

/// The traversal stack of `trace.wgsl` (`STACK_SIZE`): the deepest tree it can walk.
pub const STACK_SIZE: usize = 64;

/// The shading model's constants as `TraceParams` carries them (see
/// `fovea_render::shade::constants` for each one's meaning; the renderer's values are
/// `DirectLightModel::RENDERER`, in `crate::direct_light`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DirectLightModel {
    /// π.
    pub pi: f32,
    /// Shadow-ray origin offset per (1 + t).
    pub offset_per_t: f32,
    /// The cap on `t` in that offset.
    pub offset_t_cap: f32,
    /// A shadow ray stops `dist · (1 − shadow_shorten)` along.
    pub shadow_shorten: f32,
    /// Lights nearer than this light nothing.
    pub min_light_distance: f32,
    /// A spot's cone width is taken at least this wide.
    pub spot_min_width: f32,
    /// `n·v` is taken at least this large.
    pub min_nv: f32,
    /// GGX `D`'s denominator floor.
    pub d_floor: f32,
    /// The visibility term's denominator floor.
    pub vis_floor: f32,
}

/// The uniform block `TraceParams` of `trace.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TraceUniform {
    /// Rays in the batch (`direct_light`: surface samples).
    pub ray_count: u32,
    /// `direct_light`: the lights.
    pub light_count: u32,
    _pad: [u32; 2],
    /// `direct_light`: the shading model's constants.
    pub model: DirectLightModel,
    /// The largest `t_max` the shader sees (`direct_light`: a directional light's shadow rays).
    pub max_distance: f32,
    _pad2: [f32; 2],
}

impl TraceUniform {
    /// The block of a batch of `count` rays or samples, with `lights` lights and `model`.
    pub(crate) fn new(count: usize, lights: usize, model: DirectLightModel) -> Self {
        Self {
            ray_count: count as u32,
            light_count: lights as u32,
            _pad: [0; 2],
            model,
            max_distance: MAX_DISTANCE,
            _pad2: [0.0; 2],
        }
    }
}

/// A ray as the shader reads it: origin, `t_min`, direction (any length; the hit's `t` is in
/// its units), `t_max`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    /// Origin, world space.
    pub origin: [f32; 3],
    /// Nearest accepted distance.
    pub t_min: f32,
    /// Direction.
    pub dir: [f32; 3],
    /// Farthest accepted distance.
    pub t_max: f32,
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuHit {
    /// Distance along the ray.
    pub t: f32,
    /// The triangle's index in the list the tracer was built from.
    pub tri: u32,
    /// Barycentric coordinates of vertices 1 and 2.
    pub bary: [f32; 2],
}

/// A node as the shader reads it (`Node` in `trace.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct NodeGpu {
    pub(crate) min: [f32; 3],
    pub(crate) prim_count: u32,
    pub(crate) max: [f32; 3],
    pub(crate) first_index: u32,
}

/// A triangle as the shader reads it (`Tri` in `trace.wgsl`): its vertices, each padded to
/// a `vec4`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct TriGpu {
    pub(crate) v0: [f32; 4],
    pub(crate) v1: [f32; 4],
    pub(crate) v2: [f32; 4],
}

impl TriGpu {
    fn of(t: &[[f32; 3]; 3]) -> Self {
        let v = |p: [f32; 3]| [p[0], p[1], p[2], 0.0];
        Self {
            v0: v(t[0]),
            v1: v(t[1]),
            v2: v(t[2]),
        }
    }
}

/// The hit as the shader writes it (`Hit` in `trace.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct HitGpu {
    pub(crate) t: f32,
    pub(crate) prim: u32,
    pub(crate) u: f32,
    pub(crate) v: f32,
}

/// The largest `t_max` the shader sees (below its `FAR` marker of 3e38).
pub(crate) const MAX_DISTANCE: f32 = 1.0e38;
/// `Hit::prim` of a miss.
pub(crate) const MISS: u32 = u32::MAX;
const RAY_BYTES: u64 = std::mem::size_of::<GpuRay>() as u64;
const HIT_BYTES: u64 = std::mem::size_of::<HitGpu>() as u64;

impl TraceTimes {
    /// Counts one more batch, its pass's milliseconds (when timed) added to the sum.
    pub(crate) fn add_batch(&mut self, pass_ms: Option<f64>) {
        self.batches += 1;
        if let Some(ms) = pass_ms {
            self.gpu_pass_ms = Some(self.gpu_pass_ms.unwrap_or(0.0) + ms);
        }
    }
}

/// One batch of a trace-module entry point that reads the scene: its parameter block (binding
/// 0), its own inputs (`(binding, bytes, usage)`, at bindings 6 and up; `resident`: buffers
/// already on the device) and its output per item (at binding 8), for
/// [`GpuTracer::run_scene_pass`].
pub(crate) struct ScenePass<'a> {
    pub(crate) what: &'a str,
    pub(crate) block: TraceUniform,
    pub(crate) inputs: &'a [(u32, &'a [u8], wgpu::BufferUsages)],
    pub(crate) resident: &'a [(u32, &'a wgpu::Buffer)],
    pub(crate) items: usize,
    pub(crate) out_bytes: u64,
}

/// What was built and uploaded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhStats {
    /// Triangles.
    pub triangles: usize,
    /// Nodes of the binary tree.
    pub nodes: usize,
    /// Its depth (a lone leaf is 1).
    pub depth: usize,
    /// CPU time of the build, ms (wall).
    pub build_ms: f64,
}

/// Where the time of one [`GpuTracer::closest_hits_timed`] went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceTimes {
    /// The compute passes alone, summed over the batches, from the device's timestamps
    /// (`None` when it has no `TIMESTAMP_QUERY`, or no ray reached the device), ms.
    pub gpu_pass_ms: Option<f64>,
    /// Batches (one compute pass each) the rays were split into.
    pub batches: u32,
    /// Everything, from the call to the hits in hand (preparing, uploading, tracing,
    /// reading back), wall ms.
    pub total_ms: f64,
}

/// The scene's triangles and BVH on one device, with the two traversal pipelines.
pub struct GpuTracer {
    pub(crate) ctx: GpuContext,
    stats: BvhStats,
    /// `None` for an empty scene (every ray misses without a dispatch).
    pub(crate) scene: Option<SceneBuffers>,
    /// The hash check's pipeline (`mix64_check`; built with the scene's, or on first use
    /// for an empty scene).
    pub(crate) mix64: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The polar-point probe's pipeline (`polar_point_check`; built on first use, by tests).
    pub(crate) polar_probe: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// Each triangle's position in the BVH's leaf order (the device's triangle buffer), by
    /// its index in the caller's list ([`crate::surface`] reads its vertices there).
    pub(crate) slots: Vec<u32>,
}

pub(crate) struct SceneBuffers {
    pub(crate) nodes: wgpu::Buffer,
    pub(crate) tris: wgpu::Buffer,
    pub(crate) prim_ids: wgpu::Buffer,
    closest: wgpu::ComputePipeline,
    any: wgpu::ComputePipeline,
    pub(crate) direct: wgpu::ComputePipeline,
    pub(crate) polar: wgpu::ComputePipeline,
    pub(crate) screen: wgpu::ComputePipeline,
    pub(crate) environment: wgpu::ComputePipeline,
}

impl GpuTracer {
    /// Builds the BVH of `triangles` (vertices in world space) on the CPU and uploads it.
    /// Errors: a non-finite vertex, a tree deeper than [`STACK_SIZE`], or buffers larger than
    /// the adapter binds ([`GpuError::AdapterTooSmall`], before any allocation).
    pub fn new(ctx: &GpuContext, triangles: &[[[f32; 3]; 3]]) -> Result<Self> {
        if let Some(k) = triangles
            .iter()
            .position(|t| t.iter().flatten().any(|c| !c.is_finite()))
        {
            return Err(GpuError::Input(format!(
                "triangle {k} has a non-finite vertex coordinate"
            )));
        }
        let t0 = std::time::Instant::now();
        if triangles.is_empty() {
            return Ok(Self {
                ctx: ctx.clone(),
                stats: BvhStats {
                    triangles: 0,
                    nodes: 0,
                    depth: 0,
                    build_ms: 0.0,
                },
                scene: None,
                mix64: std::sync::OnceLock::new(),
                polar_probe: std::sync::OnceLock::new(),
                slots: Vec::new(),
            });
        }
        // The CPU backend's binary BVH (`fovea_render::bvh::same_box`): exact duplicates left
        // out and triangles sharing a box gathered, so degenerate input builds in O(n log n)
        // (PLOC alone is quadratic on it; no hit changes), then collapsed to obvhs' leaves.
        // A duplicate's slot is its first occurrence's.
        let verts: Vec<[glam::Vec3; 3]> =
            triangles.iter().map(|t| t.map(glam::Vec3::from)).collect();
        let distinct = fovea_render::bvh::Distinct::of(&verts);
        let params = BvhBuildParams::medium_build();
        let mut bvh = fovea_render::bvh::same_box::build_bvh2(&verts, &distinct);
        drop(verts);
        collapse(
            &mut bvh,
            params.max_prims_per_leaf.clamp(1, 255),
            params.collapse_traversal_cost,
        );
        let depth = tree_depth(&bvh.nodes);
        check_depth(depth)?;
        let nodes: Vec<NodeGpu> = bvh.nodes.iter().map(node_gpu).collect();
        // Triangles in leaf order, so a leaf's `first_index` addresses them directly.
        let tris: Vec<TriGpu> = bvh
            .primitive_indices
            .iter()
            .map(|&i| TriGpu::of(&triangles[i as usize]))
            .collect();
        let mut slots = vec![0u32; triangles.len()];
        for (slot, &i) in bvh.primitive_indices.iter().enumerate() {
            slots[i as usize] = slot as u32;
        }
        if let Some(first) = &distinct.first {
            for (k, &f) in first.iter().enumerate() {
                slots[k] = slots[f as usize];
            }
        }
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        ctx.check_storage_binding(
            "the BVH nodes",
            std::mem::size_of_val(nodes.as_slice()) as u64,
        )?;
        ctx.check_storage_binding(
            "the triangles",
            std::mem::size_of_val(tris.as_slice()) as u64,
        )?;
        let device = ctx.device();
        let (nodes_buf, tris_buf, ids_buf, pipelines) = ctx.scoped(
            "uploading the scene and building the trace pipelines",
            || {
                (
                    upload(
                        ctx,
                        "bvh nodes",
                        bytemuck::cast_slice(&nodes),
                        wgpu::BufferUsages::STORAGE,
                    ),
                    upload(
                        ctx,
                        "triangles",
                        bytemuck::cast_slice(&tris),
                        wgpu::BufferUsages::STORAGE,
                    ),
                    upload(
                        ctx,
                        "triangle ids",
                        bytemuck::cast_slice(&bvh.primitive_indices),
                        wgpu::BufferUsages::STORAGE,
                    ),
                    SHADER.pipelines_of(device, &SHADER.entry_points[..7]),
                )
            },
        )?;
        // `closest_hit`, `any_hit`, `direct_light`, `closest_hit_polar`,
        // `closest_hit_screen`, `environment_light`, `mix64_check`: the order of the module's
        // entry points.
        let mut pipelines = pipelines.into_iter();
        let (
            Some(closest),
            Some(any),
            Some(direct),
            Some(polar),
            Some(screen),
            Some(environment),
            Some(hash),
        ) = (
            pipelines.next(),
            pipelines.next(),
            pipelines.next(),
            pipelines.next(),
            pipelines.next(),
            pipelines.next(),
            pipelines.next(),
        )
        else {
            return Err(GpuError::Input(
                "the trace module lacks one of its seven entry points (closest_hit, any_hit, \
                 direct_light, closest_hit_polar, closest_hit_screen, environment_light, \
                 mix64_check)"
                    .into(),
            ));
        };
        let scene = SceneBuffers {
            nodes: nodes_buf,
            tris: tris_buf,
            prim_ids: ids_buf,
            closest,
            any,
            direct,
            polar,
            screen,
            environment,
        };
        Ok(Self {
            ctx: ctx.clone(),
            stats: BvhStats {
                triangles: triangles.len(),
                nodes: nodes.len(),
                depth,
                build_ms,
            },
            scene: Some(scene),
            mix64: hash.into(),
            polar_probe: std::sync::OnceLock::new(),
            slots,
        })
    }

    /// What was built.
    pub fn stats(&self) -> BvhStats {
        self.stats
    }

    /// The closest hit of every ray (`None`: a miss). Rays with a non-finite component or
    /// an empty interval miss without reaching the shader.
    pub fn closest_hits(&self, rays: &[GpuRay]) -> Result<Vec<Option<GpuHit>>> {
        Ok(self.closest_hits_timed(rays)?.0)
    }

    /// [`closest_hits`](Self::closest_hits), and where its time went: the compute passes'
    /// own time from timestamps, as the reconstructor reports its pass.
    pub fn closest_hits_timed(&self, rays: &[GpuRay]) -> Result<(Vec<Option<GpuHit>>, TraceTimes)> {
        let (raw, times) = self.run_timed(rays, false)?;
        let hits = raw
            .iter()
            .map(|h| {
                (h.prim != MISS).then_some(GpuHit {
                    t: h.t,
                    tri: h.prim,
                    bary: [h.u, h.v],
                })
            })
            .collect();
        Ok((hits, times))
    }

    /// Whether anything lies on each ray within its interval (shadow rays; `t_max` may be
    /// infinite).
    pub fn occluded(&self, rays: &[GpuRay]) -> Result<Vec<bool>> {
        Ok(self.occluded_timed(rays)?.0)
    }

    /// [`occluded`](Self::occluded), and where its time went (as
    /// [`closest_hits_timed`](Self::closest_hits_timed)).
    pub fn occluded_timed(&self, rays: &[GpuRay]) -> Result<(Vec<bool>, TraceTimes)> {
        let (raw, times) = self.run_timed(rays, true)?;
        Ok((raw.iter().map(|h| h.prim != MISS).collect(), times))
    }

    /// Runs `pass` through `pipeline` (an entry point of the trace module) with the scene's
    /// nodes, triangles and ids at bindings 1–3: the output (4-byte words) and the pass's
    /// milliseconds from timestamps.
    pub(crate) fn run_scene_pass(
        &self,
        scene: &SceneBuffers,
        pipeline: &wgpu::ComputePipeline,
        pass: ScenePass<'_>,
    ) -> Result<(Vec<u32>, Option<f64>)> {
        let ctx = &self.ctx;
        let (uniform, inputs) = ctx.scoped(pass.what, || {
            let uniform = upload(
                ctx,
                "trace parameters",
                bytemuck::bytes_of(&pass.block),
                wgpu::BufferUsages::UNIFORM,
            );
            let inputs: Vec<(u32, wgpu::Buffer)> = pass
                .inputs
                .iter()
                .map(|&(binding, bytes, usage)| (binding, upload(ctx, pass.what, bytes, usage)))
                .collect();
            (uniform, inputs)
        })?;
        let mut bindings = vec![
            (0, uniform.as_entire_binding()),
            (1, scene.nodes.as_entire_binding()),
            (2, scene.tris.as_entire_binding()),
            (3, scene.prim_ids.as_entire_binding()),
        ];
        bindings.extend(inputs.iter().map(|(b, buf)| (*b, buf.as_entire_binding())));
        bindings.extend(
            pass.resident
                .iter()
                .map(|(b, buf)| (*b, buf.as_entire_binding())),
        );
        run_1d_at(
            ctx,
            pass.what,
            pipeline,
            &bindings,
            8,
            pass.items as u64,
            pass.out_bytes,
            true,
        )
    }

    /// [`run`](Self::run) with its batches timed, and its wall time.
    fn run_timed(&self, rays: &[GpuRay], any_hit: bool) -> Result<(Vec<HitGpu>, TraceTimes)> {
        let t = std::time::Instant::now();
        let mut times = TraceTimes::default();
        let raw = self.run(rays, any_hit, &mut times)?;
        times.total_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((raw, times))
    }

    /// Runs `rays` in batches that fit the device's bindings and dispatch limits; each
    /// batch's pass is timed and counted in `times`.
    fn run(&self, rays: &[GpuRay], any_hit: bool, times: &mut TraceTimes) -> Result<Vec<HitGpu>> {
        let miss = HitGpu {
            t: 0.0,
            prim: MISS,
            u: 0.0,
            v: 0.0,
        };
        let Some(scene) = &self.scene else {
            return Ok(vec![miss; rays.len()]);
        };
        let batch = batch_len(&self.ctx, RAY_BYTES.max(HIT_BYTES));
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(batch) {
            // Rays the shader must not see (non-finite, empty interval) miss here.
            let valid: Vec<bool> = chunk.iter().map(ray_is_valid).collect();
            let input: Vec<GpuRay> = chunk
                .iter()
                .zip(&valid)
                .map(|(r, &ok)| {
                    if ok {
                        // WGSL may assume no infinities: +∞ becomes a distance no scene reaches.
                        GpuRay {
                            t_max: r.t_max.min(MAX_DISTANCE),
                            ..*r
                        }
                    } else {
                        GpuRay {
                            origin: [0.0; 3],
                            t_min: 1.0,
                            dir: [0.0, 0.0, 1.0],
                            t_max: 0.0,
                        }
                    }
                })
                .collect();
            let (hits, ms) = self.run_batch(scene, &input, any_hit)?;
            times.add_batch(ms);
            out.extend(
                hits.into_iter()
                    .zip(valid)
                    .map(|(h, ok)| if ok { h } else { miss }),
            );
        }
        Ok(out)
    }

    /// One batch, and its pass's milliseconds from timestamps (when the device has them).
    fn run_batch(
        &self,
        scene: &SceneBuffers,
        rays: &[GpuRay],
        any_hit: bool,
    ) -> Result<(Vec<HitGpu>, Option<f64>)> {
        if rays.is_empty() {
            return Ok((Vec::new(), None));
        }
        let n = rays.len() as u64;
        let what = format!(
            "tracing {} {} rays",
            rays.len(),
            if any_hit { "shadow" } else { "closest-hit" }
        );
        self.ctx.check_storage_binding(&what, n * RAY_BYTES)?;
        let pipeline = if any_hit { &scene.any } else { &scene.closest };
        let block = TraceUniform::new(rays.len(), 0, DirectLightModel::zeroed());
        let (uniform, ray_buf) = self.ctx.scoped(&what, || {
            (
                upload(
                    &self.ctx,
                    "trace parameters",
                    bytemuck::bytes_of(&block),
                    wgpu::BufferUsages::UNIFORM,
                ),
                upload(
                    &self.ctx,
                    "rays",
                    bytemuck::cast_slice(rays),
                    wgpu::BufferUsages::STORAGE,
                ),
            )
        })?;
        let (raw, ms) = run_1d(
            &self.ctx,
            &what,
            pipeline,
            &[
                uniform.as_entire_binding(),
                scene.nodes.as_entire_binding(),
                scene.tris.as_entire_binding(),
                scene.prim_ids.as_entire_binding(),
                ray_buf.as_entire_binding(),
            ],
            n,
            HIT_BYTES,
            true,
        )?;
        Ok((bytemuck::cast_slice::<u32, HitGpu>(&raw).to_vec(), ms))
    }
}

/// A ray the shader may see: finite components and a non-empty interval (`t_max` may be
/// +∞ on the caller's side; it is clamped to the shader's largest distance).
fn ray_is_valid(r: &GpuRay) -> bool {
    r.origin.iter().chain(&r.dir).all(|c| c.is_finite())
        && r.dir.iter().any(|&c| c != 0.0)
        && r.t_min.is_finite()
        && !r.t_max.is_nan()
        && r.t_min <= r.t_max
}

fn node_gpu(n: &Bvh2Node) -> NodeGpu {
    NodeGpu {
        min: n.aabb.min.into(),
        prim_count: n.prim_count,
        max: n.aabb.max.into(),
        first_index: n.first_index,
    }
}

/// The depth of the tree rooted at `nodes[0]` (a lone leaf is 1), without recursion.
fn tree_depth(nodes: &[Bvh2Node]) -> usize {
    let mut deepest = 0;
    let mut todo = vec![(0usize, 1usize)];
    while let Some((i, d)) = todo.pop() {
        deepest = deepest.max(d);
        let n = &nodes[i];
        if n.prim_count == 0 {
            let a = n.first_index as usize;
            todo.push((a, d + 1));
            todo.push((a + 1, d + 1));
        }
    }
    deepest
}

/// Refuses a tree the shader's stack cannot walk: at most one entry per level is pushed, so
/// a depth up to `STACK_SIZE + 1` fits.
fn check_depth(depth: usize) -> Result<()> {
    if depth > STACK_SIZE + 1 {
        return Err(GpuError::Input(format!(
            "the BVH is {depth} levels deep; the GPU traversal's stack holds {STACK_SIZE} \
             (use --backend cpu for this scene)"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::aabb::Aabb;

    fn leaf(first: u32) -> Bvh2Node {
        Bvh2Node {
            aabb: Aabb::empty(),
            prim_count: 1,
            first_index: first,
            ..Default::default()
        }
    }

    fn inner(first: u32) -> Bvh2Node {
        Bvh2Node {
            aabb: Aabb::empty(),
            prim_count: 0,
            first_index: first,
            ..Default::default()
        }
    }

    /// A chain: every inner node has a leaf and another inner node as children.
    fn chain(levels: usize) -> Vec<Bvh2Node> {
        let mut nodes = vec![inner(1)];
        for k in 0..levels - 2 {
            let next = nodes.len() as u32 + 2;
            nodes.push(leaf(k as u32));
            nodes.push(inner(next));
        }
        nodes.push(leaf(0));
        nodes.push(leaf(1));
        nodes
    }

    #[test]
    fn depth_is_counted_and_checked_against_the_stack() {
        assert_eq!(tree_depth(&[leaf(0)]), 1);
        assert_eq!(tree_depth(&[inner(1), leaf(0), leaf(1)]), 2);
        assert_eq!(tree_depth(&chain(10)), 10);
        assert!(check_depth(tree_depth(&chain(STACK_SIZE + 1))).is_ok());
        let err = check_depth(tree_depth(&chain(STACK_SIZE + 2))).unwrap_err();
        assert!(err.to_string().contains("levels deep"), "{err}");
    }

    #[test]
    fn invalid_rays_are_recognised() {
        let ok = GpuRay {
            origin: [0.0; 3],
            t_min: 0.0,
            dir: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        assert!(ray_is_valid(&ok));
        for bad in [
            GpuRay {
                origin: [f32::NAN, 0.0, 0.0],
                ..ok
            },
            GpuRay {
                dir: [0.0; 3],
                ..ok
            },
            GpuRay {
                t_min: 2.0,
                t_max: 1.0,
                ..ok
            },
            GpuRay {
                t_max: f32::NAN,
                ..ok
            },
        ] {
            assert!(!ray_is_valid(&bad), "{bad:?}");
        }
    }
}
