#!/usr/bin/env python3
"""Writes the fuzz seeds: fuzz/seeds/<target>/seed-* are the malformed files of
crates/fovea-render/tests/corpus/ and a few small valid files written here. The inputs of
crashes fuzzing found are kept beside them as regression-* (by hand). Fuzzing reads them as
a second corpus folder and adds its finds to fuzz/corpus/<target>/ (see docs/fuzzing.md).

    python3 fuzz/seeds.py The harness
(fuzz/src/lib.rs) splits `obj` inputs at MTL_MARKER (the rest is `m.mtl`) and `mitsuba`
inputs at INCLUDE_MARKER (the rest is `inc.xml`); `mesh.obj` and `mesh.ply` lie beside them.
"""

import base64
import json
import pathlib
import re
import struct

ROOT = pathlib.Path(__file__).resolve().parent.parent
TESTS = ROOT / "crates/fovea-render/tests/corpus"
OUT = ROOT / "fuzz/seeds"
MTL_MARKER = b"\n##mtl\n"
INCLUDE_MARKER = b"\n<!--inc.xml-->\n"


def put(target, name, data):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    (d / ("seed-" + name)).write_bytes(data)


def triangle_buffer():
    """Positions (3 × VEC3 f32), normals (3 × VEC3 f32), UVs (3 × VEC2 f32), u16 indices."""
    pos = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    nrm = struct.pack("<9f", 0, 0, 1, 0, 0, 1, 0, 0, 1)
    uv = struct.pack("<6f", 0, 0, 1, 0, 0, 1)
    idx = struct.pack("<3H", 0, 1, 2) + b"\0\0"
    return pos + nrm + uv + idx


def rich_gltf(buffer_uri):
    """A small glTF using most of what the loader reads: TRS and matrix nodes, a child, a
    camera, the three KHR_lights_punctual types (a 6,830 lx sun), a material with emissive
    strength, normals, UVs, indices, a triangle-strip primitive and a sparse accessor."""
    buf = triangle_buffer()
    doc = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 3, 4]}],
        "nodes": [
            {"mesh": 0, "translation": [0, 0, -2], "rotation": [0, 0, 0, 1],
             "scale": [1, 2, 1], "children": [1, 2]},
            {"mesh": 1, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 1]},
            {"camera": 0, "translation": [0, 0, 3]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 2, 0]},
            {"extensions": {"KHR_lights_punctual": {"light": 1}},
             "rotation": [-0.383, 0, 0, 0.924], "children": [5]},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.8, "znear": 0.01, "aspectRatio": 1.5}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "intensity": 50, "color": [1, 0.9, 0.8], "range": 10},
            {"type": "directional", "intensity": 6830},
            {"type": "spot", "intensity": 20,
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}},
        ]}},
        "materials": [{
            "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.1, 1],
                                     "metallicFactor": 0.1, "roughnessFactor": 0.7},
            "emissiveFactor": [1, 1, 1],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}},
            "doubleSided": True,
        }],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                             "indices": 3, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 4}, "mode": 5}]},
        ],
        "buffers": [{"byteLength": len(buf)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 36},
            {"buffer": 0, "byteOffset": 72, "byteLength": 24},
            {"buffer": 0, "byteOffset": 96, "byteLength": 6},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "sparse": {"count": 1,
                        "indices": {"bufferView": 3, "componentType": 5123},
                        "values": {"bufferView": 1}}},
        ],
    }
    if buffer_uri is not None:
        doc["buffers"][0]["uri"] = buffer_uri
    return doc, buf


def glb(doc, blob):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js
    body += struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def gltf_seeds():
    for p in sorted((TESTS / "gltf").glob("*.gltf")):
        put("gltf", p.name, p.read_bytes())
    for p in sorted((TESTS / "gltf").glob("*.glb")):
        put("glb", p.name, p.read_bytes())
    data_uri = "data:application/octet-stream;base64," + base64.b64encode(triangle_buffer()).decode()
    doc, _ = rich_gltf(data_uri)
    put("gltf", "rich.gltf", json.dumps(doc, indent=1))
    ext, _ = rich_gltf("mesh.obj")  # an external buffer (the scratch folder's mesh.obj)
    put("gltf", "external-buffer.gltf", json.dumps(ext))
    dev, _ = rich_gltf("/dev/zero")
    put("gltf", "dev-zero-buffer.gltf", json.dumps(dev))
    doc, blob = rich_gltf(None)
    put("glb", "rich.glb", glb(doc, blob))


def obj_seeds():
    for p in sorted((TESTS / "obj").glob("*.obj")):
        text = p.read_bytes()
        m = re.search(rb"^mtllib\s+(\S+)", text, re.M)
        if m:
            mtl = TESTS / "obj" / m.group(1).decode()
            text = text.replace(m.group(0), b"mtllib m.mtl")
            if mtl.exists():
                text += MTL_MARKER + mtl.read_bytes()
        put("obj", p.name, text)
    put("obj", "quad-mtl.obj",
        "mtllib m.mtl\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\n"
        "vt 1 1\nvt 0 1\nvn 0 0 1\ng front\nusemtl red\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
        "usemtl glow\nf -4 -2 -1\ns 1\n"
        + MTL_MARKER.decode()
        + "newmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 50\nd 1\nillum 2\n"
        "newmtl glow\nKd 0 0 0\nKe 5 5 5\nmap_Kd mesh.ply\n")
    put("obj", "colors.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n")
    put("obj", "utf16.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".encode("utf-16"))


def ply_seeds():
    for p in sorted((TESTS / "ply").glob("*.ply")):
        put("ply", p.name, p.read_bytes())
    header = ("ply\nformat {}\ncomment seed\nelement vertex 4\nproperty float x\n"
              "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
              "property float nz\nproperty uchar red\nproperty uchar green\n"
              "property uchar blue\nproperty float u\nproperty float v\nelement face 1\n"
              "property list uchar int vertex_indices\nend_header\n")
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    text = header.format("ascii 1.0")
    for i, (x, y, z) in enumerate(verts):
        text += f"{x} {y} {z} 0 0 1 {60 * i} 128 255 {x} {y}\n"
    text += "4 0 1 2 3\n"
    put("ply", "quad-ascii.ply", text)
    for fmt, end in (("binary_little_endian 1.0", "<"), ("binary_big_endian 1.0", ">")):
        data = header.format(fmt).encode()
        for i, (x, y, z) in enumerate(verts):
            data += struct.pack(end + "6f3B2f", x, y, z, 0, 0, 1, 60 * i, 128, 255, x, y)
        data += struct.pack(end + "B4i", 4, 0, 1, 2, 3)
        put("ply", f"quad-{end == '<' and 'le' or 'be'}.ply", data)


def mitsuba_seeds():
    for p in sorted((TESTS / "mitsuba").glob("*.xml")):
        put("mitsuba", p.name, p.read_bytes())
    scene = """<?xml version="1.0" encoding="utf-8"?>
<scene version="0.6.0">
  <default name="spp" value="4"/>
  <integrator type="path"><integer name="maxDepth" value="$spp"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="45"/><string name="fovAxis" value="x"/>
    <transform name="toWorld"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
  </sensor>
  <bsdf type="twosided" id="red"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf></bsdf>
  <bsdf type="roughconductor" id="metal"><float name="alpha" value="0.2"/></bsdf>
  <shape type="obj"><string name="filename" value="mesh.obj"/><ref id="red"/>
    <transform name="toWorld"><scale value="2"/><rotate y="1" angle="30"/><translate x="1"/></transform></shape>
  <shape type="ply"><string name="filename" value="mesh.ply"/><ref id="metal"/></shape>
  <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="5"/></emitter>
    <transform name="toWorld"><matrix value="1 0 0 0 0 1 0 2 0 0 1 0 0 0 0 1"/></transform></shape>
  <shape type="cube"><bsdf type="plastic"/></shape>
  <shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/></shape>
  <emitter type="point"><point name="position" x="0" y="3" z="0"/><spectrum name="intensity" value="10"/></emitter>
  <emitter type="sun"><vector name="sunDirection" x="0.3" y="1" z="0.2"/></emitter>
  <include filename="inc.xml"/>
</scene>"""
    inc = """<scene version="0.6.0">
  <shape type="disk"><bsdf type="dielectric"/></shape>
  <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
</scene>"""
    put("mitsuba", "scene-include.xml", scene + INCLUDE_MARKER.decode() + inc)


def gaze_seeds():
    put("gaze_csv", "pixels.csv",
        "t,x,y\n0,720,800\n0.011,730,805\n0.022,,\n0.033,740,810\n0.044,1500,810\n")
    put("gaze_csv", "pupil-labs.csv",
        "gaze_timestamp,world_index,confidence,norm_pos_x,norm_pos_y\n"
        "3.10,0,0.9,0.5,0.5\n3.12,1,0.3,0.6,0.4\n3.14,2,0.95,1.02,0.5\n")
    put("gaze_csv", "semicolon-ms.csv",
        "\ufeff# exported\ntime_ms;gaze_x_px;gaze_y_px;depth_mm;right_x;right_y\n"
        "0;720,5;800;1500;700;800\n11;721;801;nan;701;801\n")
    put("gaze_csv", "tabs-us.csv",
        "device_time_stamp\tx_norm\ty_norm\tconf\n100\t0.5\t0.5\t1\n11200\t0.51\t0.49\t0.8\n")
    put("gaze_csv", "decreasing.csv", "t,x,y\n1,1,1\n0.5,2,2\n")


def rgbe_header(w, h):
    return f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()


def envmap_seeds():
    """Radiance RGBE in its three scanline forms, damaged ones, and a small PNG."""
    w, h = 16, 8
    px = [bytes([(7 * i) % 256, (3 * j) % 256, 100, 128 + (i + j) % 4])
          for j in range(h) for i in range(w)]
    flat = rgbe_header(w, h) + b"".join(px)
    put("envmap", "flat.hdr", flat)
    rle = bytearray(rgbe_header(w, h))
    for j in range(h):
        rle += bytes([2, 2, 0, w])
        row = px[j * w:(j + 1) * w]
        for c in range(4):
            # One literal run of 8, then one repeat run of 8.
            rle += bytes([8]) + bytes(p[c] for p in row[:8]) + bytes([128 + 8, row[8][c]])
    put("envmap", "rle.hdr", bytes(rle))
    old = rgbe_header(4, 2) + bytes([10, 20, 30, 129, 1, 1, 1, 3]) * 2
    put("envmap", "old-rle.hdr", old)
    put("envmap", "truncated.hdr", bytes(rle[:len(rle) // 2]))
    put("envmap", "run-overflow.hdr", rgbe_header(8, 1) + bytes([2, 2, 0, 8, 128 + 9, 1]) + bytes(16))
    put("envmap", "huge-header.hdr", rgbe_header(65536, 65536))
    put("envmap", "xyze.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 2 +X 2\n" + bytes(16))
    put("envmap", "flipped.hdr", b"#?RADIANCE\n\n+Y 2 +X 2\n" + bytes(16))
    # An 8x4 grey PNG (zlib-stored IDAT), written by hand.
    import zlib
    raw = b"".join(b"\0" + bytes([128, 128, 128]) * 8 for _ in range(4))

    def chunk(t, d):
        c = struct.pack(">I", len(d)) + t + d
        return c + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 8, 4, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    put("envmap", "sky.png", png)
    put("envmap", "junk.exr", b"not an image at all")


if __name__ == "__main__":
    gltf_seeds()
    obj_seeds()
    ply_seeds()
    mitsuba_seeds()
    gaze_seeds()
    envmap_seeds()
    for d in sorted(OUT.iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} files")
