//! The node graph: the scene's root nodes, walked depth-first in document order with their
//! transforms (matrix or TRS) composed, cycles and runaway instancing refused before anything
//! is baked; each node's mesh instances (baked into world space), `KHR_lights_punctual`
//! light and perspective camera.

use glam::{Mat4, Quat, Vec3};

use super::Loader;
use crate::error::{RenderError, Result};
use crate::scene::{CameraDesc, Light};

/// Most node visits while walking the scene graph (guards against exponential instancing).
const MAX_NODE_VISITS: usize = 1 << 20;
/// Most triangles after instancing.
const MAX_TRIANGLES: usize = 1 << 27;

/// The local transform of a node (TRS with the rotation normalised; a zero quaternion is the
/// identity rotation).
fn local_transform(node: &::gltf::Node) -> Mat4 {
    match node.transform() {
        ::gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
        ::gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let q = Quat::from_array(rotation);
            let q = if q.length_squared() > 0.0 && q.is_finite() {
                q.normalize()
            } else {
                Quat::IDENTITY
            };
            Mat4::from_scale_rotation_translation(Vec3::from(scale), q, Vec3::from(translation))
        }
    }
}

/// A node on a cycle of the child links, when some node cannot be reached from `roots` (in a
/// file without scenes, the nodes that are nobody's child); `None` when every node can. An
/// unreachable node has a parent (else it would be a root) and so has each of its ancestors,
/// none of them reachable either: following parent links from it must repeat a node, and the
/// first repeated node lies on a cycle. Linear in the number of nodes and links.
fn unrooted_cycle(doc: &::gltf::Document, roots: &[usize]) -> Option<usize> {
    let n = doc.nodes().len();
    let children: Vec<Vec<usize>> = doc
        .nodes()
        .map(|node| node.children().map(|c| c.index()).collect())
        .collect();
    let mut reached = vec![false; n];
    let mut stack: Vec<usize> = roots.to_vec();
    while let Some(i) = stack.pop() {
        if !std::mem::replace(&mut reached[i], true) {
            stack.extend(children[i].iter().copied().filter(|&c| !reached[c]));
        }
    }
    let start = reached.iter().position(|&r| !r)?;
    let mut parent = vec![usize::MAX; n];
    for (p, cs) in children.iter().enumerate() {
        for &c in cs {
            parent[c] = p;
        }
    }
    let mut seen = vec![false; n];
    let mut i = start;
    while !std::mem::replace(&mut seen[i], true) {
        i = parent[i];
        if i == usize::MAX {
            // Not reachable yet without a parent: cannot happen when `roots` are the nodes
            // without one; reported at the node where the walk stopped.
            return Some(start);
        }
    }
    Some(i)
}

impl Loader<'_> {
    /// Walks the chosen scene's node trees depth-first (iteratively, with cycle detection):
    /// a counting pass, then the pass that bakes meshes, lights and cameras.
    pub(super) fn walk_nodes(&mut self) -> Result<()> {
        let doc = self.doc;
        let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                let roots: Vec<usize> = (0..is_child.len()).filter(|&i| !is_child[i]).collect();
                // Without a scene the roots are the nodes nobody lists as a child; nodes that
                // cannot be reached from them hang on a cycle (their walk would find nothing).
                if let Some(i) = unrooted_cycle(doc, &roots) {
                    return Err(RenderError::bad(
                        self.path,
                        format!(
                            "the node hierarchy has a cycle through node {i} (the file has no \
                             scene, and the nodes of the cycle have no root node)"
                        ),
                    ));
                }
                roots
            }
        };
        let nodes: Vec<::gltf::Node> = doc.nodes().collect();
        // First pass: only count (cycle and instancing checks before any mesh is baked).
        for bake in [false, true] {
            let mut stack: Vec<(usize, Mat4, usize)> = roots
                .iter()
                .rev()
                .map(|&n| (n, Mat4::IDENTITY, 0))
                .collect();
            // The path from the root to the node being visited, and a flag per node for
            // "on that path": the cycle test is O(1), so a chain of n nodes walks in O(n)
            // (a search of the path made a 1M-deep chain quadratic). Each node's world
            // transform is its parent's (carried on the stack) times its local one.
            let mut ancestors: Vec<usize> = Vec::new();
            let mut on_path = vec![false; nodes.len()];
            let mut visits = 0usize;
            while let Some((index, parent, depth)) = stack.pop() {
                for a in ancestors.drain(depth.min(ancestors.len())..) {
                    on_path[a] = false;
                }
                if on_path[index] {
                    return Err(RenderError::bad(
                        self.path,
                        format!("the node hierarchy has a cycle through node {index}"),
                    ));
                }
                visits += 1;
                if visits > MAX_NODE_VISITS {
                    return Err(RenderError::ResourceLimit {
                        what: format!("scene graph of {}", self.path.display()),
                        needed: format!("more than {MAX_NODE_VISITS} node instances"),
                        limit: format!("{MAX_NODE_VISITS}"),
                    });
                }
                ancestors.push(index);
                on_path[index] = true;
                let node = &nodes[index];
                let world = if bake {
                    let world = parent * local_transform(node);
                    self.visit(node, world)?;
                    world
                } else {
                    parent
                };
                for child in node.children().collect::<Vec<_>>().into_iter().rev() {
                    stack.push((child.index(), world, depth + 1));
                }
            }
        }
        Ok(())
    }

    /// Adds a node's mesh, light and camera.
    fn visit(&mut self, node: &::gltf::Node, world: Mat4) -> Result<()> {
        let node_name = node
            .name()
            .map(str::to_owned)
            .unwrap_or_else(|| format!("node {}", node.index()));
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let key = (mesh.index(), prim.index());
                if !self.primitive_cache.contains_key(&key) {
                    let local = self.read_primitive(&mesh, &prim)?;
                    self.primitive_cache.insert(key, local);
                }
                let Some(Some(local)) = self.primitive_cache.get(&key) else {
                    continue;
                };
                let total = self.triangles + local.indices.len();
                if total > MAX_TRIANGLES {
                    return Err(RenderError::ResourceLimit {
                        what: format!("triangles of {}", self.path.display()),
                        needed: format!("more than {total}"),
                        limit: format!("{MAX_TRIANGLES}"),
                    });
                }
                self.triangles = total;
                let mut m = local.clone();
                m.transform(world);
                self.scene.meshes.push(m);
            }
        }
        if let Some(light) = node.light() {
            self.add_light(&light, world, &node_name);
        }
        if let Some(camera) = node.camera() {
            self.add_camera(&camera, world, &node_name);
        }
        Ok(())
    }

    fn add_light(&mut self, light: &::gltf::khr_lights_punctual::Light, world: Mat4, node: &str) {
        use ::gltf::khr_lights_punctual::Kind;
        let power = Vec3::from(light.color()) * light.intensity();
        let range = light
            .range()
            .filter(|r| r.is_finite() && *r > 0.0)
            .unwrap_or(f32::INFINITY);
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let needs_direction = !matches!(light.kind(), Kind::Point);
        if !position.is_finite() || (needs_direction && direction == Vec3::ZERO) {
            self.scene.warnings.push(format!(
                "light on node `{node}` has a degenerate transform, skipped"
            ));
            return;
        }
        self.scene.lights.push(match light.kind() {
            Kind::Point => Light::Point {
                position,
                intensity: power,
                range,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let cos_outer = outer_cone_angle.cos();
                Light::Spot {
                    position,
                    direction,
                    intensity: power,
                    cos_inner: inner_cone_angle.cos().max(cos_outer),
                    cos_outer,
                    range,
                }
            }
            Kind::Directional => Light::Directional {
                direction,
                irradiance: power,
            },
        });
    }

    fn add_camera(&mut self, camera: &::gltf::Camera, world: Mat4, node: &str) {
        let ::gltf::camera::Projection::Perspective(p) = camera.projection() else {
            self.scene.warnings.push(format!(
                "orthographic camera on node `{node}` skipped (only perspective cameras are read)"
            ));
            return;
        };
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(Vec3::Y);
        let up = (up - forward * up.dot(forward)).normalize_or_zero();
        if !position.is_finite() || forward == Vec3::ZERO || up == Vec3::ZERO {
            self.scene.warnings.push(format!(
                "camera on node `{node}` has a degenerate transform, skipped"
            ));
            return;
        }
        let yfov = p.yfov().to_degrees();
        let yfov_deg = (yfov.is_finite() && yfov > 0.0 && yfov < 180.0).then_some(yfov);
        let name = camera.name().unwrap_or(node).to_owned();
        if yfov_deg.is_none() {
            self.scene.warnings.push(format!(
                "{}: camera `{name}`: yfov = {} rad is outside (0°, 180°), ignored (the \
                 display's field of view is used)",
                self.path.display(),
                p.yfov()
            ));
        }
        self.scene.cameras.push(CameraDesc {
            name,
            position,
            forward,
            up,
            yfov_deg,
        });
    }
}
