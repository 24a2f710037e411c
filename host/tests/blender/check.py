"""Poses a .glb from `sinew export gltf` the way Blender does and compares it with `sinew play`'s
OBJ frames of the same poses.

Blender (PyPI `bpy`, pinned in requirements.txt beside this file) imports the file with its own
glTF importer (io_scene_gltf2, default options: shape keys, armature, the animation as an
action), then for each keyframe sets the scene's frame, evaluates the depsgraph (shape keys, then
the armature modifier) and reads the evaluated mesh's vertices. Blender's shape keys clamp their
values to the slider range [0, 1], so an export keyed outside it would pose differently here.

With --original RIG.glb (the character an export with --rig carried meshes from), each mesh of
the original that the export carries (by name) must stand where it stood, vertex by vertex in
Blender's world, with the export's armature in its rest position: the export drops into a scene
in place of the original.

Usage: python check.py --glb FILE.glb --frames DIR --obj-unit METRES [--tolerance-mm MM]
                       [--original RIG.glb]
  DIR holds frame_00000.obj, ... from `sinew play` of the frames the .glb was exported with;
  --obj-unit is the OBJ's unit in metres (0.01 for the kit's centimetres). A looping export
  (--loop) has one keyframe more than there are frames: it is compared with frame 0.
Exported vertex and OBJ vertex are matched by triangle corner, as host/tests/three/check.mjs
does: the export keeps the triangle order of the actor (or of the rig) and only splits vertices
at texture seams, and Blender's importer keeps the triangles and their corners in order (a
corner that maps one Blender vertex onto two OBJ vertices fails the check). Positions are
compared in the mesh's own frame: Blender's world positions taken back from its +Z up to glTF's
+Y up, with the transform above the skeleton (a rig's node transform) taken off. Exits non-zero
when any vertex of any keyframe is further than the tolerance (default 0.01 mm) from sinew
play's, or when the file cannot be imported.
"""

import argparse
import json
import math
import os
import re
import struct
import sys

import bpy
import numpy as np


def fail(message):
    print(message, file=sys.stderr)
    sys.exit(1)


def read_glb(path):
    """The JSON document and the BIN chunk of a .glb."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 20 or data[:4] != b"glTF":
        fail(f"{path}: not a binary glTF")
    length, kind = struct.unpack_from("<II", data, 12)
    if kind != 0x4E4F534A:
        fail(f"{path}: first chunk is not JSON")
    doc = json.loads(data[20 : 20 + length])
    at = 20 + length
    bin_chunk = b""
    if at + 8 <= len(data):
        blen, _ = struct.unpack_from("<II", data, at)
        bin_chunk = data[at + 8 : at + 8 + blen]
    return doc, bin_chunk


def accessor_floats(doc, bin_chunk, index):
    """An accessor of 32-bit floats, flat (the keyframe times a Sinew export writes)."""
    a = doc["accessors"][index]
    if a["componentType"] != 5126:
        fail(f"accessor {index}: not 32-bit floats")
    view = doc["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[a["type"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    return np.frombuffer(bin_chunk, dtype="<f4", count=a["count"] * width, offset=start)


def node_matrix(node):
    """A glTF node's local matrix (row-major numpy), from `matrix` or its TRS."""
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    s = np.array(node.get("scale", [1.0, 1.0, 1.0]))
    m = np.eye(4)
    m[:3, :3] = r * s
    m[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return m


def above_skeleton(doc, face_node):
    """The scene transform of the parent of the face's first joint (a rig's node transform)."""
    skin = doc["skins"][doc["nodes"][face_node]["skin"]]
    parent = {c: i for i, n in enumerate(doc["nodes"]) for c in n.get("children", [])}
    m = np.eye(4)
    at = parent.get(skin["joints"][0])
    for _ in range(len(doc["nodes"])):
        if at is None:
            break
        m = node_matrix(doc["nodes"][at]) @ m
        at = parent.get(at)
    return m


def read_obj(path):
    """One OBJ frame: positions and the corners of its polygons, fan-triangulated as Sinew does."""
    positions, corners = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                positions.append([float(p[1]), float(p[2]), float(p[3])])
            elif p[0] == "f":
                poly = [int(c.split("/")[0]) - 1 for c in p[1:]]
                for k in range(1, len(poly) - 1):
                    corners.extend([poly[0], poly[k], poly[k + 1]])
    return np.array(positions, dtype=np.float64), np.array(corners, dtype=np.int64)


def world_vertices(rest):
    """Each mesh object's evaluated vertices in Blender's world, by object name; with `rest`, every
    armature in its rest position."""
    if rest:
        for o in bpy.context.scene.objects:
            if o.type == "ARMATURE":
                o.data.pose_position = "REST"
    depsgraph = bpy.context.evaluated_depsgraph_get()
    out = {}
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            continue
        evaluated = o.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        co = np.zeros(3 * len(mesh.vertices), dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
        m = np.array(evaluated.matrix_world, dtype=np.float64)
        evaluated.to_mesh_clear()
        out[o.name] = co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    return out


def import_glb(path):
    """A fresh scene holding the .glb, imported by Blender's glTF importer."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        result = bpy.ops.import_scene.gltf(filepath=os.path.abspath(path))
    except RuntimeError as e:
        fail(f"{path}: Blender cannot import it: {e}")
    if "FINISHED" not in result:
        fail(f"{path}: Blender's importer returned {result}")


def carried_in_place(glb, original, face):
    """The largest distance (mm) of a carried mesh's vertex from where the original has it, and
    the meshes compared; the export's armature at rest. Leaves the original's scene loaded."""
    exported = world_vertices(rest=True)
    import_glb(original)
    before = world_vertices(rest=False)
    names, far = [], (0.0, "", 0)
    for name, p in before.items():
        if name == face or name not in exported:
            continue
        q = exported[name]
        if q.shape != p.shape:
            fail(f"{glb}: {name} has {len(q)} vertices, {original} {len(p)}")
        d = np.linalg.norm(p - q, axis=1) * 1000.0
        i = int(np.argmax(d)) if len(d) else 0
        if len(d) and not d[i] <= far[0]:
            far = (float(d[i]), name, i)
        names.append(name)
    if not names:
        fail(f"{glb}: carries no mesh of {original}")
    return far, names


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--glb", required=True)
    parser.add_argument("--frames", required=True)
    parser.add_argument("--obj-unit", type=float, required=True)
    parser.add_argument("--tolerance-mm", type=float, default=0.01)
    parser.add_argument("--original")
    args = parser.parse_args(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else None)
    if not (args.obj_unit > 0 and args.tolerance_mm > 0):
        fail("--obj-unit and --tolerance-mm must be positive numbers")

    doc, bin_chunk = read_glb(args.glb)
    face_nodes = [i for i, n in enumerate(doc.get("nodes", [])) if n.get("name") == "face" and "skin" in n]
    if not face_nodes:
        fail(f"{args.glb}: no skinned node \"face\"")
    face_node = face_nodes[0]
    face_mesh_name = doc["meshes"][doc["nodes"][face_node]["mesh"]].get("name", "face")
    animations = doc.get("animations", [])
    if len(animations) != 1:
        fail(f"{args.glb}: {len(animations)} animations, expected 1")
    times = accessor_floats(doc, bin_chunk, animations[0]["samplers"][0]["input"])
    to_mesh_frame = np.linalg.inv(above_skeleton(doc, face_node))

    names = sorted(n for n in os.listdir(args.frames) if re.fullmatch(r"frame_\d+\.obj", n))
    if not names:
        fail(f"{args.frames}: no frame_NNNNN.obj files")
    if len(times) not in (len(names), len(names) + 1):
        fail(f"{args.glb}: {len(times)} keyframes for {len(names)} frames in {args.frames}")
    frames = [read_obj(os.path.join(args.frames, n)) for n in names]
    corners = frames[0][1]

    import_glb(args.glb)
    scene = bpy.context.scene
    meshes = [
        o
        for o in scene.objects
        if o.type == "MESH" and o.data.name == face_mesh_name and any(m.type == "ARMATURE" for m in o.modifiers)
    ]
    if len(meshes) != 1:
        fail(f"{args.glb}: {len(meshes)} skinned mesh objects of mesh \"{face_mesh_name}\" in Blender")
    face = meshes[0]
    me = face.data
    if me.shape_keys is None:
        fail(f"{args.glb}: Blender imported no shape keys")

    # Blender vertex -> OBJ vertex, by corner.
    loops = np.zeros(len(me.loops), dtype=np.int64)
    me.loops.foreach_get("vertex_index", loops)
    sizes = np.zeros(len(me.polygons), dtype=np.int64)
    me.polygons.foreach_get("loop_total", sizes)
    if np.any(sizes != 3) or len(loops) != len(corners):
        fail(f"{args.glb}: Blender has {len(me.polygons)} polygons ({len(loops)} corners), the OBJ frames {len(corners) // 3} triangles")
    count = len(me.vertices)
    source = np.full(count, -1, dtype=np.int64)
    for k in range(len(loops)):
        i = loops[k]
        if source[i] != -1 and source[i] != corners[k]:
            fail(f"{args.glb}: Blender vertex {i} is OBJ vertex {source[i]} and {corners[k]}")
        source[i] = corners[k]
    used = source >= 0

    # glTF's +Y up from Blender's +Z up (the importer's conversion undone), then the mesh frame.
    z_to_y = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)
    fps = scene.render.fps / scene.render.fps_base
    worst = (0.0, 0, 0)
    co = np.zeros(3 * count, dtype=np.float32)
    for key, t in enumerate(times):
        frame = float(t) * fps
        whole = math.floor(frame)
        scene.frame_set(whole, subframe=frame - whole)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        evaluated = face.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        if len(mesh.vertices) != count:
            fail(f"{args.glb}: the evaluated mesh has {len(mesh.vertices)} vertices, the mesh {count}")
        mesh.vertices.foreach_get("co", co)
        world = np.array(evaluated.matrix_world, dtype=np.float64)
        evaluated.to_mesh_clear()
        m = to_mesh_frame @ z_to_y @ world
        p = co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        obj = frames[key % len(frames)][0]
        d = np.linalg.norm(p[used] / args.obj_unit - obj[source[used]], axis=1) * args.obj_unit * 1000.0
        i = int(np.argmax(d))
        if not d[i] <= worst[0]:
            worst = (float(d[i]), key, int(np.flatnonzero(used)[i]))
    carried = ""
    if args.original:
        far, carried_names = carried_in_place(args.glb, args.original, face.name)
        if far[0] > worst[0]:
            worst = (far[0], "rest", f"{far[1]} {far[2]}")
        carried = f"; carried {', '.join(carried_names)} where {args.original} has them within {far[0]:.2e} mm"
    mm, key, vertex = worst
    within = mm <= args.tolerance_mm
    print(
        f"{args.glb}: Blender {bpy.app.version_string}, {len(times)} keyframes of {count} vertices against "
        f"{args.frames}: max {mm:.2e} mm (keyframe {key}, vertex {vertex}); "
        f"tolerance {args.tolerance_mm} mm{carried}: {'ok' if within else 'FAILED'}"
    )
    sys.exit(0 if within else 1)


if __name__ == "__main__":
    main()
