//! BSDFs → [`Material`]s (the mapping is listed in the module docs of the loader, "Mapping"):
//! `twosided`, `diffuse`, `plastic`, `conductor` (F0 from the complex IOR, or from a table of
//! measured values after Hoffman, "Physics and Math of Shading"), `dielectric` (an opaque
//! glossy approximation), `phong`, `ward`, `principled`, the wrappers that keep their nested
//! BSDF (`normalmap` adds its texture), and `null` (invisible shape). Each `<bsdf>` element
//! becomes one material, built once.

use glam::Vec3;

use super::tree::XNode;
use super::values::{req_attr, Color};
use super::{bad, Loader, MAX_DEPTH};
use crate::error::Result;
use crate::scene::{Material, MaterialId};

/// Roughness of the smooth (`plastic`, `conductor`, `dielectric`) BSDFs and lower bound of
/// the rough ones: sharper GGX lobes only alias under point lights.
const MIN_ROUGHNESS: f32 = 0.05;

/// A texture a material waits for: slot, request index.
#[derive(Clone, Copy, Debug)]
pub(super) enum Slot {
    BaseColor,
    Normal,
}

/// A material being built: the material, the textures it waits for, and whether the BSDF is
/// `null` (the shape is skipped).
#[derive(Clone, Debug)]
pub(super) struct MatBuild {
    pub(super) mat: Material,
    pub(super) tex: Vec<(Slot, usize)>,
    pub(super) invisible: bool,
}

/// Linear F0 of common conductors (Hoffman, "Physics and Math of Shading", sRGB primaries).
fn conductor_f0(name: &str) -> Option<Vec3> {
    let n = name.trim().to_ascii_lowercase();
    let n = n.strip_prefix("a-").unwrap_or(&n);
    Some(match n {
        "al" | "aluminium" | "aluminum" => Vec3::new(0.913, 0.922, 0.924),
        "ag" | "silver" => Vec3::new(0.972, 0.960, 0.915),
        "au" | "gold" => Vec3::new(1.000, 0.766, 0.336),
        "cu" | "copper" | "cu2o" | "cuo" => Vec3::new(0.955, 0.638, 0.538),
        "cr" | "chromium" => Vec3::new(0.550, 0.556, 0.554),
        "fe" | "iron" => Vec3::new(0.562, 0.565, 0.578),
        "ni" | "nickel" => Vec3::new(0.660, 0.609, 0.526),
        "ti" | "titanium" => Vec3::new(0.542, 0.497, 0.449),
        "pt" | "platinum" => Vec3::new(0.673, 0.637, 0.585),
        "w" | "tungsten" => Vec3::new(0.504, 0.498, 0.478),
        "hg" | "mercury" => Vec3::new(0.781, 0.779, 0.779),
        "none" => Vec3::ONE,
        _ => return None,
    })
}

/// Index of refraction by Mitsuba's names.
fn ior_by_name(name: &str) -> Option<f32> {
    Some(match name.trim().to_ascii_lowercase().as_str() {
        "vacuum" => 1.0,
        "helium" => 1.000_036,
        "hydrogen" => 1.000_132,
        "air" => 1.000_277,
        "carbon dioxide" => 1.000_45,
        "water" => 1.333,
        "acetone" => 1.36,
        "ethanol" => 1.361,
        "carbon tetrachloride" => 1.461,
        "glycerol" => 1.4729,
        "benzene" => 1.501,
        "silicone oil" => 1.52045,
        "bromine" => 1.661,
        "water ice" => 1.31,
        "fused quartz" => 1.458,
        "pyrex" => 1.470,
        "acrylic glass" => 1.49,
        "polypropylene" => 1.49,
        "bk7" => 1.5046,
        "sodium chloride" => 1.544,
        "amber" => 1.55,
        "pet" => 1.5750,
        "diamond" => 2.419,
        _ => return None,
    })
}

impl<'t> Loader<'t> {
    fn ior(&mut self, node: &'t XNode, names: &[&str], default: f32) -> Result<f32> {
        if let Some(s) = node.param(&["string"], names) {
            let v = req_attr(s, "value")?;
            return Ok(match ior_by_name(v) {
                Some(x) => x,
                None => {
                    self.warn(format!("{}: unknown IOR name `{v}`, using 1.5", s.at()));
                    1.5
                }
            });
        }
        let v = self.float_param(node, names, default)?;
        Ok(if v.is_finite() && v > 0.0 { v } else { default })
    }

    fn alpha_roughness(&mut self, node: &'t XNode, default_alpha: f32) -> Result<f32> {
        let alpha = if node.children.iter().any(|c| c.named(&["alpha"])) {
            self.float_param(node, &["alpha"], default_alpha)?
        } else if node.children.iter().any(|c| c.named(&["alphaU", "alphaV"])) {
            let u = self.float_param(node, &["alphaU"], default_alpha)?;
            let v = self.float_param(node, &["alphaV"], default_alpha)?;
            0.5 * (u + v)
        } else {
            default_alpha
        };
        Ok(alpha.max(0.0).sqrt().clamp(MIN_ROUGHNESS, 1.0))
    }

    /// The first BSDF nested in `node` (inline or by reference).
    fn inner_bsdf(&self, node: &'t XNode) -> Result<Option<&'t XNode>> {
        for c in &node.children {
            if c.tag == "bsdf" {
                return Ok(Some(c));
            }
            if c.tag == "ref" {
                let t = self.lookup(c)?;
                if t.tag == "bsdf" {
                    return Ok(Some(t));
                }
            }
        }
        Ok(None)
    }

    /// Builds the material of a `<bsdf>` element (not registered).
    fn build_bsdf(&mut self, node: &'t XNode, depth: u32) -> Result<MatBuild> {
        if depth > MAX_DEPTH {
            return Err(bad(
                &node.file,
                format!(
                    "line {}: BSDF nesting too deep (reference cycle?)",
                    node.line
                ),
            ));
        }
        let name = node
            .attr("id")
            .map(str::to_string)
            .unwrap_or_else(|| format!("{} ({})", node.ty(), node.at()));
        let mut b = MatBuild {
            mat: Material {
                name: name.clone(),
                two_sided: false,
                ..Material::default()
            },
            tex: Vec::new(),
            invisible: false,
        };
        let ty = node.ty().to_string();
        let set_base = |b: &mut MatBuild, c: Color| match c {
            Color::Const(v) => b.mat.base_color = v,
            Color::Texture(i) => {
                b.mat.base_color = Vec3::ONE;
                b.tex.push((Slot::BaseColor, i));
            }
        };
        match ty.as_str() {
            "twosided" => {
                let mut inner = match self.inner_bsdf(node)? {
                    Some(i) => self.build_bsdf(i, depth + 1)?,
                    None => {
                        self.warn(format!("{}: empty twosided BSDF, using diffuse", node.at()));
                        MatBuild {
                            mat: Material::diffuse(name.clone(), Vec3::splat(0.5)),
                            tex: Vec::new(),
                            invisible: false,
                        }
                    }
                };
                inner.mat.two_sided = true;
                if node.attr("id").is_some() {
                    inner.mat.name = name;
                }
                return Ok(inner);
            }
            "diffuse" | "roughdiffuse" | "difftrans" => {
                let names: &[&str] = if ty == "difftrans" {
                    &["transmittance"]
                } else {
                    &["reflectance"]
                };
                let c = self.color_param(node, names, Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.roughness = 1.0;
                b.mat.specular = Vec3::ZERO;
                if ty == "difftrans" {
                    self.warn(format!("{}: difftrans approximated by diffuse", node.at()));
                }
            }
            "plastic" | "roughplastic" => {
                let c = self.color_param(node, &["diffuseReflectance"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                let int = self.ior(node, &["intIOR"], 1.49)?;
                let ext = self.ior(node, &["extIOR"], 1.000_277)?;
                let f0 = ((int - ext) / (int + ext)).powi(2);
                let ks = self.const_param(node, &["specularReflectance"], Vec3::ONE)?;
                b.mat.specular = (ks * f0).clamp(Vec3::ZERO, Vec3::ONE);
                b.mat.roughness = if ty == "plastic" {
                    MIN_ROUGHNESS
                } else {
                    self.alpha_roughness(node, 0.1)?
                };
            }
            "conductor" | "roughconductor" => {
                b.mat.metallic = 1.0;
                let has = |n: &str| node.children.iter().any(|c| c.named(&[n]));
                let mut f0 = if has("eta") && has("k") {
                    let eta = self.const_param(node, &["eta"], Vec3::ONE)?;
                    let k = self.const_param(node, &["k"], Vec3::ZERO)?;
                    let num = (eta - Vec3::ONE) * (eta - Vec3::ONE) + k * k;
                    let den = (eta + Vec3::ONE) * (eta + Vec3::ONE) + k * k;
                    (num / den.max(Vec3::splat(1e-6))).clamp(Vec3::ZERO, Vec3::ONE)
                } else if let Some(m) = Self::string_param(node, &["material"]) {
                    match conductor_f0(&m) {
                        Some(v) => v,
                        None => {
                            self.warn(format!(
                                "{}: conductor `{m}` not in the table, using grey 0.9",
                                node.at()
                            ));
                            Vec3::splat(0.9)
                        }
                    }
                } else {
                    Vec3::splat(0.9)
                };
                match self.color_param(node, &["specularReflectance"], Vec3::ONE)? {
                    Color::Const(v) => f0 *= v,
                    Color::Texture(i) => b.tex.push((Slot::BaseColor, i)),
                }
                b.mat.base_color = f0;
                b.mat.roughness = if ty == "conductor" {
                    MIN_ROUGHNESS
                } else {
                    self.alpha_roughness(node, 0.1)?
                };
            }
            "dielectric" | "roughdielectric" | "thindielectric" => {
                let int = self.ior(node, &["intIOR"], 1.5046)?;
                let ext = self.ior(node, &["extIOR"], 1.000_277)?;
                b.mat.base_color = Vec3::splat(0.9);
                b.mat.specular = Vec3::splat(((int - ext) / (int + ext)).powi(2));
                b.mat.roughness = if ty == "roughdielectric" {
                    self.alpha_roughness(node, 0.1)?
                } else {
                    MIN_ROUGHNESS
                };
                b.mat.two_sided = true;
                self.warn(format!(
                    "{}: {ty} `{name}` approximated as an opaque glossy white surface (no transmission)",
                    node.at()
                ));
            }
            "phong" => {
                let c = self.color_param(node, &["diffuseReflectance"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.specular = self
                    .const_param(node, &["specularReflectance"], Vec3::splat(0.2))?
                    .clamp(Vec3::ZERO, Vec3::ONE);
                let e = self.float_param(node, &["exponent"], 30.0)?;
                b.mat.roughness = Material::roughness_from_phong(e);
            }
            "ward" => {
                let c = self.color_param(node, &["diffuseReflectance"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.specular = self
                    .const_param(node, &["specularReflectance"], Vec3::splat(0.2))?
                    .clamp(Vec3::ZERO, Vec3::ONE);
                b.mat.roughness = self.alpha_roughness(node, 0.1)?;
            }
            "principled" => {
                let c = self.color_param(node, &["base_color"], Vec3::splat(0.5))?;
                set_base(&mut b, c);
                b.mat.metallic = self.float_param(node, &["metallic"], 0.0)?.clamp(0.0, 1.0);
                b.mat.roughness = self
                    .float_param(node, &["roughness"], 0.5)?
                    .clamp(MIN_ROUGHNESS, 1.0);
                b.mat.specular =
                    Vec3::splat(0.08 * self.float_param(node, &["specular"], 0.5)?.clamp(0.0, 1.0));
            }
            "null" => {
                b.invisible = true;
            }
            "bumpmap" | "normalmap" | "mask" | "coating" | "roughcoating" | "blendbsdf"
            | "mixturebsdf" => {
                let mut inner = match self.inner_bsdf(node)? {
                    Some(i) => self.build_bsdf(i, depth + 1)?,
                    None => {
                        self.warn(format!("{}: {ty} without a nested BSDF", node.at()));
                        MatBuild {
                            mat: Material::diffuse(name.clone(), Vec3::splat(0.5)),
                            tex: Vec::new(),
                            invisible: false,
                        }
                    }
                };
                let mut used = false;
                if ty == "normalmap" {
                    if let Some(t) = node.children.iter().find(|c| c.tag == "texture") {
                        if let Some(file) = t
                            .param(&["string"], &["filename"])
                            .and_then(|s| s.attr("value"))
                        {
                            let p = self.resolve(file);
                            let i = self.request_texture(p, false);
                            inner.tex.push((Slot::Normal, i));
                            used = true;
                        }
                    }
                }
                if !used {
                    self.warn(format!(
                        "{}: {ty} not supported, using the nested BSDF only",
                        node.at()
                    ));
                }
                if node.attr("id").is_some() {
                    inner.mat.name = name;
                }
                return Ok(inner);
            }
            other => {
                self.warn(format!(
                    "{}: BSDF type `{other}` unsupported, using diffuse 0.5",
                    node.at()
                ));
                b.mat.base_color = Vec3::splat(0.5);
                b.mat.roughness = 1.0;
                b.mat.specular = Vec3::ZERO;
            }
        }
        Ok(b)
    }

    /// The registered material of a `<bsdf>` element, built once per element.
    pub(super) fn material_of(&mut self, node: &'t XNode) -> Result<(MaterialId, bool)> {
        let key = node as *const XNode as usize;
        if let Some(&m) = self.bsdf_memo.get(&key) {
            return Ok(m);
        }
        let b = self.build_bsdf(node, 0)?;
        let invisible = b.invisible;
        self.materials.push(b);
        let id = (self.materials.len() - 1) as MaterialId;
        self.bsdf_memo.insert(key, (id, invisible));
        Ok((id, invisible))
    }

    pub(super) fn default_material(&mut self) -> MaterialId {
        if let Some(m) = self.default_material {
            return m;
        }
        self.materials.push(MatBuild {
            mat: Material {
                two_sided: false,
                specular: Vec3::ZERO,
                ..Material::diffuse("default", Vec3::splat(0.5))
            },
            tex: Vec::new(),
            invisible: false,
        });
        let id = (self.materials.len() - 1) as MaterialId;
        self.default_material = Some(id);
        id
    }
}
