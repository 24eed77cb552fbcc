//! Mitsuba 0.6 XML loader: small scenes written to a temporary directory, and the Japanese
//! classroom from `shared/scenes` when it is present.

use std::path::{Path, PathBuf};
use std::time::Instant;

use fovea_render::scene::{Light, Scene};
use fovea_render::RenderError;
use glam::Vec3;

fn write(dir: &Path, name: &str, content: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

/// A scene document around `body`.
fn scene_xml(body: &str) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<scene version=\"0.6.0\">\n{body}\n</scene>\n"
    )
}

fn load(body: &str) -> Result<Scene, RenderError> {
    let dir = tempfile::tempdir().unwrap();
    load_in(dir.path(), body)
}

fn load_in(dir: &Path, body: &str) -> Result<Scene, RenderError> {
    let p = write(dir, "scene.xml", scene_xml(body));
    Scene::load(&p)
}

fn near(a: Vec3, b: Vec3, eps: f32) -> bool {
    (a - b).abs().max_element() <= eps
}

const CUBE: &str = r#"<shape type="cube"/>"#;

#[test]
fn defaults_are_substituted_and_unknown_parameters_left_alone() {
    let s = load(
        r#"
    <default name="r" value="0.25"/>
    <default name="spp" value="64"/>
    <integrator type="$method">
        <integer name="maxDepth" value="$unknownDepth"/>
    </integrator>
    <sampler type="independent"><integer name="sampleCount" value="$spp"/></sampler>
    <shape type="cube">
        <bsdf type="diffuse"><rgb name="reflectance" value="$r, $r, 0.5"/></bsdf>
    </shape>"#,
    )
    .unwrap();
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.base_color, Vec3::new(0.25, 0.25, 0.5));
    assert_eq!(m.roughness, 1.0);
    assert!(!m.two_sided, "not wrapped in twosided");
}

#[test]
fn rectangle_transform_composes_like_mitsuba() {
    // translate then scale: T = S · Tr, so (-1,-1,0) → (0,-1,0) → (0,-2,0).
    let s = load(
        r#"
    <shape type="rectangle">
        <transform name="toWorld">
            <translate x="1"/>
            <scale value="2"/>
        </transform>
    </shape>"#,
    )
    .unwrap();
    let m = &s.meshes[0];
    assert_eq!(m.indices.len(), 2);
    let b = s.bounds().unwrap();
    assert!(near(b.min, Vec3::new(0.0, -2.0, 0.0), 1e-6), "{b:?}");
    assert!(near(b.max, Vec3::new(4.0, 2.0, 0.0), 1e-6), "{b:?}");
    assert!(m.normals.iter().all(|n| near(*n, Vec3::Z, 1e-6)));
    // Geometric normal of the winding agrees.
    let t = m.indices[0];
    let (a, b, c) = (
        m.positions[t[0] as usize],
        m.positions[t[1] as usize],
        m.positions[t[2] as usize],
    );
    assert!((b - a).cross(c - a).z > 0.0);

    // The other order: scale then translate → [-2, 2] shifted by 1.
    let s = load(
        r#"
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="2" y="2"/>
            <translate value="1 0 0"/>
        </transform>
    </shape>"#,
    )
    .unwrap();
    let b = s.bounds().unwrap();
    assert!(near(b.min, Vec3::new(-1.0, -2.0, 0.0), 1e-6), "{b:?}");
    assert!(near(b.max, Vec3::new(3.0, 2.0, 0.0), 1e-6), "{b:?}");
}

#[test]
fn rotate_and_matrix_transforms() {
    // 90° about z maps +x to +y; the matrix (row-major) translates by (0, 0, 5).
    let s = load(
        r#"
    <shape type="rectangle">
        <transform name="toWorld">
            <scale x="2" y="1" z="1"/>
            <rotate z="1" angle="90"/>
            <matrix value="1 0 0 0  0 1 0 0  0 0 1 5  0 0 0 1"/>
        </transform>
    </shape>"#,
    )
    .unwrap();
    let b = s.bounds().unwrap();
    assert!(near(b.min, Vec3::new(-1.0, -2.0, 5.0), 1e-5), "{b:?}");
    assert!(near(b.max, Vec3::new(1.0, 2.0, 5.0), 1e-5), "{b:?}");
}

#[test]
fn cube_has_twelve_outward_triangles() {
    let s = load(CUBE).unwrap();
    assert_eq!(s.triangle_count(), 12);
    let b = s.bounds().unwrap();
    assert!(near(b.min, Vec3::splat(-1.0), 1e-6) && near(b.max, Vec3::ONE, 1e-6));
    let m = &s.meshes[0];
    for t in &m.indices {
        let (a, b, c) = (
            m.positions[t[0] as usize],
            m.positions[t[1] as usize],
            m.positions[t[2] as usize],
        );
        let n = (b - a).cross(c - a);
        assert!(n.dot((a + b + c) / 3.0) > 0.0, "outward");
        assert!(n.normalize().dot(m.normals[t[0] as usize]) > 0.999);
    }
}

#[test]
fn sphere_vertices_lie_on_the_radius() {
    let s = load(
        r#"
    <shape type="sphere">
        <point name="center" x="1" y="2" z="3"/>
        <float name="radius" value="0.5"/>
    </shape>"#,
    )
    .unwrap();
    let c = Vec3::new(1.0, 2.0, 3.0);
    let m = &s.meshes[0];
    assert!(m.indices.len() > 1000);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!(((*p - c).length() - 0.5).abs() < 1e-4);
        assert!(near(*n, (*p - c).normalize(), 1e-4));
    }
    assert!(
        !s.warnings.iter().any(|w| w.contains("degenerate")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn disk_is_a_unit_disk_facing_z() {
    let s = load(r#"<shape type="disk"/>"#).unwrap();
    let m = &s.meshes[0];
    assert_eq!(m.indices.len(), 64);
    for p in &m.positions {
        assert!(p.z == 0.0 && p.length() <= 1.0 + 1e-6);
    }
    let b = s.bounds().unwrap();
    assert!(near(b.max, Vec3::new(1.0, 1.0, 0.0), 1e-3));
    assert!(m.normals.iter().all(|n| *n == Vec3::Z));
}

#[test]
fn cylinder_between_two_points() {
    let s = load(
        r#"
    <shape type="cylinder">
        <point name="p0" value="0, 0, 0"/>
        <point name="p1" value="0, 2, 0"/>
        <float name="radius" value="0.5"/>
    </shape>"#,
    )
    .unwrap();
    let m = &s.meshes[0];
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let radial = Vec3::new(p.x, 0.0, p.z);
        assert!((radial.length() - 0.5).abs() < 1e-5);
        assert!(near(*n, radial.normalize(), 1e-5));
        assert!(p.y >= -1e-6 && p.y <= 2.0 + 1e-6);
    }
    let t = m.indices[0];
    let (a, b, c) = (
        m.positions[t[0] as usize],
        m.positions[t[1] as usize],
        m.positions[t[2] as usize],
    );
    assert!(
        (b - a).cross(c - a).dot(Vec3::new(a.x, 0.0, a.z)) > 0.0,
        "outward"
    );
}

#[test]
fn twosided_roughplastic_with_texture_and_references() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("textures")).unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([255, 0, 0]))
        .save(dir.path().join("textures/red.png"))
        .unwrap();
    let s = load_in(
        dir.path(),
        r#"
    <texture type="bitmap" id="redtex">
        <string name="filename" value="textures/red.png"/>
    </texture>
    <bsdf type="twosided" id="Wood">
        <bsdf type="roughplastic">
            <float name="alpha" value="0.09"/>
            <float name="intIOR" value="1.5"/>
            <float name="extIOR" value="1"/>
            <texture name="diffuseReflectance" type="bitmap">
                <string name="filename" value="textures/red.png"/>
            </texture>
        </bsdf>
    </bsdf>
    <bsdf type="diffuse" id="Ref">
        <ref name="reflectance" id="redtex"/>
    </bsdf>
    <shape type="cube"><ref id="Wood"/></shape>
    <shape type="cube"><ref id="Wood"/></shape>
    <shape type="rectangle"><ref id="Ref"/></shape>"#,
    )
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.textures.len(), 1, "decoded once");
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(
        s.meshes[0].material, s.meshes[1].material,
        "one material per BSDF"
    );
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.name, "Wood");
    assert!(m.two_sided);
    assert_eq!(m.base_color_texture, Some(0));
    assert!((m.roughness - 0.3).abs() < 1e-6, "√α");
    assert!((m.specular.x - 0.04).abs() < 1e-6, "F0 of IOR 1.5");
    assert_eq!(m.metallic, 0.0);
    let r = &s.materials[s.meshes[2].material as usize];
    assert_eq!(r.base_color_texture, Some(0));
    let texel = s.textures[0].sample(glam::Vec2::splat(0.5), 0.0);
    assert!((texel.x - 1.0).abs() < 1e-6 && texel.y.abs() < 1e-6);
}

#[test]
fn missing_texture_is_a_warning_and_grey() {
    let s = load(
        r#"
    <shape type="cube">
        <bsdf type="diffuse">
            <texture name="reflectance" type="bitmap"><string name="filename" value="nope.jpg"/></texture>
        </bsdf>
    </shape>"#,
    )
    .unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("nope.jpg")),
        "{:?}",
        s.warnings
    );
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.base_color_texture, None);
    assert_eq!(m.base_color, Vec3::splat(0.5));
}

#[test]
fn conductors_plastics_and_colours() {
    let s = load(
        r##"
    <bsdf type="conductor" id="al"><string name="material" value="Al"/></bsdf>
    <bsdf type="roughconductor" id="eta">
        <float name="alpha" value="0.04"/>
        <rgb name="specularReflectance" value="0.5"/>
        <rgb name="eta" value="1.65746, 0.880369, 0.521229"/>
        <rgb name="k" value="9.22387, 6.26952, 4.837"/>
    </bsdf>
    <bsdf type="plastic" id="pl"><srgb name="diffuseReflectance" value="#808080"/></bsdf>
    <bsdf type="diffuse" id="sp"><spectrum name="reflectance" value="400:0.1, 450:0.1, 550:0.2, 650:0.3"/></bsdf>
    <bsdf type="dielectric" id="glass"/>
    <shape type="cube"><ref id="al"/></shape>
    <shape type="cube"><ref id="eta"/></shape>
    <shape type="cube"><ref id="pl"/></shape>
    <shape type="cube"><ref id="sp"/></shape>
    <shape type="cube"><ref id="glass"/></shape>"##,
    )
    .unwrap();
    let mat = |i: usize| &s.materials[s.meshes[i].material as usize];
    assert_eq!(mat(0).metallic, 1.0);
    assert!(near(
        mat(0).base_color,
        Vec3::new(0.913, 0.922, 0.924),
        1e-6
    ));
    assert_eq!(mat(0).roughness, 0.05);
    assert!(
        (mat(1).base_color.x - 0.5 * 0.928).abs() < 0.005,
        "{}",
        mat(1).base_color
    );
    assert!((mat(1).roughness - 0.2).abs() < 1e-6);
    assert!(near(mat(2).base_color, Vec3::splat(0.2158605), 1e-4));
    assert_eq!(mat(2).roughness, 0.05);
    assert!(near(mat(3).base_color, Vec3::new(0.3, 0.2, 0.1), 1e-6));
    assert!(mat(4).two_sided);
    assert!(s.warnings.iter().any(|w| w.contains("no transmission")));
}

#[test]
fn sensor_fov_is_converted_to_vertical() {
    let s = load(&format!(
        r#"
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="toWorld">
            <lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/>
        </transform>
        <film type="hdrfilm">
            <integer name="width" value="1280"/>
            <integer name="height" value="720"/>
        </film>
    </sensor>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fovAxis" value="y"/>
    </sensor>
    <sensor type="perspective" id="focal"/>
    {CUBE}"#
    ))
    .unwrap();
    assert_eq!(s.cameras.len(), 3);
    let c = &s.cameras[0];
    let expected = 2.0
        * ((30f32).to_radians().tan() * 720.0 / 1280.0)
            .atan()
            .to_degrees();
    assert!((c.yfov_deg.unwrap() - expected).abs() < 1e-3);
    assert!((expected - 35.98).abs() < 0.01);
    assert!(near(c.position, Vec3::new(0.0, 1.0, 5.0), 1e-6));
    assert!(near(c.forward, Vec3::NEG_Z, 1e-6));
    assert!(near(c.up, Vec3::Y, 1e-6));
    assert!((s.cameras[1].yfov_deg.unwrap() - 40.0).abs() < 1e-3);
    // 50 mm on a 36 × 24 mm film diagonal, 768 × 576 film.
    let diag = (2.0f32 * (43.266_6f32 / 100.0).atan()).to_degrees();
    let tan_x = (diag.to_radians() / 2.0).tan() / (1.0f32 + 1.0 / (4.0 / 3.0f32).powi(2)).sqrt();
    let yfov = (2.0 * (tan_x * 0.75).atan()).to_degrees();
    assert!((s.cameras[2].yfov_deg.unwrap() - yfov).abs() < 1e-2);
    assert_eq!(s.cameras[2].name, "focal");
}

#[test]
fn point_spot_and_directional_emitters() {
    let s = load(&format!(
        r#"
    <emitter type="point">
        <point name="position" x="1" y="2" z="3"/>
        <rgb name="intensity" value="10, 20, 30"/>
    </emitter>
    <emitter type="point">
        <transform name="toWorld"><translate x="-1"/></transform>
    </emitter>
    <emitter type="spot">
        <transform name="toWorld"><lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
        <float name="cutoffAngle" value="30"/>
        <spectrum name="intensity" value="100"/>
    </emitter>
    <emitter type="directional">
        <vector name="direction" x="0" y="-2" z="0"/>
        <spectrum name="irradiance" value="3"/>
    </emitter>
    {CUBE}"#
    ))
    .unwrap();
    assert_eq!(s.lights.len(), 4);
    assert_eq!(
        s.lights[0],
        Light::Point {
            position: Vec3::new(1.0, 2.0, 3.0),
            intensity: Vec3::new(10.0, 20.0, 30.0),
            range: f32::INFINITY
        }
    );
    assert!(
        matches!(s.lights[1], Light::Point { position, intensity, .. }
        if position == Vec3::new(-1.0, 0.0, 0.0) && intensity == Vec3::ONE)
    );
    match &s.lights[2] {
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
            ..
        } => {
            assert!(near(*position, Vec3::new(0.0, 5.0, 0.0), 1e-6));
            assert!(near(*direction, Vec3::NEG_Y, 1e-6));
            assert_eq!(*intensity, Vec3::splat(100.0));
            assert!((cos_outer - 30f32.to_radians().cos()).abs() < 1e-6);
            assert!((cos_inner - 22.5f32.to_radians().cos()).abs() < 1e-6);
        }
        l => panic!("{l:?}"),
    }
    assert_eq!(
        s.lights[3],
        Light::Directional {
            direction: Vec3::NEG_Y,
            irradiance: Vec3::splat(3.0)
        }
    );
}

#[test]
fn area_emitter_makes_an_emissive_material_and_a_point_light() {
    let s = load(
        r#"
    <bsdf type="diffuse" id="white"/>
    <shape type="rectangle">
        <transform name="toWorld"><scale value="0.5"/><translate y="3"/></transform>
        <ref id="white"/>
        <emitter type="area"><rgb name="radiance" value="4, 5, 6"/></emitter>
    </shape>
    <shape type="cube"><ref id="white"/></shape>"#,
    )
    .unwrap();
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.emissive, Vec3::new(4.0, 5.0, 6.0));
    let plain = &s.materials[s.meshes[1].material as usize];
    assert_eq!(
        plain.emissive,
        Vec3::ZERO,
        "the shared BSDF is not made emissive"
    );
    assert_eq!(s.lights.len(), 1);
    match s.lights[0] {
        Light::Point {
            position,
            intensity,
            ..
        } => {
            // Area 1 m², centred at (0, 3, 0), facing +z: 1 cm in front.
            assert!(
                near(position, Vec3::new(0.0, 3.0, 0.01), 1e-5),
                "{position}"
            );
            assert!(
                near(intensity, Vec3::new(4.0, 5.0, 6.0), 1e-4),
                "{intensity}"
            );
        }
        ref l => panic!("{l:?}"),
    }

    // A closed emitter: the light sits at its centre with intensity L·A/4, with a warning.
    let s = load(
        r#"
    <shape type="sphere">
        <float name="radius" value="2"/>
        <emitter type="area"><spectrum name="radiance" value="1"/></emitter>
    </shape>"#,
    )
    .unwrap();
    match s.lights[0] {
        Light::Point {
            position,
            intensity,
            ..
        } => {
            assert!(position.length() < 1e-4);
            let pi_r2 = std::f32::consts::PI * 4.0;
            assert!((intensity.x - pi_r2).abs() < 0.02 * pi_r2, "{intensity}");
        }
        ref l => panic!("{l:?}"),
    }
    assert!(s.warnings.iter().any(|w| w.contains("closed")));
}

#[test]
fn sunsky_gives_a_sun_and_a_sky() {
    let s = load(&format!(
        r#"
    <emitter type="sunsky">
        <vector name="sunDirection" x="-0.865804" y="0.416766" z="-0.276929"/>
        <float name="skyScale" value="6"/>
        <float name="sunScale" value="10"/>
    </emitter>
    {CUBE}"#
    ))
    .unwrap();
    match s.lights.as_slice() {
        [Light::Directional {
            direction,
            irradiance,
        }] => {
            let to_sun = Vec3::new(-0.865804, 0.416766, -0.276929).normalize();
            assert!(near(*direction, -to_sun, 1e-6));
            assert!(irradiance.min_element() > 0.0);
        }
        l => panic!("{l:?}"),
    }
    let sky = s.environment.as_constant().expect("the sky is a constant");
    assert!(sky.z > sky.x, "sky blue: {sky}");

    // Without a direction the sun position is computed (Mitsuba's default date and place).
    let s = load(&format!(r#"<emitter type="sun"/>{CUBE}"#)).unwrap();
    match s.lights.as_slice() {
        [Light::Directional { direction, .. }] => assert!(direction.y < 0.0, "from above"),
        l => panic!("{l:?}"),
    }
    let s = load(&format!(
        r#"<emitter type="constant"><rgb name="radiance" value="0.1, 0.2, 0.3"/></emitter>{CUBE}"#
    ))
    .unwrap();
    assert_eq!(s.environment.as_constant(), Some(Vec3::new(0.1, 0.2, 0.3)));
}

/// An 8 × 4 latitude-longitude map with a different colour in every pixel.
fn small_map() -> image::Rgb32FImage {
    let (w, h) = (8u32, 4u32);
    let px: Vec<f32> = (0..w * h)
        .flat_map(|k| [0.25 + k as f32, 1.0, 0.5 + 0.125 * (k % 4) as f32])
        .collect();
    image::Rgb32FImage::from_raw(w, h, px).unwrap()
}

#[test]
fn envmap_files_become_maps_with_scale_and_to_world() {
    use fovea_render::scene::environment::envmap::uv_to_direction;
    let dir = tempfile::tempdir().unwrap();
    let img = small_map();
    for ext in ["exr", "hdr"] {
        image::DynamicImage::ImageRgb32F(img.clone())
            .save(dir.path().join(format!("sky.{ext}")))
            .unwrap();
        let s = load_in(
            dir.path(),
            &format!(
                r#"<emitter type="envmap">
                    <string name="filename" value="sky.{ext}"/>
                    <float name="scale" value="2"/>
                </emitter>{CUBE}"#
            ),
        )
        .unwrap();
        let map = s.environment.as_map().expect("a map, not its mean");
        assert_eq!((map.width(), map.height()), (8, 4));
        assert!(
            !s.warnings.iter().any(|w| w.contains("environment map")),
            "{:?}",
            s.warnings
        );
        // Pixel (5, 2) seen from its centre's direction, times the scale (RGBE: ~1 %).
        let d = uv_to_direction(glam::Vec2::new(5.5 / 8.0, 2.5 / 4.0));
        let want = 2.0 * Vec3::from_array(img.get_pixel(5, 2).0);
        let got = s.environment.radiance(d);
        assert!(
            near(got, want, 0.02 * want.max_element()),
            "{ext}: {got} vs {want}"
        );

        // A toWorld rotation turns the map.
        let s = load_in(
            dir.path(),
            &format!(
                r#"<emitter type="envmap">
                    <string name="filename" value="sky.{ext}"/>
                    <transform name="toWorld"><rotate y="1" angle="90"/></transform>
                </emitter>{CUBE}"#
            ),
        )
        .unwrap();
        let turned = glam::Mat3::from_rotation_y(90f32.to_radians()) * d;
        let got = s.environment.radiance(turned);
        assert!(
            near(got, want / 2.0, 0.01 * want.max_element()),
            "{ext}: {got}"
        );
    }

    // A missing or corrupt file: a warning naming it and a constant 0.5 × scale, as for a
    // missing texture.
    std::fs::write(dir.path().join("broken.exr"), b"not an exr").unwrap();
    for file in ["missing.hdr", "broken.exr"] {
        let s = load_in(
            dir.path(),
            &format!(
                r#"<emitter type="envmap">
                    <string name="filename" value="{file}"/>
                    <float name="scale" value="3"/>
                </emitter>{CUBE}"#
            ),
        )
        .unwrap();
        assert_eq!(s.environment.as_constant(), Some(Vec3::splat(1.5)));
        assert!(
            s.warnings.iter().any(|w| w.contains(file)),
            "{file}: {:?}",
            s.warnings
        );
    }
    // A negative scale is refused.
    let e = load_in(
        dir.path(),
        r#"<emitter type="envmap"><string name="filename" value="sky.exr"/>
           <float name="scale" value="-1"/></emitter><shape type="cube"/>"#,
    )
    .unwrap_err();
    assert!(e.to_string().contains("scale"), "{e}");
}

#[test]
fn obj_and_ply_shapes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("models")).unwrap();
    write(
        dir.path(),
        "models/tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\n",
    );
    write(
        dir.path(),
        "models/tri.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2\n",
    );
    let s = load_in(
        dir.path(),
        r#"
    <shape type="obj">
        <string name="filename" value="models/tri.obj"/>
        <transform name="toWorld"><translate z="2"/></transform>
    </shape>
    <shape type="obj" id="flat">
        <string name="filename" value="models/tri.obj"/>
        <boolean name="faceNormals" value="true"/>
    </shape>
    <shape type="ply"><string name="filename" value="models/tri.ply"/></shape>"#,
    )
    .unwrap();
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(s.meshes[0].name, "tri");
    assert!(s.meshes[0].positions.iter().all(|p| p.z == 2.0));
    assert_eq!(s.meshes[0].normals.len(), 3);
    assert!(
        s.meshes[1].normals.is_empty(),
        "faceNormals drops vertex normals"
    );
    assert_eq!(s.meshes[1].name, "flat");
    // OBJ vt (0, 0) is the image's bottom-left → glTF uv (0, 1).
    let i = s.meshes[0]
        .positions
        .iter()
        .position(|p| p.x == 0.0 && p.y == 0.0)
        .unwrap();
    assert_eq!(s.meshes[0].uvs[i], glam::Vec2::new(0.0, 1.0));
    // Mitsuba reads PLY uvs as stored.
    assert_eq!(s.meshes[2].uvs[0], glam::Vec2::new(0.0, 0.0));
    // Shapes without a BSDF get Mitsuba's default diffuse 0.5.
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.base_color, Vec3::splat(0.5));
}

#[test]
fn includes_are_spliced() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "materials.xml",
        r#"<scene version="0.6.0"><bsdf type="diffuse" id="m"><rgb name="reflectance" value="0.1"/></bsdf></scene>"#,
    );
    let s = load_in(
        dir.path(),
        r#"<include filename="materials.xml"/><shape type="cube"><ref id="m"/></shape>"#,
    )
    .unwrap();
    assert_eq!(
        s.materials[s.meshes[0].material as usize].base_color,
        Vec3::splat(0.1)
    );
    // An include cycle is an error.
    write(
        dir.path(),
        "a.xml",
        r#"<scene><include filename="scene.xml"/></scene>"#,
    );
    let e = load_in(dir.path(), r#"<include filename="a.xml"/>"#).unwrap_err();
    assert!(e.to_string().contains("cycle"), "{e}");
}

#[test]
fn unknown_shapes_and_bsdfs_are_warnings() {
    let s = load(
        r#"
    <shape type="serialized"><string name="filename" value="x.serialized"/></shape>
    <shape type="cube"><bsdf type="hk"/></shape>
    <shape type="cube"><bsdf type="null"/></shape>
    <medium type="homogeneous" id="fog"/>"#,
    )
    .unwrap();
    assert_eq!(s.meshes.len(), 1);
    assert!(s.warnings.iter().any(|w| w.contains("serialized")));
    assert!(s.warnings.iter().any(|w| w.contains("`hk`")));
    assert!(s.warnings.iter().any(|w| w.contains("null BSDF")));
}

#[test]
fn malformed_inputs_are_errors() {
    // Malformed XML: roxmltree's message with a position.
    let e = load("<shape type=\"cube\">").unwrap_err();
    match &e {
        RenderError::BadInput { what, .. } => assert!(what.contains("malformed XML"), "{what}"),
        e => panic!("{e}"),
    }
    assert!(e.to_string().chars().any(|c| c.is_ascii_digit()), "{e}");
    // Missing OBJ: the message names the file and the shape.
    let e =
        load(r#"<shape type="obj"><string name="filename" value="models/missing.obj"/></shape>"#)
            .unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, RenderError::BadInput { .. }));
    assert!(
        msg.contains("missing.obj") && msg.contains("shape"),
        "{msg}"
    );
    // Reference to an undefined id.
    let e = load(r#"<shape type="cube"><ref id="nowhere"/></shape>"#).unwrap_err();
    assert!(e.to_string().contains("nowhere"), "{e}");
    // Numbers that do not parse.
    let e = load(r#"<shape type="sphere"><float name="radius" value="big"/></shape>"#).unwrap_err();
    assert!(e.to_string().contains("big"), "{e}");
    // Wrong root.
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "x.xml", "<notascene/>");
    assert!(matches!(Scene::load(&p), Err(RenderError::BadInput { .. })));
    // No shapes at all.
    assert!(load(r#"<emitter type="constant"/>"#).is_err());
}

/// The Japanese classroom (Bitterli's Mitsuba version) from `shared/scenes`.
#[test]
fn japanese_classroom_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes/japanese-classroom/scene.xml");
    if !path.exists() {
        println!("skipping: ../shared/scenes not found");
        return;
    }
    let t0 = Instant::now();
    let s = Scene::load(&path).unwrap();
    let dt = t0.elapsed();
    println!("classroom: loaded in {dt:?}");
    let tris = s.triangle_count();
    println!(
        "classroom: {tris} triangles, {} meshes, {} materials, {} textures, warnings {:?}",
        s.meshes.len(),
        s.materials.len(),
        s.textures.len(),
        s.warnings
    );
    let expected = 103_832f64;
    assert!(
        ((tris as f64 - expected) / expected).abs() < 0.005,
        "{tris} triangles"
    );
    assert!(s.meshes.len() <= 79);
    assert_eq!(s.metres_per_unit, 1.0);

    let c = &s.cameras[0];
    assert!(
        near(c.position, Vec3::new(-1.69049, 1.27158, 5.88653), 1e-3),
        "{c:?}"
    );
    assert!(
        near(c.forward, Vec3::new(0.151294, 0.0283071, -0.988083), 1e-3),
        "{c:?}"
    );
    assert!(c.up.y > 0.99, "{c:?}");
    assert!((c.yfov_deg.unwrap() - 36.0).abs() < 0.1, "{c:?}");

    let b = s.bounds().unwrap();
    assert!(
        near(b.min, Vec3::new(-110.81, -0.17, -110.81), 0.02),
        "{b:?}"
    );
    assert!(near(b.max, Vec3::new(110.81, 3.06, 110.81), 0.02), "{b:?}");

    assert_eq!(s.textures.len(), 3);
    let mut names: Vec<&str> = s.textures.iter().map(|t| t.name.as_str()).collect();
    names.sort();
    assert_eq!(names, ["blackboard.jpg", "wood1.jpg", "wood2.jpg"]);
    for (mat, tex) in [
        ("Lectern", "wood1.jpg"),
        ("ChairWood", "wood2.jpg"),
        ("WoodFrame", "blackboard.jpg"),
    ] {
        let m = s.materials.iter().find(|m| m.name == mat).unwrap();
        let t = m.base_color_texture.expect(mat);
        assert_eq!(s.textures[t as usize].name, tex);
        assert!(m.two_sided);
    }
    let floor = s.materials.iter().find(|m| m.name == "Floor").unwrap();
    assert!(near(
        floor.base_color,
        Vec3::new(0.659224, 0.592438, 0.517401),
        1e-6
    ));
    let frame = s.materials.iter().find(|m| m.name == "ChairFrame").unwrap();
    assert!(frame.metallic == 1.0 || frame.base_color.x > 0.6);
    assert!(s
        .lights
        .iter()
        .any(|l| matches!(l, Light::Directional { direction, .. } if direction.y < 0.0)));
    assert!(s.environment.mean().max_element() > 0.0);
}
