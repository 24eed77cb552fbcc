//! Materials (metallic-roughness) and their textures: every glTF material becomes the scene
//! material of the same index (factors clamped, `KHR_materials_emissive_strength` applied);
//! texture references become requests, one per `(image, sRGB?)`, decoded in parallel and
//! assigned to the material slots; an emissive texture is replaced by its mean colour.

use std::borrow::Cow;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::images::{decode_texture, image_source};
use super::{Loader, Msg};
use crate::scene::{Material, MaterialId, Texture, TextureId};

/// `KHR_materials_emissive_strength` per material (1 where absent), read from the raw JSON
/// because the `gltf` crate is built without that extension.
pub(super) fn read_emissive_strengths(json_bytes: &[u8]) -> Vec<f32> {
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(json_bytes) else {
        return Vec::new();
    };
    let Some(materials) = v.get("materials").and_then(|m| m.as_array()) else {
        return Vec::new();
    };
    materials
        .iter()
        .map(|m| {
            m.pointer("/extensions/KHR_materials_emissive_strength/emissiveStrength")
                .and_then(|s| s.as_f64())
                .map(|s| s as f32)
                .filter(|s| s.is_finite() && *s >= 0.0)
                .unwrap_or(1.0)
        })
        .collect()
}

/// An image to decode: name, encoded bytes (or why there are none), sRGB?
type ImageSource<'b> = (String, Msg<Cow<'b, [u8]>>, bool);

/// Which material slot a texture request feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Slot {
    BaseColor,
    MetallicRoughness,
    Normal,
    Emissive,
}

impl Loader<'_> {
    /// Records that `slot` of `material` uses `tex`: one request per distinct image and colour
    /// space. A texture on another set than `TEXCOORD_0` is dropped with a warning.
    fn request(&mut self, material: usize, slot: Slot, info_tex_coord: u32, tex: ::gltf::Texture) {
        let image = tex.source().index();
        if info_tex_coord != 0 {
            let name = self.scene.materials[material].name.clone();
            self.scene.warnings.push(format!(
                "material `{name}`: {slot:?} texture uses TEXCOORD_{info_tex_coord}; only \
                 TEXCOORD_0 is read, texture ignored"
            ));
            return;
        }
        let srgb = matches!(slot, Slot::BaseColor | Slot::Emissive);
        let next = self.requests.len();
        let r = *self.request_of.entry((image, srgb)).or_insert(next);
        if r == next {
            self.requests.push((image, srgb));
        }
        self.slots.push((material, slot, r));
    }

    /// Converts every glTF material (same indices) and records its texture requests.
    pub(super) fn read_materials(&mut self, emissive_strength: &[f32]) {
        let doc = self.doc;
        for (i, m) in doc.materials().enumerate() {
            let pbr = m.pbr_metallic_roughness();
            let [r, g, b, _alpha] = pbr.base_color_factor();
            let unit = |x: f32, default: f32| {
                if x.is_finite() {
                    x.clamp(0.0, 1.0)
                } else {
                    default
                }
            };
            let strength = emissive_strength.get(i).copied().unwrap_or(1.0);
            let emissive = Vec3::from(m.emissive_factor()) * strength;
            let normal = m.normal_texture();
            self.scene.materials.push(Material {
                name: m
                    .name()
                    .map(str::to_owned)
                    .unwrap_or_else(|| format!("material {i}")),
                base_color: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
                base_color_texture: None,
                metallic: unit(pbr.metallic_factor(), 1.0),
                roughness: unit(pbr.roughness_factor(), 1.0),
                metallic_roughness_texture: None,
                normal_texture: None,
                normal_scale: normal
                    .as_ref()
                    .map(|n| n.scale())
                    .filter(|s| s.is_finite())
                    .unwrap_or(1.0),
                specular: Vec3::splat(0.04),
                emissive: if emissive.is_finite() {
                    emissive.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                },
                two_sided: m.double_sided(),
            });
            if let Some(t) = pbr.base_color_texture() {
                self.request(i, Slot::BaseColor, t.tex_coord(), t.texture());
            }
            if let Some(t) = pbr.metallic_roughness_texture() {
                self.request(i, Slot::MetallicRoughness, t.tex_coord(), t.texture());
            }
            if let Some(n) = normal {
                self.request(i, Slot::Normal, n.tex_coord(), n.texture());
            }
            if let Some(t) = m.emissive_texture() {
                if self.scene.materials[i].emissive != Vec3::ZERO {
                    self.request(i, Slot::Emissive, t.tex_coord(), t.texture());
                }
            }
        }
    }

    /// The id of the shared default material, appended on first use.
    pub(super) fn default_material(&mut self) -> MaterialId {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(Material::default());
            (self.scene.materials.len() - 1) as MaterialId
        })
    }

    /// Decodes the requested images in parallel and fills the material slots.
    pub(super) fn decode_textures(&mut self) {
        let doc = self.doc;
        let images: Vec<::gltf::Image> = doc.images().collect();
        // Resolve the sources serially (cheap), decode in parallel.
        let sources: Vec<ImageSource> = self
            .requests
            .iter()
            .map(|&(i, srgb)| {
                let (name, bytes) = image_source(self.files, &images[i], self.base, self.buffers);
                (name, bytes, srgb)
            })
            .collect();
        let decoded: Vec<(String, Msg<Texture>)> = sources
            .into_par_iter()
            .map(|(name, bytes, srgb)| {
                let tex = bytes.and_then(|b| decode_texture(&name, &b, srgb));
                (name, tex)
            })
            .collect();
        let mut ids: Vec<Option<TextureId>> = vec![None; decoded.len()];
        let mut means: Vec<Option<Vec3>> = vec![None; decoded.len()];
        for (r, (name, tex)) in decoded.into_iter().enumerate() {
            match tex {
                Ok(tex) => {
                    let as_map = self.slots.iter().any(|s| s.2 == r && s.1 != Slot::Emissive);
                    if self.slots.iter().any(|s| s.2 == r && s.1 == Slot::Emissive) {
                        means[r] = Some(tex.sample(Vec2::ZERO, f32::MAX).truncate());
                    }
                    if as_map {
                        ids[r] = Some(self.scene.textures.len() as TextureId);
                        self.scene.textures.push(tex);
                    }
                }
                Err(e) => self
                    .scene
                    .warnings
                    .push(format!("missing texture `{name}` ({e}), using flat colour")),
            }
        }
        for &(m, slot, r) in &self.slots {
            let mat = &mut self.scene.materials[m];
            match slot {
                Slot::BaseColor => mat.base_color_texture = ids[r],
                Slot::MetallicRoughness => mat.metallic_roughness_texture = ids[r],
                Slot::Normal => mat.normal_texture = ids[r],
                Slot::Emissive => {
                    if let Some(mean) = means[r] {
                        mat.emissive *= mean;
                        self.scene.warnings.push(format!(
                            "material `{}`: emissive texture replaced by its mean colour",
                            mat.name
                        ));
                    }
                }
            }
        }
    }
}
