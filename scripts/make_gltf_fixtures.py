#!/usr/bin/env python3
"""Regenerates the glTF decoding fixtures in crates/derma-core/tests/data/gltf/ (run by hand; the
tests read only the committed files). Needs Node.js with npm and Python 3 with numpy.

Every fixture is MediaPipe's canonical face (../shared/data/canonical_face_model.obj, Apache-2.0;
see its PROVENANCE file), encoded by tools derma does not contain, as the web ships glTF:
  face_plain.glb           written here: float positions, UVs and indices, no extension
  face_quantized.glb       gltfpack 1.3.0 (default: KHR_mesh_quantization, integer positions
                           dequantized by the node's scale, normalized UVs under
                           KHR_texture_transform)
  face_meshopt.glb         gltfpack -c (EXT_meshopt_compression, attributes and triangles)
  face_meshopt_oct.glb     gltfpack -cc -gn 60 -vpn (normalized positions; normals generated at a
                           60° crease and stored with the OCTAHEDRAL filter)
  face_meshopt_exp.glb     gltfpack -c -vpf (float positions under the EXPONENTIAL filter)
  face_draco.glb           glTF Transform 4.2.1 `draco` of face_plain.glb
                           (KHR_draco_mesh_compression, edgebreaker)
  face_basisu.glb          face_meshopt.glb with its texture moved under KHR_texture_basisu (a
                           KTX2 image derma never decodes): texture extensions must not block
                           geometry
  rig.gltf                 written here: a skinned face under an armature node (scale 100,
                           −90° about X, as Blender exports), two morph targets with names, an
                           eye node, a node matrix, and a sparse accessor
  rig_meshopt.glb          gltfpack -c -kn of rig.gltf (morph targets compressed too)

Usage: python3 scripts/make_gltf_fixtures.py
"""

import base64
import json
import os
import struct
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
OUT = os.path.join(ROOT, "crates", "derma-core", "tests", "data", "gltf")
FACE = os.path.join(ROOT, "..", "shared", "data", "canonical_face_model.obj")
GLTFPACK = "gltfpack@1.3.0"
TRANSFORM = "@gltf-transform/cli@4.2.1"


def read_obj(path):
    v, vt, faces = [], [], []
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            v.append([float(x) for x in t[1:4]])
        elif t[0] == "vt":
            vt.append([float(x) for x in t[1:3]])
        elif t[0] == "f":
            faces.append([tuple(int(i) - 1 for i in c.split("/")[:2]) for c in t[1:]])
    # One vertex per (position, uv) pair, as a glTF needs.
    key, pos, uv, tri = {}, [], [], []
    for f in faces:
        idx = []
        for c in f:
            if c not in key:
                key[c] = len(pos)
                pos.append(v[c[0]])
                uv.append(vt[c[1]])
            idx.append(key[c])
        for k in range(1, len(idx) - 1):
            tri.append([idx[0], idx[k], idx[k + 1]])
    return np.array(pos, np.float32), np.array(uv, np.float32), np.array(tri, np.uint32)


class Builder:
    """A minimal glTF writer: one buffer, views and accessors appended in order."""

    def __init__(self):
        self.bin = bytearray()
        self.j = {"asset": {"version": "2.0", "generator": "derma make_gltf_fixtures.py"},
                  "bufferViews": [], "accessors": [], "meshes": [], "nodes": [],
                  "scenes": [{"nodes": []}], "scene": 0}

    def view(self, data):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.j["bufferViews"].append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)})
        self.bin += data
        return len(self.j["bufferViews"]) - 1

    def accessor(self, arr, kind, minmax=False, sparse=None):
        ct = {np.float32: 5126, np.uint32: 5125, np.uint16: 5123}[arr.dtype.type]
        a = {"bufferView": self.view(arr.tobytes()), "componentType": ct, "count": int(arr.shape[0]), "type": kind}
        if minmax:
            a["min"] = arr.min(0).tolist()
            a["max"] = arr.max(0).tolist()
        if sparse is not None:
            idx, vals = sparse
            a["sparse"] = {"count": len(idx),
                           "indices": {"bufferView": self.view(np.array(idx, np.uint16).tobytes()), "componentType": 5123},
                           "values": {"bufferView": self.view(np.array(vals, np.float32).tobytes())}}
        self.j["accessors"].append(a)
        return len(self.j["accessors"]) - 1

    def glb(self, path):
        self.j["buffers"] = [{"byteLength": len(self.bin)}]
        write_glb(path, self.j, bytes(self.bin))

    def gltf(self, path):
        self.j["buffers"] = [{"byteLength": len(self.bin),
                              "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()}]
        with open(path, "w") as f:
            json.dump(self.j, f, indent=1)


def write_glb(path, j, binary):
    js = json.dumps(j, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    binary = binary + b"\0" * (-len(binary) % 4)
    out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(binary))
    out += struct.pack("<II", len(js), 0x4E4F534A) + js
    out += struct.pack("<II", len(binary), 0x004E4942) + binary
    open(path, "wb").write(out)


def read_glb(path):
    b = open(path, "rb").read()
    n = struct.unpack("<I", b[12:16])[0]
    j = json.loads(b[20:20 + n])
    rest = b[20 + n:]
    m = struct.unpack("<I", rest[:4])[0]
    return j, rest[8:8 + m]


def face_plain(path, pos, uv, tri):
    b = Builder()
    p = b.accessor(pos, "VEC3", minmax=True)
    t = b.accessor(uv * np.array([1, -1], np.float32) + np.array([0, 1], np.float32), "VEC2")
    i = b.accessor(tri.reshape(-1), "SCALAR")
    b.j["materials"] = [{"name": "skin"}]
    b.j["meshes"].append({"name": "face", "primitives": [{"attributes": {"POSITION": p, "TEXCOORD_0": t}, "indices": i, "material": 0}]})
    b.j["nodes"].append({"name": "face", "mesh": 0})
    b.j["scenes"][0]["nodes"] = [0]
    b.glb(path)


def rig(path, pos, uv, tri):
    """A skinned face (its bind shape in centimetres, placed by an armature of scale 100 and
    −90° about X) with two morph targets, an eye node under a matrix, a sparse target."""
    b = Builder()
    cm = pos / 100.0
    # The armature turns −90° about X; the bind shape is stored turned +90° so the face stands.
    turned = np.stack([cm[:, 0], -cm[:, 2], cm[:, 1]], 1).astype(np.float32)
    p = b.accessor(turned, "VEC3", minmax=True)
    t = b.accessor(uv * np.array([1, -1], np.float32) + np.array([0, 1], np.float32), "VEC2")
    i = b.accessor(tri.reshape(-1), "SCALAR")
    n = len(pos)
    smile = np.zeros((n, 3), np.float32)
    smile[:, 0] = 0.01 * (np.arange(n) % 7)
    s = b.accessor(smile, "VEC3", minmax=True)
    zeros = np.zeros((n, 3), np.float32)
    blink = b.accessor(zeros, "VEC3", minmax=True, sparse=([3, 5], [[0, 0, 0.02], [0, 0, -0.03]]))
    joints = b.accessor(np.zeros((n, 4), np.uint16), "VEC4")
    weights = b.accessor(np.tile(np.array([[1, 0, 0, 0]], np.float32), (n, 1)), "VEC4")
    ibm = b.accessor(np.eye(4, dtype=np.float32).reshape(1, 16), "MAT4")
    b.j["meshes"].append({"name": "FaceMesh", "extras": {"targetNames": ["smile", "blink"]},
                          "primitives": [{"attributes": {"POSITION": p, "TEXCOORD_0": t, "JOINTS_0": joints, "WEIGHTS_0": weights},
                                          "indices": i, "targets": [{"POSITION": s}, {"POSITION": blink}]}]})
    eye = b.accessor(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), "VEC3", minmax=True)
    b.j["meshes"].append({"name": "EyeMesh", "primitives": [{"attributes": {"POSITION": eye}}]})
    q = [-0.70710678, 0, 0, 0.70710678]
    b.j["nodes"] = [
        {"name": "Armature", "rotation": q, "scale": [100, 100, 100], "children": [1]},
        {"name": "Root"},
        # The skinned node's own transform must be ignored (glTF 2.0 §3.7.3).
        {"name": "Head", "mesh": 0, "skin": 0, "scale": [7, 7, 7]},
        {"name": "Eye_L", "mesh": 1, "matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 10, 20, 30, 1]},
    ]
    b.j["skins"] = [{"joints": [1], "inverseBindMatrices": ibm}]
    b.j["scenes"][0]["nodes"] = [0, 2, 3]
    b.gltf(path)


def basisu(src, path):
    j, binary = read_glb(src)
    ktx2 = b"\xabKTX 20\xbb\r\n\x1a\n" + b"\0" * 64
    off = len(binary) + (-len(binary) % 4)
    binary = binary + b"\0" * (-len(binary) % 4) + ktx2
    j["buffers"][0]["byteLength"] = len(binary)
    j["bufferViews"].append({"buffer": 0, "byteOffset": off, "byteLength": len(ktx2)})
    j["images"] = [{"bufferView": len(j["bufferViews"]) - 1, "mimeType": "image/ktx2"}]
    j["textures"] = [{"extensions": {"KHR_texture_basisu": {"source": 0}}}]
    for key in ("extensionsUsed", "extensionsRequired"):
        j.setdefault(key, []).append("KHR_texture_basisu")
    write_glb(path, j, binary)


def npx(pkg, *args):
    subprocess.run(["npx", "--yes", "--package", pkg, "--"] + list(args), check=True)


def main():
    os.makedirs(OUT, exist_ok=True)
    pos, uv, tri = read_obj(FACE)
    tmp = tempfile.mkdtemp(prefix="derma-gltf-")
    # gltfpack reads the OBJ with a textured material, so its UVs go under KHR_texture_transform.
    from PIL import Image  # noqa: E402 (only this step needs it)
    Image.new("RGB", (4, 4), (200, 150, 120)).save(os.path.join(tmp, "skin.png"))
    with open(os.path.join(tmp, "face.mtl"), "w") as f:
        f.write("newmtl skin\nKd 1 1 1\nmap_Kd skin.png\n")
    obj = os.path.join(tmp, "face.obj")
    with open(obj, "w") as f:
        f.write("mtllib face.mtl\nusemtl skin\n")
        f.writelines(l for l in open(FACE) if not l.startswith(("mtllib", "usemtl")))
    o = lambda name: os.path.join(OUT, name)  # noqa: E731
    face_plain(o("face_plain.glb"), pos, uv, tri)
    npx(GLTFPACK, "gltfpack", "-i", obj, "-o", o("face_quantized.glb"))
    npx(GLTFPACK, "gltfpack", "-i", obj, "-o", o("face_meshopt.glb"), "-c")
    npx(GLTFPACK, "gltfpack", "-i", obj, "-o", o("face_meshopt_oct.glb"), "-cc", "-gn", "60", "-vpn")
    npx(GLTFPACK, "gltfpack", "-i", obj, "-o", o("face_meshopt_exp.glb"), "-c", "-vpf")
    npx(TRANSFORM, "gltf-transform", "draco", o("face_plain.glb"), o("face_draco.glb"))
    basisu(o("face_meshopt.glb"), o("face_basisu.glb"))
    rig(o("rig.gltf"), pos, uv, tri)
    npx(GLTFPACK, "gltfpack", "-i", o("rig.gltf"), "-o", o("rig_meshopt.glb"), "-c", "-kn")
    print("wrote", OUT)


if __name__ == "__main__":
    sys.exit(main())
