#!/usr/bin/env python3
"""Convert a Mafia `.4ds` model (version 0x1D, as used by the LPV thesis at
github.com/djbozkosz/Light-Propagation-Volumes) to Wavefront OBJ + MTL and a TOML scene file.

    python3 tools/convert_4ds.py --git-dir /work/.mirror/djbozkosz+Light-Propagation-Volumes/repo \\
        --model data/models/sibenik.4ds --out /tmp/sibenik
    target/release/scene --scene /tmp/sibenik/sibenik.toml

The model and its diffuse and alpha maps (data/maps/, matched case-insensitively, kept as BMP) are read
from the thesis repository with `git show REV:PATH`. Writes OUT/STEM.obj, .mtl, .toml and the maps; the
scene file has the thesis' sun, and for sibenik.4ds the thesis' camera (a key of its Sibenik fly-through;
other models get the engine's framed default). Standard library only. Bad or unsupported input is one
line on stderr naming the file and the problem, exit code 2.

Coordinates: 4DS is left-handed, Y up; OBJ is right-handed, Y up. Z is negated for positions, normals,
the camera and the sun, and the winding is reversed so faces stay front-facing. 4DS texture v runs down
from the image's top row (the thesis uploads rows top-down and samples v as stored), so vt = 1 - v.
"""
import argparse
import math
import struct
import subprocess
import sys
from pathlib import Path

# Material flags and mesh / visual types (thesis src/headers/modelTypes.h).
MAT_ENV, MAT_ANIMATED, MAT_COLOR_KEY, MAT_ALPHA = 0x00080000, 0x04000000, 0x20000000, 0x40000000
STANDARD, SECTOR, DUMMY, TARGET, BONE = 0x01, 0x05, 0x06, 0x07, 0x0A
VIS_STANDARD, SINGLE_MESH, SINGLE_MORPH, BILLBOARD, MORPH, GLOW, MIRROR = 0x00, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08
WITH_GEOMETRY = (VIS_STANDARD, SINGLE_MESH, SINGLE_MORPH, BILLBOARD, MORPH)

# The thesis' Sibenik fly-through (src/engine.cpp:372-396): position, (pitch, yaw) in degrees, Mafia
# space. Playback starts at key 1: Catmull-Rom over keys 0-3 at t = 0 is key 1 (src/window.cpp:334).
SIBENIK_TRACK = [((10.0, -0.7, 2.5), (-42.0, 112.0)), ((4.8, 1.0, 1.7), (-10.0, -107.0)),
                 ((-3.5, 3.1, 0.4), (-63.0, -114.0)), ((-10.4, 22.6, -0.5), (20.0, 67.0)),
                 ((-5.5, 7.5, 0.8), (19.0, 96.0)), ((9.0, 1.67, -5.27), (9.0, 1.0))]
FOV_Y, FAR = 60.0, 200.0  # cameraTypes.h:16 (glm::perspective's fovy), engine.cpp:260
# Sun (engine.cpp:277-282): elevation 0.91, azimuth 1.87 rad; colour (1.6, 1.35, 1.2) * 1.5, which the
# thesis multiplies with the texture without 1/pi, so our Lambertian irradiance is pi times it.
SUN_ELEVATION, SUN_AZIMUTH, SUN_COLOR, SUN_SCALE = 0.91, 1.87, (1.6, 1.35, 1.2), 1.5


class ConvertError(Exception):
    pass


class Reader:
    def __init__(self, data):
        self.data, self.pos = data, 0

    def take(self, n, what):
        if self.pos + n > len(self.data):
            raise ConvertError(f"truncated at byte {self.pos} reading {what} ({n} bytes, {len(self.data) - self.pos} left)")
        self.pos += n
        return self.data[self.pos - n:self.pos]

    def unpack(self, fmt, what):
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt), what))

    def one(self, fmt, what):
        return self.unpack(fmt, what)[0]

    def string(self, what):
        return self.take(self.one("B", what), what).decode("latin-1")


def read_material(r, i):
    flags = r.one("I", f"material {i} flags")
    _ambient, diffuse, _emission, (opacity,) = (r.unpack(f, f"material {i} colours") for f in ("3f", "3f", "3f", "f"))
    if flags & MAT_ENV:
        r.take(4, "environment ratio")
        r.string("environment map name")
    diffuse_map = r.string(f"material {i} diffuse map name")
    alpha_map = r.string("alpha map name") if flags & MAT_ALPHA and diffuse_map else ""  # models.cpp:130
    if flags & MAT_ANIMATED:
        r.take(18, "animated texture block")
    return dict(flags=flags, diffuse=diffuse, opacity=opacity, diffuse_map=diffuse_map, alpha_map=alpha_map)


def read_lods(r, name):
    """Standard-mesh LODs: LOD 0 as (vertices, [(indices, material)]) and the LOD count."""
    lod0, count = None, r.one("B", f"mesh {name} LOD count")
    for lod in range(count):
        nv = r.unpack("fH", "LOD header")[1]
        raw, groups = r.take(32 * nv, f"mesh {name} vertices"), []
        for _ in range(r.one("B", "face group count")):
            nf = r.one("H", "face count")
            groups.append((struct.unpack(f"<{3 * nf}H", r.take(6 * nf, f"mesh {name} faces")), r.one("H", "material")))
        if lod == 0:  # position, normal, uv
            lod0 = ([struct.unpack_from("<8f", raw, 32 * k) for k in range(nv)], groups)
    return lod0, count


def skip_skin(r, lods):
    for _ in range(lods):
        bones = r.one("B", "skin bone count")
        r.take(4 + 24, "skin LOD header")
        for _ in range(bones):
            weights = r.unpack("16f3I", "skin bone")[17]
            r.take(24 + 4 * weights, "skin bone weights")


def skip_morph(r):
    frames = r.one("B", "morph frame count")
    if frames:  # nothing else is stored without frames (models.cpp:401)
        for _ in range(r.unpack("2B", "morph header")[0]):
            nv = r.one("H", "morph vertex count")
            if nv:
                r.take(24 * frames * nv + 1 + 2 * nv, "morph vertices")
        r.take(24 + 16, "morph bounds")


def skip_sector(r):
    nv, nf = r.unpack("4I", "sector header")[2:]
    r.take(12 * nv + 6 * nf + 24, "sector geometry")
    for _ in range(r.one("B", "portal count")):
        r.take(4 + 24 + 12 * r.one("B", "portal vertex count"), "portal")


def read_mesh(r, index):
    kind, visual = r.one("B", f"mesh {index} type"), None
    if kind not in (STANDARD, SECTOR, DUMMY, TARGET, BONE):
        raise ConvertError(f"mesh {index}: unsupported mesh type 0x{kind:02x}")
    if kind == STANDARD:
        visual = r.unpack("BH", "visual type, render flags")[0]
        if visual not in WITH_GEOMETRY + (GLOW, MIRROR):
            raise ConvertError(f"mesh {index}: unsupported visual type 0x{visual:02x}")
    link, *values = r.unpack("H10fB", f"mesh {index} transform")
    mesh = dict(link=link, position=values[0:3], scale=values[3:6], rotation=values[6:10],  # w, x, y, z
                name=r.string(f"mesh {index} name"), lod0=None, instance=0)
    r.string("mesh parameters")
    if visual in WITH_GEOMETRY:
        mesh["instance"] = r.one("H", "instance index")
        lods = 0
        if not mesh["instance"]:  # an instance has no geometry of its own
            mesh["lod0"], lods = read_lods(r, mesh["name"])
        if visual in (SINGLE_MESH, SINGLE_MORPH):
            skip_skin(r, lods)
        if visual in (SINGLE_MORPH, MORPH):
            skip_morph(r)
        if visual == BILLBOARD:
            r.take(5, "billboard axis")
    elif visual == GLOW:
        r.take(6 * r.one("B", "flare count"), "glow flares")
    elif visual == MIRROR:
        nv, nf = r.unpack("30f2I", "mirror header")[30:]
        r.take(12 * nv + 6 * nf, "mirror geometry")
    elif kind == SECTOR:
        skip_sector(r)
    elif kind == DUMMY:
        r.take(24, "dummy bounds")
    elif kind == TARGET:
        r.take(2 * r.unpack("HB", "target header")[1], "targets")
    elif kind == BONE:
        r.take(64 + 4, "bone")
    return mesh


def read_4ds(data):
    r = Reader(data)
    if r.take(4, "signature") != b"4DS\0":
        raise ConvertError("not a 4DS file (bad signature)")
    version = r.unpack("HQ", "version, timestamp")[0]
    if version != 0x1D:
        raise ConvertError(f"unsupported 4DS version 0x{version:x} (only 0x1d, Mafia PC)")
    materials = [read_material(r, i + 1) for i in range(r.one("H", "material count"))]
    meshes = [read_mesh(r, i + 1) for i in range(r.one("H", "mesh count"))]
    r.one("B", "allowAnimation")
    if any(data[r.pos:]):  # some of the thesis' files end in a spare zero byte; its loader stops reading
        print(f"warning: {len(data) - r.pos} bytes after allowAnimation ignored", file=sys.stderr)
    return materials, meshes


def trs(m):
    """Row-major 3x4 T * R * S, the thesis' composeTransformation (headers/math.h)."""
    w, x, y, z = m["rotation"]
    rot = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
           [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
           [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    return [[rot[i][j] * m["scale"][j] for j in range(3)] + [m["position"][i]] for i in range(3)]


def world_transforms(meshes):
    """Links are 1-based (0: none); world = parent world * local in file order, as in CModel::update."""
    worlds = []
    for i, mesh in enumerate(meshes):
        local, link = trs(mesh), mesh["link"]
        if link > i:  # the thesis would use a parent it has not placed yet; Mafia files link backwards
            raise ConvertError(f"mesh `{mesh['name']}`: link index {link} is not an earlier mesh")
        p = worlds[link - 1] if link else None
        worlds.append([[sum(p[r][k] * local[k][c] for k in range(3)) + (p[r][3] if c == 3 else 0) for c in range(4)]
                       for r in range(3)] if p else local)
    return worlds


def cross(a, b, c):
    e, f = [b[k] - a[k] for k in range(3)], [c[k] - a[k] for k in range(3)]
    return [e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]]


def unit(v):
    length = math.sqrt(sum(c * c for c in v))
    return [c / length for c in v] if length > 1e-12 else None


def mesh_geometry(name, verts, groups, world, n_materials):
    """Output-space positions, normals and (a, b, c, material) faces of one placed LOD 0."""
    for faces, mat in groups:
        if mat > n_materials or max(faces, default=0) >= len(verts):
            raise ConvertError(f"mesh `{name}`: material {mat} (of {n_materials}) or vertex index "
                               f"{max(faces, default=0)} (of {len(verts)}) out of range")
    (a, b, c), (d, e, f), (g, h, i) = (row[:3] for row in world)
    # Normals take the inverse transpose (the thesis' mwnit): the cofactor matrix over the determinant.
    cof = [[e * i - f * h, f * g - d * i, d * h - e * g], [c * h - b * i, a * i - c * g, b * g - a * h],
           [b * f - c * e, c * d - a * f, a * e - b * d]]
    det = a * cof[0][0] + b * cof[0][1] + c * cof[0][2]
    flip = -1 if det < 0 else 1
    pos = [[sum(world[k][j] * v[j] for j in range(3)) + world[k][3] for k in range(3)] for v in verts]
    nrm = [unit([flip * sum(cof[k][j] * v[3 + j] for j in range(3)) for k in range(3)]) for v in verts]
    pos, nrm = [[x, y, -z] for x, y, z in pos], [n and [n[0], n[1], -n[2]] for n in nrm]
    # Flipping Z mirrors every triangle; a mirroring transform (det < 0) mirrors it back.
    order = (2, 1, 0) if det >= 0 else (0, 1, 2)
    faces = [tuple(t[3 * k + o] for o in order) + (mat,) for t, mat in groups for k in range(len(t) // 3)]
    fixed = 0
    for *tri, _ in faces:  # one zero normal would make the engine regenerate the whole mesh's normals
        for v in tri:
            if nrm[v] is None and unit(cross(*(pos[k] for k in tri))):
                nrm[v], fixed = unit(cross(*(pos[k] for k in tri))), fixed + 1
    return pos, [n or [0.0, 1.0, 0.0] for n in nrm], faces, fixed


def write_obj(out, stem, materials, meshes, maps):
    lines, lo, hi, base, tris, fixed, count = [f"mtllib {stem}.mtl"], [math.inf] * 3, [-math.inf] * 3, 1, 0, 0, 0
    for mesh, world in zip(meshes, world_transforms(meshes)):
        if mesh["instance"] > len(meshes):
            raise ConvertError(f"mesh `{mesh['name']}`: instance index {mesh['instance']} out of range")
        src = meshes[mesh["instance"] - 1] if mesh["instance"] else mesh
        if not src["lod0"] or not src["lod0"][0]:
            continue
        verts, groups = src["lod0"]
        pos, nrm, faces, n_fixed = mesh_geometry(mesh["name"], verts, groups, world, len(materials))
        lines.append("o " + ("_".join(mesh["name"].split()) or "mesh"))
        for p, n, v in zip(pos, nrm, verts):
            lines.append("v %.6f %.6f %.6f\nvt %.6f %.6f\nvn %.6f %.6f %.6f" % (*p, v[6], 1.0 - v[7], *n))
            lo, hi = [min(x, y) for x, y in zip(lo, p)], [max(x, y) for x, y in zip(hi, p)]
        current = None
        for a, b, c, mat in faces:
            if mat != current:
                lines.append("usemtl " + ("mat%02d" % mat if mat else "none"))
                current = mat
            lines.append("f %d/%d/%d %d/%d/%d %d/%d/%d" % ((a + base,) * 3 + (b + base,) * 3 + (c + base,) * 3))
        base, tris, fixed, count = base + len(verts), tris + len(faces), fixed + n_fixed, count + 1
    if not tris:
        raise ConvertError("the model has no triangles")
    (out / f"{stem}.obj").write_text("\n".join(lines) + "\n")
    mtl = ["newmtl none\nKd 0.7 0.7 0.7"]
    for i, m in enumerate(materials, 1):
        diffuse, alpha = maps.get(m["diffuse_map"].lower()), maps.get(m["alpha_map"].lower())
        # The thesis' shader never reads colorDiffuse, only the texture, so textured materials are white.
        kd = (1.0, 1.0, 1.0) if diffuse else m["diffuse"]
        mtl.append("newmtl mat%02d\nKd %.4f %.4f %.4f\nd %.4f" % (i, *kd, min(max(m["opacity"], 0.0), 1.0)))
        mtl += [f"map_Kd {diffuse}"] * bool(diffuse) + [f"map_d {alpha}"] * bool(alpha)
    (out / f"{stem}.mtl").write_text("\n".join(mtl) + "\n")
    return count, tris, (lo, hi), fixed


def git(git_dir, *args):
    p = subprocess.run(["git", "--git-dir", str(git_dir), *args], capture_output=True)
    return p.stdout if p.returncode == 0 else None


def copy_maps(git_dir, rev, out, materials):
    listing = (git(git_dir, "ls-tree", "--name-only", f"{rev}:data/maps") or b"").decode("latin-1")
    available, copied = {n.lower(): n for n in listing.splitlines()}, {}
    for want in sorted({m[k] for m in materials for k in ("diffuse_map", "alpha_map") if m[k]}):
        found = available.get(want.replace("\\", "/").rsplit("/", 1)[-1].lower())
        data = git(git_dir, "show", f"{rev}:data/maps/{found}") if found else None
        if data is None:
            print(f"warning: map {want} is not in {rev}:data/maps; left out", file=sys.stderr)
            continue
        (out / found).write_bytes(data)
        copied[want.lower()] = found
    return copied


def sun_direction():
    """The direction sunlight travels; the same angles aim the thesis' shadow camera (window.cpp:386)."""
    el, az = SUN_ELEVATION, SUN_AZIMUTH
    to_sun = (math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el))  # engine.cpp:1025
    return (-to_sun[0], -to_sun[1], to_sun[2])  # away from the sun, then Z flipped


def track_camera(key):
    """A track key as position and target. The thesis' view is Rx(pitch) Ry(yaw + 180) S(-1, 1, 1) T(-p)
    (camera.h:51-57); with Z flipped instead of X that is a plain camera looking along `forward`."""
    (x, y, z), (pitch, yaw) = SIBENIK_TRACK[key]
    p, w = math.radians(pitch), math.radians(yaw)
    forward = (math.cos(p) * math.sin(w), -math.sin(p), -math.cos(p) * math.cos(w))
    return (x, y, -z), (x + forward[0], y + forward[1], -z + forward[2])


def fmt(v):
    return "[" + ", ".join("%.4f" % c for c in v) + "]"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--git-dir", required=True, type=Path, help="the thesis repository's git directory")
    ap.add_argument("--model", required=True, help="path in the repository, e.g. data/models/sibenik.4ds")
    ap.add_argument("--out", required=True, type=Path, help="output directory")
    ap.add_argument("--rev", default="HEAD", help="git revision (default HEAD)")
    ap.add_argument("--view", type=int, default=1, choices=range(len(SIBENIK_TRACK)),
                    help="Sibenik fly-through key for the camera (default 1, where playback starts)")
    args = ap.parse_args()
    where, stem = f"{args.git_dir}:{args.rev}:{args.model}", Path(args.model).stem.lower()
    try:
        data = git(args.git_dir, "show", f"{args.rev}:{args.model}")
        if data is None:
            raise ConvertError("not found (git show failed)")
        materials, meshes = read_4ds(data)
        args.out.mkdir(parents=True, exist_ok=True)
        maps = copy_maps(args.git_dir, args.rev, args.out, materials)
        count, tris, (lo, hi), fixed = write_obj(args.out, stem, materials, meshes, maps)
    except (ConvertError, OSError) as e:
        print(f"{where}: {e}", file=sys.stderr)
        return 2
    keyed = [i for i, m in enumerate(materials, 1) if m["flags"] & MAT_COLOR_KEY]
    if keyed:  # MTL has no colour key (the thesis discards texels of the key colour)
        print(f"warning: colour-keyed materials {keyed} are written opaque", file=sys.stderr)
    lum = 0.2126 * SUN_COLOR[0] + 0.7152 * SUN_COLOR[1] + 0.0722 * SUN_COLOR[2]
    color, intensity, sun = [c / lum for c in SUN_COLOR], math.pi * SUN_SCALE * lum, sun_direction()
    toml = [f"# {args.model} of the LPV thesis, converted by tools/convert_4ds.py", f'model = "{stem}.obj"']
    camera = track_camera(args.view) if stem == "sibenik" else None
    if camera:  # near: the thesis has 0.01; 0.05 spends less depth precision and clips nothing here
        toml += [f"# Sibenik fly-through key {args.view} (thesis src/engine.cpp:372-396)", "[camera]",
                 f"position = {fmt(camera[0])}", f"target = {fmt(camera[1])}", f"fov = {FOV_Y}", "near = 0.05",
                 f"far = {FAR}"]
    toml += ["# The thesis' sun (src/engine.cpp:277-282)", "[[lights]]", 'type = "directional"',
             f"direction = {fmt(sun)}", f"color = {fmt(color)}", "intensity = %.4f" % intensity]
    (args.out / f"{stem}.toml").write_text("\n".join(toml) + "\n")
    print(f"{where}: {count} meshes, {tris} triangles, {len(materials)} materials, {len(maps)} maps\n"
          f"  bounds {fmt(lo)} .. {fmt(hi)} (output space: right-handed, Y up)")
    if fixed:
        print(f"  {fixed} zero normals replaced by face normals")
    if camera:
        print(f"  camera {fmt(camera[0])} -> {fmt(camera[1])}, fov {FOV_Y}")
    print(f"  sun direction {fmt(sun)}, color {fmt(color)}, intensity {intensity:.4f}\n"
          f"  wrote {args.out / stem}.obj, .mtl, .toml")
    return 0


if __name__ == "__main__":
    sys.exit(main())
