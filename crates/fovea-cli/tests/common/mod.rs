//! Scene files the CLI tests generate (nothing large is committed).

use std::path::{Path, PathBuf};

/// A glTF ground (10 m square) with a camera 2 m up looking 25° down (`yfov` 0.7 rad) and a
/// directional light of `lux` lux falling 60° from the horizon, as a Blender export writes a
/// sun of strength `lux / 683` W/m²; the buffer is a `.bin` next to it.
pub fn photometric_ground(dir: &Path, lux: f32) -> PathBuf {
    let pos: [[f32; 3]; 4] = [[-5., 0., -5.], [5., 0., -5.], [5., 0., 5.], [-5., 0., 5.]];
    let mut bin: Vec<u8> = pos.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
    bin.extend([0u16, 2, 1, 0, 3, 2].iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(dir.join("ground.bin"), &bin).unwrap();
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1,2]}}],
        "extensionsUsed":["KHR_lights_punctual"],
        "extensions":{{"KHR_lights_punctual":{{"lights":[{{"type":"directional","intensity":{lux}}}]}}}},
        "nodes":[{{"mesh":0}},
          {{"camera":0,"translation":[0,2,4],"rotation":[-0.21644,0,0,0.97630]}},
          {{"extensions":{{"KHR_lights_punctual":{{"light":0}}}},"rotation":[-0.5,0,0,0.86603]}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.7,"znear":0.1}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{{"byteLength":{len},"uri":"ground.bin"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},
          {{"buffer":0,"byteOffset":48,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3",
          "min":[-5,0,-5],"max":[5,0,5]}},
          {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
        len = bin.len()
    );
    let p = dir.join("ground.gltf");
    std::fs::write(&p, gltf).unwrap();
    p
}
