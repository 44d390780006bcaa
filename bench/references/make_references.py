#!/usr/bin/env python3
"""Independent reference illuminance for luxbake's built-in scenes, computed with Radiance.

luxbake's accuracy is measured against values it did not compute: this script exports a
built-in scene with `cargo xtask export-scene`, converts the glTF to a Radiance scene
description, picks calculation points on every kind of surface, and runs `rtrace -I` (irradiance
at a point with a given normal) with settings for a converged diffuse inter-reflection solution:
no ambient cache, many bounces, thousands of hemisphere samples. The result is
`bench/references/<scene>.csv`, which `cargo xtask bench refcheck` and `cargo xtask bench trade`
compare bakes against. CI never runs this script (it needs Radiance); the CSVs are committed.

Requirements (not part of the repository, not needed by CI):
    python3 -m venv /tmp/radiance-venv
    /tmp/radiance-venv/bin/pip install pyradiance==1.3.1 numpy   # Radiance 6.0a binaries
    /tmp/radiance-venv/bin/python bench/references/make_references.py

Conventions (see README.md beside this file for the full story):
- luxbake world: metres, right-handed, +Y up. Radiance world here: (X, Y, Z) = (x, -z, y), a
  proper rotation (Z up), so the luminaire that `ies2rad` writes (nadir -Z, C0 +X, C90 +Y) is,
  untransformed, exactly luxbake's default lamp frame (nadir -y, C0 +x, C90 -z). Lamps with a
  non-default `aim` or `rotationDeg` are refused.
- Materials: `plastic` with the object's linear RGB albedo (glTF baseColorFactor times the mean
  vertex COLOR_0 of the triangle), specularity 0, roughness 0: Lambertian, as luxbake.
- Lamps: `ies2rad -dm -i 0.005 -c R G B -m MULT`: an `illum` sphere of 5 mm radius (a point
  source for every point more than a few cm away, like luxbake's point lamps; the IES file's
  150 mm disk opening is not used), intensity = candela x multiplier. Isotropic lamps (the
  `floor` and `sphere` scenes) become a 5 mm `illum` sphere of radiance I / (179 pi r^2).
- Lux: Radiance irradiance per channel (W/m^2 in its 179 lm/W convention) times 179, then the
  Rec. 709 luminance Y = 0.2126 R + 0.7152 G + 0.0722 B, the weighting `cargo xtask measure`
  applies to luxbake's maps (the lamps are white, so direct light has R = G = B; Radiance's own
  0.265/0.670/0.065 weighting differs only on coloured inter-reflections, see the README).

Cost on the 2-core development machine (shared, niced): about 5 to 6 minutes of rtrace per
furnished scene, 21 minutes for all five scenes, 9 minutes for `validate`.

Sub-commands:
    scenes       (default) write <scene>.csv for the scenes given (--scenes): built-in names,
                 or scene files (a path ending in .toml, <stem>.csv) whose lamps are IES files
                 (bench/scenes/real_*.toml: each file through ies2rad as the downlight's);
                 --trace-offset: traced that far off the surface (the rows stay 1 mm off)
    validate     direct-only check (inverse-square-cosine law with the IES intensity), the CIE
                 171:2006 closed box (test case 5.8) and the convergence check; writes
                 validation.json
    nearfield    direct light of the lamps' luminous openings (ies2rad without -i) and of the
                 point model in the rooms bench/scenes/nearfield_*.toml: nearfield_<room>.csv,
                 nearfield.json; and the method against closed forms: nearfield_validation.json
                 (about 6 minutes)
    retrace      the points of an existing <scene>.csv (--from) with less total light than
                 --dark-below lux traced again with --ad-dark hemisphere samples, written with
                 the other rows unchanged to <out>/<scene>.csv: points in a gap (under a sofa)
                 see the lit room through a narrow slit of their hemisphere, so their noise at
                 -ad 4096 is tens of per cent (--scenes: one scene; --surface: of one kind only;
                 --trace-offset: traced that far off the surface instead of at the rows' 1 mm)
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
DOWNLIGHT_IES = REPO / "crates" / "scene" / "lamps" / "luxbake_downlight.ies"
EFFICACY = 179.0  # Radiance's luminous efficacy of white light, lm/W
REC709 = np.array([0.2126, 0.7152, 0.0722])
RADIANCE_Y = np.array([0.265, 0.670, 0.065])
LAMP_RADIUS = 0.005  # m, radius of the illum sphere standing in for a point lamp
OFFSET = 0.001  # m, calculation points sit this far off the surface along its normal

# Reference rtrace settings: no ambient cache (-aa 0, so -ar/-as/-ac do not matter), 20 ambient
# bounces (mean reflectance of the rooms ~0.65: 0.65^20 = 2e-4 of the inter-reflected light is
# cut off), 4096 hemisphere samples at the point itself (deeper bounces take one path each:
# with -aa 0, Radiance sizes the sample count by the ray weight), no weight cut-off to speak of,
# zero ambient value. Direct: every source sampled every time (-dt 0 -dc 1), no jitter or
# subdivision of the 5 mm lamp sphere. -lr 1000: Radiance's default -lr -10 ends paths by
# Russian roulette after 10 reflections, which lost 10 % of the indirect light in the closed box
# at rho = 0.8; with a hard limit far above -ab, -ab alone decides the bounces.
REFERENCE = {"ab": 20, "ad": 4096, "lw": 1e-9}
COMMON = ["-aa", "0", "-av", "0", "0", "0", "-dt", "0", "-dc", "1", "-dj", "0", "-ds", "0",
          "-dr", "0", "-st", "1", "-ss", "0", "-lr", "1000", "-u+"]

# Points per surface kind of the furnished scenes; furniture split by facing (seat tops,
# backs and sides, undersides), so that the chair backs are not left out for their small area.
COUNTS = {"floor": 90, "wall": 90, "ceiling": 40, "furniture/up": 40, "furniture/side": 40,
          "furniture/down": 20}
MARGIN_ROOM = 0.05  # m, least distance of a room point from any other surface or face edge
MARGIN_FURNITURE = 0.02  # m, the same on furniture (chair parts are 3.5 to 45 cm wide)


# ---------------------------------------------------------------------------------------------
# Radiance


def radiance_env() -> dict:
    """Environment with pyradiance's bundled Radiance binaries and library on the path."""
    try:
        import pyradiance  # noqa: F401  (only for its location)
    except ImportError:
        sys.exit("error: pyradiance is not installed (pip install pyradiance numpy)")
    base = Path(sys.modules["pyradiance"].__file__).resolve().parent
    env = dict(os.environ)
    env["PATH"] = f"{base / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["RAYPATH"] = f".{os.pathsep}{base / 'lib'}"
    return env


def radiance_version(env: dict) -> str:
    out = subprocess.run(["rtrace", "-version"], env=env, capture_output=True, text=True)
    return out.stdout.strip()


def rtrace(octree: Path, rays: np.ndarray, ab: int, ad: int, lw: float, env: dict,
           cwd: Path) -> np.ndarray:
    """Irradiance (W/m^2, RGB) of `rtrace -I` at rows `x y z nx ny nz` (Radiance frame)."""
    args = ["-ab", str(ab), "-ad", str(ad), "-lw", f"{lw:g}", *COMMON]
    return run_rtrace(args, octree, rays, env, cwd)


def run_rtrace(args: list, octree: Path, rays: np.ndarray, env: dict, cwd: Path) -> np.ndarray:
    """The RGB rows of `rtrace -I -h <args> <octree>` (niced) at the rows of `rays`."""
    text = "".join(" ".join(f"{v:.6f}" for v in r) + "\n" for r in rays)
    out = subprocess.run(["nice", "-n", "10", "rtrace", "-I", "-h", *args, str(octree)],
                         input=text, env=env, cwd=cwd, capture_output=True, text=True, check=True)
    vals = np.array([[float(v) for v in line.split()] for line in out.stdout.splitlines()
                     if line.strip()])
    if vals.shape != (len(rays), 3):
        raise RuntimeError(f"rtrace returned {vals.shape} for {len(rays)} rays: {out.stderr}")
    return vals


def to_rad(p: np.ndarray) -> np.ndarray:
    """luxbake world (y up) -> Radiance world (z up): (x, y, z) -> (x, -z, y)."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


# ---------------------------------------------------------------------------------------------
# glTF


COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
             5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_glb(path: Path):
    data = path.read_bytes()
    magic, _version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF":
        raise ValueError(f"{path}: not a .glb")
    off, chunks = 12, {}
    while off < length:
        size, kind = struct.unpack_from("<I4s", data, off)
        chunks[kind] = data[off + 8: off + 8 + size]
        off += 8 + size
    return json.loads(chunks[b"JSON"]), chunks.get(b"BIN\x00", b"")


def accessor(gltf, binary, index) -> np.ndarray:
    a = gltf["accessors"][index]
    view = gltf["bufferViews"][a["bufferView"]]
    dtype = np.dtype(COMPONENT[a["componentType"]])
    width = WIDTH[a["type"]]
    stride = view.get("byteStride") or dtype.itemsize * width
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    arr = np.ndarray((a["count"], width), dtype=dtype, buffer=binary, offset=start,
                     strides=(stride, dtype.itemsize)).copy()
    if a.get("normalized"):
        return arr.astype(np.float64) / np.iinfo(dtype).max
    return arr


def load_scene(glb: Path) -> dict:
    """World triangles (luxbake frame), per-triangle normal, albedo and object; the lamps."""
    gltf, binary = read_glb(glb)
    tris, normals, albedo, objects, names = [], [], [], [], []

    def visit(node_index, parent):
        node = gltf["nodes"][node_index]
        m = np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T if "matrix" in node \
            else np.eye(4)
        if "matrix" not in node and any(k in node for k in ("rotation", "scale")):
            raise ValueError("TRS nodes with rotation/scale are not supported")
        if "translation" in node:
            m[:3, 3] += node["translation"]
        world = parent @ m
        if "mesh" in node:
            obj = len(names)
            names.append(node.get("name", f"object_{obj}"))
            receiver = node.get("extras", {}).get("luxbake", {}).get("receiver", True)
            for prim in gltf["meshes"][node["mesh"]]["primitives"]:
                if prim.get("mode", 4) != 4:
                    raise ValueError("only triangle primitives")
                attrs = prim["attributes"]
                pos = accessor(gltf, binary, attrs["POSITION"]).astype(np.float64)
                nrm = accessor(gltf, binary, attrs["NORMAL"]).astype(np.float64)
                idx = accessor(gltf, binary, prim["indices"]).reshape(-1, 3).astype(np.int64)
                mat = gltf["materials"][prim["material"]]
                pbr = mat.get("pbrMetallicRoughness", {})
                if "baseColorTexture" in pbr:
                    raise ValueError(f"{names[-1]}: albedo textures are not supported")
                factor = np.array(pbr.get("baseColorFactor", [1, 1, 1, 1])[:3], dtype=np.float64)
                if "COLOR_0" in attrs:
                    col = accessor(gltf, binary, attrs["COLOR_0"]).astype(np.float64)[:, :3]
                    tri_col = col[idx].mean(axis=1) * factor
                else:
                    tri_col = np.tile(factor, (len(idx), 1))
                wp = pos @ world[:3, :3].T + world[:3, 3]
                nm = np.linalg.inv(world[:3, :3]).T
                wn = nrm @ nm.T
                t = wp[idx]
                n = wn[idx].mean(axis=1)
                n /= np.linalg.norm(n, axis=1, keepdims=True)
                geo = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
                keep = np.linalg.norm(geo, axis=1) > 1e-12
                tris.append(t[keep])
                normals.append(n[keep])
                albedo.append(tri_col[keep])
                objects.append(np.full(int(keep.sum()), obj))
                if not receiver:
                    print(f"note: {names[-1]} is not a receiver (occluder only)")
        for child in node.get("children", []):
            visit(child, world)

    scene = gltf["scenes"][gltf.get("scene", 0)]
    for n in scene["nodes"]:
        visit(n, np.eye(4))
    lamps = scene.get("extras", {}).get("luxbake", {}).get("lamps", [])
    return {
        "lamp_positions": [np.array(lamp["position"], dtype=np.float64) for lamp in lamps],
        "tris": np.concatenate(tris),
        "normals": np.concatenate(normals),
        "albedo": np.concatenate(albedo),
        "object": np.concatenate(objects),
        "names": names,
        "lamps": lamps,
    }


# ---------------------------------------------------------------------------------------------
# Scene description


def lamp_rad(lamp: dict, index: int, workdir: Path, env: dict, files: dict) -> str:
    """Radiance text of one luxbake lamp (see the module docs)."""
    aim = np.array(lamp.get("aim", [0, -1, 0]), dtype=np.float64)
    aim_ok = np.linalg.norm(aim) > 0 and np.allclose(aim / np.linalg.norm(aim), [0, -1, 0])
    if not aim_ok or abs(lamp.get("rotationDeg", 0.0)) > 1e-9:
        raise NotImplementedError(f"lamp {lamp['name']}: only the default frame is converted")
    mult = float(lamp.get("multiplier", 1.0))
    color = [float(c) for c in lamp.get("color", [1, 1, 1])]
    x, y, z = to_rad(np.array(lamp["position"]))
    name = f"lamp{index}"
    # A scene file's lamp with a file of its own: that file as a point, like the downlight.
    source = files.get(lamp["name"]) or (DOWNLIGHT_IES if lamp["name"] == "downlight" else None)
    if source is not None:
        if source.suffix.lower() != ".ies":
            raise NotImplementedError(f"lamp {lamp['name']}: {source.name}: ies2rad reads IES only")
        shutil.copy(source, workdir / f"{name}.ies")
        subprocess.run(["ies2rad", "-dm", "-i", str(LAMP_RADIUS), "-c", *map(str, color),
                        "-m", str(mult), "-o", name, f"{name}.ies"],
                       cwd=workdir, env=env, check=True, capture_output=True)
        return f"!xform -n {name} -t {x:.6f} {y:.6f} {z:.6f} {name}.rad\n"
    if lamp["name"].startswith("isotropic"):
        candela = float(lamp["peakCandela"]) * mult
        radiance = candela / (EFFICACY * math.pi * LAMP_RADIUS ** 2)
        r, g, b = (radiance * c for c in color)
        return (f"void illum {name}_mat\n0\n0\n3 {r:.6g} {g:.6g} {b:.6g}\n\n"
                f"{name}_mat sphere {name}\n0\n0\n4 {x:.6f} {y:.6f} {z:.6f} {LAMP_RADIUS}\n\n")
    raise NotImplementedError(f"lamp {lamp['name']}: unknown photometry")


def write_scene(scene: dict, workdir: Path, env: dict) -> Path:
    """Writes scene.rad and scene.oct in `workdir`; returns the octree."""
    lines = []
    materials = {}
    for rgb in scene["albedo"]:
        key = tuple(np.round(rgb, 6))
        if key not in materials:
            materials[key] = f"mat{len(materials)}"
            lines.append(f"void plastic {materials[key]}\n0\n0\n5 {key[0]:.6f} {key[1]:.6f} "
                         f"{key[2]:.6f} 0 0\n")
    rad = to_rad(scene["tris"])
    for i, (t, rgb) in enumerate(zip(rad, scene["albedo"])):
        m = materials[tuple(np.round(rgb, 6))]
        coords = " ".join(f"{v:.7f}" for v in t.reshape(-1))
        lines.append(f"{m} polygon t{i}\n0\n0\n9 {coords}\n")
    for k, lamp in enumerate(scene["lamps"]):
        lines.append(lamp_rad(lamp, k, workdir, env, scene.get("lamp_files", {})))
    (workdir / "scene.rad").write_text("\n".join(lines))
    with open(workdir / "scene.oct", "wb") as f:
        subprocess.run(["oconv", "scene.rad"], cwd=workdir, env=env, stdout=f, check=True)
    return workdir / "scene.oct"


# ---------------------------------------------------------------------------------------------
# Geometry helpers for choosing points


def first_hits(scene: dict, origins: np.ndarray, dirs: np.ndarray):
    """Nearest triangle hit per ray (Moller-Trumbore): (t, triangle index), t = inf on a miss."""
    tri = scene["tris"]
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    best_t = np.full(len(origins), np.inf)
    best_i = np.full(len(origins), -1)
    for k, (o, d) in enumerate(zip(origins, dirs)):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-7)
        if hit.any():
            t = np.where(hit, t, np.inf)
            j = int(np.argmin(t))
            best_t[k], best_i[k] = t[j], j
    return best_t, best_i


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance from point `p` to every triangle of `tri` (n, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.linalg.norm(n, axis=1)
    n = n / nn[:, None]
    d_plane = np.einsum("ij,ij->i", p - a, n)
    q = p - d_plane[:, None] * n
    inside = np.ones(len(tri), dtype=bool)
    for x, y in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(y - x, q - x), n) >= 0
    dist = np.abs(d_plane)

    def seg(x, y):
        e = y - x
        t = np.clip(np.einsum("ij,ij->i", p - x, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        return np.linalg.norm(p - (x + t[:, None] * e), axis=1)

    edge = np.minimum(np.minimum(seg(a, b), seg(b, c)), seg(c, a))
    return np.where(inside, dist, edge)


def surface_kind(scene: dict, tri_index: int) -> str:
    name = scene["names"][scene["object"][tri_index]]
    ny = scene["normals"][tri_index][1]
    if name in ("room", "floor"):
        return "floor" if ny > 0.9 else "ceiling" if ny < -0.9 else "wall"
    if name == "sphere":
        return "sphere"
    return "furniture"


def hemisphere_dirs(n: np.ndarray, count: int, rng) -> np.ndarray:
    """The normal plus `count - 1` random directions within 70 degrees of it."""
    helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    dirs = [n]
    for _ in range(count - 1):
        th = math.radians(70) * math.sqrt(rng.random())
        ph = 2 * math.pi * rng.random()
        dirs.append(math.cos(th) * n + math.sin(th) * (math.cos(ph) * u + math.sin(ph) * v))
    return np.array(dirs)


def acceptable(scene: dict, ti: int, p: np.ndarray, margin: float, rng) -> bool:
    """Whether surface point `p` of triangle `ti` is an unambiguous calculation point."""
    tri, nrm, obj = scene["tris"], scene["normals"], scene["object"]
    n = nrm[ti]
    coplanar = (np.einsum("ij,j->i", nrm, n) > 1 - 1e-6) & \
        (np.abs(np.einsum("ij,j->i", tri[:, 0] - p, n)) < 1e-6) & (obj == obj[ti])
    # 1. Every other surface in front of or touching the plane is at least `margin` away
    #    (corners, touching or crossing parts); one wholly behind it (the far side of a thin
    #    board) only needs to be clearly farther than the point's 1 mm offset.
    others = ~coplanar
    behind = np.all(np.einsum("ijk,k->ij", tri - p, n) < -1e-4, axis=1)
    for group, least in ((others & ~behind, margin), (others & behind, 0.005)):
        if group.any() and point_triangle_distance(p, tri[group]).min() < least:
            return False
    # 2. The face extends at least `margin` around the point in every direction (open edges).
    helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    plane = tri[coplanar]
    for k in range(8):
        a = 2 * math.pi * k / 8
        q = p + margin * (math.cos(a) * u + math.sin(a) * v)
        if point_triangle_distance(q, plane).min() > 1e-6:
            return False
    # 3. Not inside a solid: rays from the point leave through front faces only.
    dirs = hemisphere_dirs(n, 6, rng)
    origins = np.repeat((p + OFFSET * n)[None], len(dirs), axis=0)
    t, idx = first_hits(scene, origins, dirs)
    for d, tt, j in zip(dirs, t, idx):
        if np.isfinite(tt) and np.dot(d, nrm[j]) > 0:
            return False
    # 4. Not near a hard shadow edge: every lamp is seen (or hidden) alike from the point and
    #    from the 8 points `margin` around it. luxbake's lamps are points, so their shadows
    #    are sharp, and a light map resolves a sharp edge only to its texel size and blur: a
    #    point a few mm inside a shadow reads as half lit (+400 % against the reference), which
    #    says nothing about the inter-reflections these references are for.
    ring = [p + OFFSET * n + margin * (math.cos(a) * u + math.sin(a) * v)
            for a in np.arange(8) * (2 * math.pi / 8)]
    probes = np.array([p + OFFSET * n, *ring])
    for lamp in scene["lamp_positions"]:
        to = lamp - probes
        dist = np.linalg.norm(to, axis=1)
        t, _ = first_hits(scene, probes, to / dist[:, None])
        seen = t > dist - 1e-3
        if seen.any() and not seen.all():
            return False
    return True


def margin_of(kind: str) -> float:
    """How far from a hard shadow edge a point of surface `kind` stays (`acceptable`)."""
    return MARGIN_ROOM if kind in ("floor", "wall", "ceiling") else MARGIN_FURNITURE


def stratified_points(scene: dict, counts: dict, rng, accept, per_point: int = 1):
    """Area-uniform random points per stratum of `counts` (a surface kind, or kind/facing:
    up, down or side by the normal), `per_point` times its count, at most 200 tries a point,
    that `accept(ti, p, margin_of(kind))`. Yields (stratum, count wanted, points got) per
    stratum with triangles and a count, a point being (p, normal, kind, object name)."""
    tri = scene["tris"]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    kinds = np.array([surface_kind(scene, i) for i in range(len(tri))])
    ny = scene["normals"][:, 1]
    facing = np.where(ny > 0.5, "up", np.where(ny < -0.5, "down", "side"))
    strata = np.char.add(np.char.add(kinds.astype(str), "/"), facing)
    for stratum, count in counts.items():
        kind = stratum.split("/")[0]
        pool = np.flatnonzero((kinds == stratum) | (strata == stratum))
        if len(pool) == 0 or count == 0:
            continue
        w = area[pool] / area[pool].sum()
        count *= per_point
        got, tries = [], 0
        while len(got) < count and tries < 200 * count:
            tries += 1
            ti = int(rng.choice(pool, p=w))
            r1, r2 = rng.random(), rng.random()
            if r1 + r2 > 1:
                r1, r2 = 1 - r1, 1 - r2
            t = tri[ti]
            p = t[0] + r1 * (t[1] - t[0]) + r2 * (t[2] - t[0])
            if accept(ti, p, margin_of(kind)):
                got.append((p, scene["normals"][ti], kind, scene["names"][scene["object"][ti]]))
        yield stratum, count, got


def choose_points(scene: dict, counts: dict, seed: int):
    """Area-uniform random points per surface kind that pass `acceptable`."""
    rng = np.random.default_rng(seed)
    chosen = []
    for stratum, count, got in stratified_points(
            scene, counts, rng, lambda ti, p, margin: acceptable(scene, ti, p, margin, rng)):
        chosen += got
        if len(got) < count:
            print(f"warning: only {len(got)} of {count} {stratum} points")
    return chosen


def sphere_points(scene: dict, count: int, seed: int):
    """Centroids of random triangles (the sphere has no flat face to keep off the edges of)."""
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(scene["tris"]), size=count, replace=False)
    return [(scene["tris"][i].mean(axis=0), scene["normals"][i], "sphere", "sphere")
            for i in sorted(picks)]


def floor_points(scene: dict, count: int, seed: int):
    """Random points of the `floor` scene's plane, at least 1 m inside its edges."""
    rng = np.random.default_rng(seed)
    half = np.abs(scene["tris"][:, :, 0]).max() - 1.0
    pts = []
    for _ in range(count):
        x, z = rng.uniform(-half, half, size=2)
        pts.append((np.array([x, 0.0, z]), np.array([0.0, 1.0, 0.0]), "floor", "floor"))
    return pts


# ---------------------------------------------------------------------------------------------
# Scenes


def export_glb(name: str, out: Path) -> None:
    # LUXBAKE_XTASK: a prebuilt xtask binary, for a tree that does not build at the moment.
    xtask = os.environ.get("LUXBAKE_XTASK")
    cmd = [xtask] if xtask else ["cargo", "xtask"]
    cmd += ["export-scene", name, str(out)]
    subprocess.run(["nice", "-n", "10", *cmd], cwd=REPO, check=True)


def points_for(name: str, scene: dict):
    if name == "sphere":
        return sphere_points(scene, 100, seed=1)
    if name == "floor":
        return floor_points(scene, 100, seed=1)
    return choose_points(scene, COUNTS, seed=sum(map(ord, name)))


def rays_of(points, offset: float = OFFSET) -> np.ndarray:
    p = np.array([q[0] + offset * q[1] for q in points])
    n = np.array([q[1] for q in points])
    return np.concatenate([to_rad(p), to_rad(n)], axis=1)


def lux(irradiance: np.ndarray) -> np.ndarray:
    """Per-channel lux (179 lm/W) of Radiance irradiance."""
    return EFFICACY * irradiance


def scene_stem(name: str) -> str:
    """The name a scene's files go by: a built-in's name, or a scene file's stem."""
    return Path(name).stem if name.endswith(".toml") else name


def lamp_files(name: str) -> dict:
    """Lamp name -> photometric file of a scene file's lamps that name one (none for a
    built-in, whose lamp is the built-in downlight)."""
    if not name.endswith(".toml"):
        return {}
    import tomllib
    path = Path(name).resolve()
    files = {}
    for i, lamp in enumerate(tomllib.loads(path.read_text()).get("lamp", [])):
        ies = lamp.get("ies", "builtin:downlight")
        if not ies.startswith(("builtin:", "isotropic:")):
            files[lamp.get("name", f"lamp_{i}")] = (path.parent / ies).resolve()
    return files


def build_scene(name: str, env: dict, workroot: Path):
    """Exports scene `name` (a built-in or a scene file) into `workroot/<stem>` and writes its
    Radiance scene there; returns the stem, the working folder, the scene and its octree."""
    stem = scene_stem(name)
    work = workroot / stem
    work.mkdir(parents=True, exist_ok=True)
    glb = work / f"{stem}.glb"
    export_glb(name, glb)
    scene = {**load_scene(glb), "lamp_files": lamp_files(name)}
    return stem, work, scene, write_scene(scene, work, env)


def make_scene(name: str, out_dir: Path, env: dict, workroot: Path, settings: dict) -> dict:
    stem, work, scene, octree = build_scene(name, env, workroot)
    t0 = time.time()
    points = points_for(stem, scene)
    t_points = time.time() - t0
    offset = settings.get("trace_offset")  # None: from the rows' 1 mm
    traced_at = OFFSET if offset is None else offset
    rays = rays_of(points, traced_at)
    t0 = time.time()
    direct = lux(rtrace(octree, rays, 0, settings["ad"], settings["lw"], env, work))
    total = lux(rtrace(octree, rays, settings["ab"], settings["ad"], settings["lw"], env, work))
    t_trace = time.time() - t0
    y_total, y_direct = total @ REC709, direct @ REC709
    path = out_dir / f"{stem}.csv"
    with open(path, "w") as f:
        what = f"scene file `{name}`" if name.endswith(".toml") else f"built-in scene `{name}`"
        f.write(f"# Radiance reference for the {what}: made by "
                f"make_references.py (see README.md)\n")
        f.write(f"# {radiance_version(env)}; rtrace -I -ab {settings['ab']} -ad {settings['ad']} "
                f"-lw {settings['lw']:g} {' '.join(COMMON)}\n")
        traced = ("" if offset is None else
                  f", traced {offset * 1000:g} mm off it (make_references.py --trace-offset)")
        f.write(f"# position 1 mm off the surface along the normal{traced}; lux = Rec. 709 Y "
                "of the RGB illuminance (179 lm/W); direct = -ab 0\n")
        f.write("x,y,z,nx,ny,nz,surface,object,lux,direct_lux,lux_r,lux_g,lux_b\n")
        for (p, n, kind, obj), yt, yd, rgb in zip(points, y_total, y_direct, total):
            q = p + OFFSET * n
            f.write(f"{q[0]:.4f},{q[1]:.4f},{q[2]:.4f},{n[0]:.5f},{n[1]:.5f},{n[2]:.5f},"
                    f"{kind},{obj},{yt:.3f},{yd:.3f},{rgb[0]:.3f},{rgb[1]:.3f},{rgb[2]:.3f}\n")
    kinds = {}
    for (_, _, kind, _), yt, yr in zip(points, y_total, total @ RADIANCE_Y):
        kinds.setdefault(kind, []).append((yt, yr))
    summary = {
        "points": len(points),
        "per_kind": {k: len(v) for k, v in kinds.items()},
        "mean_lux_per_kind": {k: float(np.mean([a for a, _ in v])) for k, v in kinds.items()},
        "radiance_weighting_vs_rec709_max_rel": float(
            np.max(np.abs(total @ RADIANCE_Y / np.maximum(y_total, 1e-9) - 1))),
        "seconds_points": round(t_points, 1),
        "seconds_rtrace": round(t_trace, 1),
        "trace_offset_m": traced_at,
        "triangles": int(len(scene["tris"])),
    }
    print(f"{name}: wrote {path} ({len(points)} points, rtrace {t_trace:.0f} s)")
    return summary


def surface_points(name: str, scene: dict, pos: np.ndarray, nrm: np.ndarray) -> np.ndarray:
    """The exact surface points (float64, before the 1 mm offset) of the CSV rows at `pos`
    (1 mm off, written to 0.1 mm) with normals `nrm`: the scene's points chosen again (the
    choice is seeded), matched to the rows. `retrace --trace-offset` traces from them: a point
    1 mm below a seat, 6 cm above its aprons' lower edges, sees a wider ring of the lit floor
    than the seat's surface does (+0.57 % of the first bounce at the undersides of `chairs_01`'s
    seat), and the CSV's 0.1 mm rounding is too coarse for a smaller offset."""
    exact = points_for(name, scene)
    p = np.array([q[0] for q in exact])
    n = np.array([q[1] for q in exact])
    out = []
    for x, m in zip(pos, nrm):
        d = np.linalg.norm(p + OFFSET * n - x, axis=1)
        i = int(np.argmin(d))
        if d[i] > 2e-4 or np.dot(n[i], m) < 1 - 1e-4:
            sys.exit(f"error: no chosen point of {name} at {x} (nearest {d[i] * 1000:.2f} mm)")
        out.append(p[i])
    return np.array(out)


def retrace_dark(name: str, source: Path, out_dir: Path, env: dict, workroot: Path,
                 settings: dict) -> dict:
    """`retrace`: the dark points of `source` traced again at settings["ad_dark"]."""
    stem, work, scene, octree = build_scene(name, env, workroot)
    lines = source.read_text().splitlines(keepends=True)
    header = [i for i, line in enumerate(lines) if line.startswith("x,y,z,")]
    if len(header) != 1:
        sys.exit(f"error: {source}: no single header row")
    cols = lines[header[0]].strip().split(",")
    rows = [(i, line.strip().split(",")) for i, line in enumerate(lines)
            if i > header[0] and line.strip() and not line.startswith("#")]
    of_kind = [(i, f) for i, f in rows
               if settings.get("surface") in (None, f[cols.index("surface")])]
    dark = [(i, f) for i, f in of_kind if float(f[cols.index("lux")]) < settings["dark_below"]]
    if not dark:
        sys.exit(f"error: {source}: no point under {settings['dark_below']:g} lx")
    pos = np.array([[float(f[cols.index(c)]) for c in "xyz"] for _, f in dark])
    nrm = np.array([[float(f[cols.index(c)]) for c in ("nx", "ny", "nz")] for _, f in dark])
    offset = settings.get("trace_offset")
    if offset is not None:
        pos = surface_points(stem, scene, pos, nrm) + offset * nrm
    rays = np.concatenate([to_rad(pos), to_rad(nrm)], axis=1)  # positions already 1 mm off
    t0 = time.time()
    total = lux(rtrace(octree, rays, settings["ab"], settings["ad_dark"], settings["lw"], env,
                       work))
    # Traced from elsewhere, the direct light is traced again there too (-ab 0).
    direct = None if offset is None else lux(
        rtrace(octree, rays, 0, settings["ad_dark"], settings["lw"], env, work)) @ REC709
    seconds = time.time() - t0
    y = total @ REC709
    changes = []
    for k, ((i, f), yt, rgb) in enumerate(zip(dark, y, total)):
        old = float(f[cols.index("lux")])
        changes.append((yt - old) / yt if yt > 0 else 0.0)
        f[cols.index("lux")] = f"{yt:.3f}"
        if direct is not None:
            f[cols.index("direct_lux")] = f"{direct[k]:.3f}"
        for c, v in zip(("lux_r", "lux_g", "lux_b"), rgb):
            f[cols.index(c)] = f"{v:.3f}"
        lines[i] = ",".join(f) + "\n"
    kind = f" {settings['surface']}" if settings.get("surface") else ""
    where = "" if offset is None else f" {offset * 1000:g} mm off their surfaces (not 1 mm)"
    under = "" if len(dark) == len(of_kind) else f" under {settings['dark_below']:g} lx"
    note = (f"# retrace: the {len(dark)}{kind} points{under} traced again "
            f"with -ad {settings['ad_dark']}{where} (make_references.py retrace --from "
            f"{source.name}); their lux, lux_r, lux_g, lux_b"
            f"{'' if offset is None else ', direct_lux'} are those\n")
    lines.insert(header[0], note)
    path = out_dir / f"{stem}.csv"
    path.write_text("".join(lines))
    print(f"{name}: wrote {path} ({len(dark)} points retraced, rtrace {seconds:.0f} s)")
    return {"source": str(source.name), "points": len(dark), "surface": settings.get("surface"),
            "trace_offset_m": offset,
            "dark_below_lux": settings["dark_below"], "ad_dark": settings["ad_dark"],
            "seconds_rtrace": round(seconds, 1),
            "mean_abs_change_of_old": float(np.mean(np.abs(changes))),
            "mean_change_of_old": float(np.mean(changes))}


# ---------------------------------------------------------------------------------------------
# Validation


def ies_table(path: Path):
    """(vertical angles, horizontal angles, candela[h][v]) of an LM-63 file with TILT=NONE."""
    text = path.read_text().splitlines()
    i = next(k for k, line in enumerate(text) if line.startswith("TILT="))
    nums = " ".join(text[i + 1:]).split()
    vals = [float(v) for v in nums]
    n_lamps, lumens, mult, nv, nh = vals[0], vals[1], vals[2], int(vals[3]), int(vals[4])
    rest = vals[13:]
    vert, horiz = np.array(rest[:nv]), np.array(rest[nv:nv + nh])
    cd = np.array(rest[nv + nh: nv + nh + nv * nh]).reshape(nh, nv) * mult
    return vert, horiz, cd


def ies_intensity(table, gamma_deg: float, c_deg: float) -> float:
    """Bilinear intensity (as luxbake-ies and Radiance's brightdata interpolate)."""
    vert, horiz, cd = table
    c = c_deg % 360.0
    if gamma_deg > vert[-1]:
        return 0.0
    row = [np.interp(gamma_deg, vert, cd[h]) for h in range(len(horiz))]
    return float(np.interp(c, horiz, row))


def direct_check(env: dict, workroot: Path) -> dict:
    """chairs_01, -ab 0: unoccluded room points against I(gamma, C) cos(theta) / d^2."""
    work = workroot / "direct"
    work.mkdir(parents=True, exist_ok=True)
    glb = work / "chairs_01.glb"
    export_glb("chairs_01", glb)
    scene = load_scene(glb)
    octree = write_scene(scene, work, env)
    lamp = np.array(scene["lamps"][0]["position"])
    table = ies_table(DOWNLIGHT_IES)
    rng = np.random.default_rng(7)
    pts, normals = [], []
    # Floor grid and the four walls below the lamp, kept off the corners.
    for x in np.linspace(-2.3, 2.3, 9):
        for z in np.linspace(-1.8, 1.8, 7):
            pts.append([x, 0.0, z])
            normals.append([0, 1.0, 0])
    for _ in range(40):
        side = rng.integers(4)
        h = rng.uniform(0.1, 2.0)
        if side < 2:
            x = 2.5 * (1 if side == 0 else -1)
            pts.append([x, h, rng.uniform(-1.8, 1.8)])
            normals.append([-np.sign(x), 0, 0])
        else:
            z = 2.0 * (1 if side == 2 else -1)
            pts.append([rng.uniform(-2.3, 2.3), h, z])
            normals.append([0, 0, -np.sign(z)])
    pts, normals = np.array(pts), np.array(normals)
    origins = pts + OFFSET * normals
    to_lamp = lamp - origins
    dist = np.linalg.norm(to_lamp, axis=1)
    dirs = to_lamp / dist[:, None]
    t, _ = first_hits(scene, origins, dirs)
    visible = t > dist - 0.01
    expected = []
    for o, d, r, n in zip(origins, dirs, dist, normals):
        w = -d  # lamp -> point, world
        gamma = math.degrees(math.acos(np.clip(-w[1], -1, 1)))  # from nadir (-y)
        c = math.degrees(math.atan2(-w[2], w[0]))  # C0 +x, C90 -z
        expected.append(ies_intensity(table, gamma, c) * max(np.dot(n, d), 0) / r ** 2)
    expected = np.array(expected)
    rays = np.concatenate([to_rad(origins), to_rad(normals)], axis=1)
    got = lux(rtrace(octree, rays, 0, 64, 1e-9, env, work)) @ REC709
    use = visible & (expected > 1.0)
    rel = got[use] / expected[use] - 1
    print(f"direct check: {use.sum()} unoccluded points, max |rel| {np.abs(rel).max():.4%}, "
          f"mean {rel.mean():+.4%}")
    return {"points": int(use.sum()), "max_abs_rel": float(np.abs(rel).max()),
            "mean_rel": float(rel.mean()), "lux_range": [float(expected[use].min()),
                                                         float(expected[use].max())],
            "worst": {"expected_lux": float(expected[use][np.argmax(np.abs(rel))]),
                      "radiance_lux": float(got[use][np.argmax(np.abs(rel))])}}


def closed_box(env: dict, workroot: Path, rho: float, ab: int, ad: int, grid: int) -> dict:
    """CIE 171:2006 test case 5.8: 4 m cube, 10 000 lm isotropic point source at the centre."""
    work = workroot / f"box_{rho}_{ab}"
    work.mkdir(parents=True, exist_ok=True)
    side, flux = 4.0, 10000.0
    candela = flux / (4 * math.pi)
    h = side / 2
    rad = [f"void plastic grey\n0\n0\n5 {rho} {rho} {rho} 0 0\n"]
    corners = {  # inward-facing faces (Radiance frame, z up)
        "floor": [(-h, -h, -h), (-h, h, -h), (h, h, -h), (h, -h, -h)],
        "ceiling": [(-h, -h, h), (h, -h, h), (h, h, h), (-h, h, h)],
        "xm": [(-h, -h, -h), (-h, -h, h), (-h, h, h), (-h, h, -h)],
        "xp": [(h, -h, -h), (h, h, -h), (h, h, h), (h, -h, h)],
        "ym": [(-h, -h, -h), (h, -h, -h), (h, -h, h), (-h, -h, h)],
        "yp": [(-h, h, -h), (-h, h, h), (h, h, h), (h, h, -h)],
    }
    for k, c in corners.items():
        rad.append(f"grey polygon {k}\n0\n0\n12 " + " ".join(f"{v}" for p in c for v in p) + "\n")
    L = candela / (EFFICACY * math.pi * LAMP_RADIUS ** 2)
    rad.append(f"void illum src\n0\n0\n3 {L} {L} {L}\n\nsrc sphere s\n0\n0\n4 0 0 0 "
               f"{LAMP_RADIUS}\n")
    (work / "box.rad").write_text("\n".join(rad))
    with open(work / "box.oct", "wb") as f:
        subprocess.run(["oconv", "box.rad"], cwd=work, env=env, stdout=f, check=True)
    # Gauss-Legendre product rule (grid x grid nodes per face) for the area mean: the nodes
    # crowd toward the edges, where the indirect illuminance bends fastest (a uniform midpoint
    # grid converges only about linearly there: +1.4 %, +0.5 %, +0.2 % at 4, 8, 16 per side).
    x, wx = np.polynomial.legendre.leggauss(grid)
    u = x * h
    rays, weights = [], []
    for axis in range(3):
        for sign in (-1, 1):
            for a, wa in zip(u, wx):
                for b, wb in zip(u, wx):
                    weights.append(wa * wb)
                    p = [0.0, 0.0, 0.0]
                    others = [k for k in range(3) if k != axis]
                    p[axis] = sign * (h - OFFSET)
                    p[others[0]], p[others[1]] = a, b
                    n = [0.0, 0.0, 0.0]
                    n[axis] = -sign
                    rays.append(p + n)
    rays = np.array(rays)
    t0 = time.time()
    total = lux(rtrace(work / "box.oct", rays, ab, ad, 1e-9, env, work)) @ REC709
    direct = lux(rtrace(work / "box.oct", rays, 0, ad, 1e-9, env, work)) @ REC709
    secs = time.time() - t0
    # Analytic direct at the same points: I cos(theta) / d^2.
    pos = rays[:, :3]
    d = np.linalg.norm(pos, axis=1)
    cos = np.einsum("ij,ij->i", -pos / d[:, None], rays[:, 3:])
    direct_exact = candela * cos / d ** 2
    indirect = total - direct
    want = flux * rho / (6 * side ** 2 * (1 - rho))
    weights = np.array(weights)
    got = float((indirect * weights).sum() / weights.sum())
    res = {"rho": rho, "ab": ab, "ad": ad, "points": len(rays), "indirect_mean_lux": got,
           "closed_form_lux": want, "rel_error": got / want - 1,
           "truncation_expected": -rho ** ab,
           "direct_max_abs_rel": float(np.max(np.abs(direct / direct_exact - 1))),
           "seconds": round(secs, 1)}
    print(f"closed box rho={rho} ab={ab} ad={ad}: indirect mean {got:.2f} lx vs {want:.2f} "
          f"({res['rel_error']:+.3%}; truncation alone {-rho ** ab:+.3%}), direct max |rel| "
          f"{res['direct_max_abs_rel']:.3%}")
    return res


def convergence(env: dict, workroot: Path, name: str, count: int, settings: dict,
                higher: dict) -> dict:
    """Reruns `count` points of <name>.csv with higher -ab/-ad and reports the change."""
    work = workroot / f"conv_{name}"
    work.mkdir(parents=True, exist_ok=True)
    glb = work / f"{name}.glb"
    export_glb(name, glb)
    scene = load_scene(glb)
    octree = write_scene(scene, work, env)
    rows = [line.split(",") for line in (HERE / f"{name}.csv").read_text().splitlines()
            if line and not line.startswith("#") and not line.startswith("x,")]
    rng = np.random.default_rng(3)
    pick = sorted(rng.choice(len(rows), size=min(count, len(rows)), replace=False))
    sub = [rows[i] for i in pick]
    pos = np.array([[float(v) for v in r[:3]] for r in sub])
    nrm = np.array([[float(v) for v in r[3:6]] for r in sub])
    ref = np.array([float(r[8]) for r in sub])
    rays = np.concatenate([to_rad(pos), to_rad(nrm)], axis=1)
    t0 = time.time()
    again = lux(rtrace(octree, rays, settings["ab"], settings["ad"], settings["lw"], env,
                       work)) @ REC709
    hi = lux(rtrace(octree, rays, higher["ab"], higher["ad"], higher["lw"], env, work)) @ REC709
    secs = time.time() - t0
    rel_hi = hi / ref - 1
    rel_again = again / ref - 1
    res = {"scene": name, "points": len(sub), "settings": settings, "higher": higher,
           "higher_vs_committed": {"mean_rel": float(rel_hi.mean()),
                                   "mean_abs_rel": float(np.abs(rel_hi).mean()),
                                   "max_abs_rel": float(np.abs(rel_hi).max())},
           "rerun_same_settings": {"mean_rel": float(rel_again.mean()),
                                   "mean_abs_rel": float(np.abs(rel_again).mean()),
                                   "max_abs_rel": float(np.abs(rel_again).max())},
           "seconds": round(secs, 1)}
    print(f"convergence {name}: -ab {higher['ab']} -ad {higher['ad']} vs committed: mean "
          f"{rel_hi.mean():+.3%}, mean |rel| {np.abs(rel_hi).mean():.3%}, max |rel| "
          f"{np.abs(rel_hi).max():.3%}; rerun at the same settings: mean |rel| "
          f"{np.abs(rel_again).mean():.3%}, max {np.abs(rel_again).max():.3%}")
    return res


# ---------------------------------------------------------------------------------------------
# Near field: lamps with their luminous openings (the `nearfield` sub-command)
#
# `ies2rad -dm` without `-i` turns the file's luminous opening into emitting `light` geometry
# (see README.md, "Near field"): a flat rectangle or disk (one face per hemisphere the file has
# light in) with radiance I(w) / (A cos) (`flatcorr`), or a box / vertical cylinder (all faces,
# when the file has light both up and down) with radiance I(w) / A_proj(w) (`boxcorr`,
# `cylcorr`): uniform luminance on every emitting face, equal to the intensity over the
# projected area. Two limits of rtrace's area-source sampling are worked around here, without
# changing that model:
# - a source is split into at most 64 cells (MAXSPART), whatever -ds asks: a 0.6 m opening
#   0.15 m from a point is then integrated with 10 cm cells. Each emitting rectangle is cut
#   into pieces of at most NF_PIECE (same modifier, same plane, same orientation), so -ds
#   decides again;
# - a disk (`ring`) is sampled through a square-to-disk map that is not area-preserving while
#   every cell keeps the same weight: 13 % low on the axis at h = D/4 (nearfield_validation.json).
#   Each disk is replaced by strips of NF_STRIP width whose lengths give every strip exactly
#   the disk's area in its band (total area pi r^2, as ies2rad's correction assumes), then cut
#   into pieces as above.

NF_DS = 0.02          # rtrace -ds: cells below 2 % of their distance
NF_PIECE = 0.04       # m, largest emitting piece (64 cells of 5 mm at most)
NF_STRIP = 0.004      # m, strip width of a disk
NF_MIN_DIST = 0.10    # m, least distance of a calculation point from a luminous opening
NF_MIN_LUX = 1.0      # lx, least direct illuminance (opening model) of a calculation point
NF_CANDIDATES = 5     # random candidates per wanted point (shadowed ones are dropped)
NF_FLAGS = ["-ab", "0", "-aa", "0", "-av", "0", "0", "0", "-dt", "0", "-dc", "1", "-dj", "0",
            "-dr", "0", "-st", "1", "-ss", "0", "-lr", "1000", "-u+"]
NF_SCENE_DIR = REPO / "bench" / "scenes"
# Points per room: random strata (as the furnished scenes) plus points aimed at from every lamp
# (under, beside, above it); only lit points are kept, so a stratum no lamp lights is left out.
NF_ROOMS = {
    "nearfield_dining": {"floor": 45, "wall": 45, "furniture/up": 45},
    "nearfield_office": {"floor": 40, "wall": 40, "furniture/up": 45, "furniture/side": 15},
    "nearfield_round": {"floor": 35, "wall": 35, "ceiling": 35, "furniture/up": 40},
    "nearfield_box": {"floor": 35, "wall": 45, "ceiling": 40, "furniture/up": 15,
                      "furniture/side": 10},
}


def from_rad(p: np.ndarray) -> np.ndarray:
    """Radiance world (z up) -> luxbake world (y up): (X, Y, Z) -> (X, Z, -Y)."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)


def rad_primitives(text: str) -> list:
    """Primitives of a Radiance scene text: dicts with mod, type, name, s, i, r."""
    words = []
    for line in text.splitlines():
        if line.lstrip().startswith("#") or line.lstrip().startswith("!"):
            continue
        words += [w.strip("'\"") for w in line.split()]
    prims, k = [], 0
    while k < len(words):
        mod, typ, name = words[k:k + 3]
        k += 3
        ns = int(words[k]); s = words[k + 1:k + 1 + ns]; k += 1 + ns
        ni = int(words[k]); ints = words[k + 1:k + 1 + ni]; k += 1 + ni
        nr = int(words[k]); r = [float(v) for v in words[k + 1:k + 1 + nr]]; k += 1 + nr
        prims.append({"mod": mod, "type": typ, "name": name, "s": s, "i": ints, "r": r})
    return prims


def prim_text(p: dict) -> str:
    reals = " ".join(f"{v:.9g}" for v in p["r"])
    return (f"{p['mod']} {p['type']} {p['name']}\n{len(p['s'])} {' '.join(p['s'])}\n"
            f"{len(p['i'])} {' '.join(p['i'])}\n{len(p['r'])} {reals}\n")


def poly_normal(v: np.ndarray) -> np.ndarray:
    n = np.cross(v[1] - v[0], v[2] - v[0])
    return n / np.linalg.norm(n)


def split_quad(v: np.ndarray, piece: float) -> list:
    """A parallelogram v0 v1 v2 v3 cut into a grid of pieces no larger than `piece`, same order."""
    a, b = v[1] - v[0], v[3] - v[0]
    assert np.allclose(v[2], v[0] + a + b, atol=1e-7), "emitting polygon is no parallelogram"
    n = max(1, math.ceil(np.linalg.norm(a) / piece - 1e-9))
    m = max(1, math.ceil(np.linalg.norm(b) / piece - 1e-9))
    out = []
    for i in range(n):
        for j in range(m):
            o = v[0] + a * (i / n) + b * (j / m)
            out.append(np.array([o, o + a / n, o + a / n + b / m, o + b / m]))
    return out


def disk_quads(center: np.ndarray, normal: np.ndarray, radius: float, strip: float,
               piece: float) -> list:
    """An axis-aligned disk (normal +-z) as area-exact strips, cut into pieces."""
    assert abs(abs(normal[2]) - 1) < 1e-9, "only disks facing +-z (what ies2rad writes)"
    nstrips = max(2, math.ceil(2 * radius / strip))
    edges = np.linspace(-radius, radius, nstrips + 1)

    def band(y):  # integral of 2 sqrt(r^2 - y^2) from 0 to y
        y = np.clip(y, -radius, radius)
        return y * np.sqrt(radius ** 2 - y ** 2) + radius ** 2 * np.arcsin(y / radius)

    quads = []
    for y0, y1 in zip(edges[:-1], edges[1:]):
        half = (band(y1) - band(y0)) / (y1 - y0) / 2  # exact band area / width / 2
        v = np.array([[-half, y0, 0], [half, y0, 0], [half, y1, 0], [-half, y1, 0]]) + center
        if poly_normal(v) @ normal < 0:
            v = v[[0, 3, 2, 1]]
        quads += split_quad(v, piece)
    return quads


def opening_lamp(ies: Path, name: str, mult: float, color, workdir: Path, env: dict,
                 piece: float, strip: float) -> dict:
    """ies2rad's luminous-opening luminaire (lamp frame), its faces cut into pieces.

    Returns the Radiance text, the emitting faces as ies2rad wrote them (for the probes) and
    what ies2rad said (shape comments, warnings)."""
    shutil.copy(ies, workdir / f"{name}.ies")
    run = subprocess.run(["ies2rad", "-dm", "-c", *map(str, color), "-m", str(mult), "-o", name,
                          f"{name}.ies"], cwd=workdir, env=env, check=True, capture_output=True,
                         text=True)
    text = (workdir / f"{name}.rad").read_text()
    shape = [line[2:].strip() for line in text.splitlines()
             if line.startswith("# IES file shape") or line.startswith("# Radiance geometry")]
    out, faces, npieces = [], [], 0
    for p in rad_primitives(text):
        if p["type"] == "polygon":
            v = np.array(p["r"]).reshape(-1, 3)
            faces.append({"kind": "polygon", "vertices": v, "normal": poly_normal(v)})
            for k, q in enumerate(split_quad(v, piece)):
                out.append(prim_text({**p, "name": f"{p['name']}.{k}", "r": list(q.reshape(-1))}))
                npieces += 1
        elif p["type"] == "ring":
            c, n, r0, r1 = np.array(p["r"][:3]), np.array(p["r"][3:6]), p["r"][6], p["r"][7]
            assert r0 == 0.0
            faces.append({"kind": "disk", "center": c, "normal": n, "radius": r1})
            for k, q in enumerate(disk_quads(c, n, r1, strip, piece)):
                out.append(prim_text({"mod": p["mod"], "type": "polygon",
                                      "name": f"{p['name']}.{k}", "s": [], "i": [],
                                      "r": list(q.reshape(-1))}))
                npieces += 1
        elif p["type"] in ("cylinder", "sphere"):
            raise NotImplementedError(f"{ies.name}: ies2rad wrote a {p['type']}; the near-field "
                                      "references take rectangles, boxes and disks")
        else:
            out.append(prim_text(p))
    return {"text": "\n".join(out), "faces": faces, "pieces": npieces, "shape": shape,
            "warnings": run.stderr.strip()}


def face_probes(face: dict, inset: float = 0.002) -> np.ndarray:
    """Points of an emitting face (lamp frame): centre, corners and edge midpoints (inset)."""
    if face["kind"] == "polygon":
        v = face["vertices"]
        c = v.mean(axis=0)
        pts = [c]
        for k in range(len(v)):
            a, b = v[k], v[(k + 1) % len(v)]
            for q in (a, 0.5 * (a + b)):
                d = c - q
                pts.append(q + inset * d / np.linalg.norm(d))
        return np.array(pts)
    c, r = face["center"], face["radius"] - inset
    return np.array([c] + [c + r * np.array([math.cos(a), math.sin(a), 0.0])
                           for a in np.arange(8) * (2 * math.pi / 8)])


def face_triangles(face: dict) -> np.ndarray:
    if face["kind"] == "polygon":
        v = face["vertices"]
        return np.array([[v[0], v[k], v[k + 1]] for k in range(1, len(v) - 1)])
    c, r = face["center"], face["radius"]
    ring = [c + r * np.array([math.cos(a), math.sin(a), 0.0])
            for a in np.arange(33) * (2 * math.pi / 32)]
    return np.array([[c, ring[k], ring[k + 1]] for k in range(32)])


def nf_lamp_files(toml_path: Path) -> dict:
    """Lamp name -> photometric file, from the scene file (the export does not carry it)."""
    import tomllib
    data = tomllib.loads(toml_path.read_text())
    files = {}
    for i, lamp in enumerate(data.get("lamp", [])):
        ies = lamp.get("ies", "builtin:downlight")
        if ies.startswith(("builtin:", "isotropic:")):
            raise NotImplementedError(f"{toml_path.name}: lamp {i}: {ies} has no opening")
        files[lamp.get("name", f"lamp_{i}")] = (toml_path.parent / ies).resolve()
    return files


def nf_build(name: str, work: Path, env: dict, piece: float, strip: float) -> dict:
    """Exports a near-field room, writes its Radiance scene with the opening model
    (scene_open.oct) and the point model (scene_point.oct); returns the scene and the lamps."""
    toml_path = NF_SCENE_DIR / f"{name}.toml"
    glb = work / f"{name}.glb"
    export_glb(str(toml_path), glb)
    scene = load_scene(glb)
    files = nf_lamp_files(toml_path)
    geometry = (work / "scene.rad")
    write_scene({**scene, "lamps": []}, work, env)  # geometry and materials only
    base = geometry.read_text()
    open_txt, point_txt, lamps = [base], [base], []
    for k, lamp in enumerate(scene["lamps"]):
        aim = np.array(lamp.get("aim", [0, -1, 0]), dtype=np.float64)
        if not np.allclose(aim / np.linalg.norm(aim), [0, -1, 0]) or \
                abs(lamp.get("rotationDeg", 0.0)) > 1e-9:
            raise NotImplementedError(f"{name}: lamp {lamp['name']}: only the default frame")
        ies = files[lamp["name"]]
        mult = float(lamp.get("multiplier", 1.0))
        color = [float(c) for c in lamp.get("color", [1, 1, 1])]
        pos = to_rad(np.array(lamp["position"]))
        t = f"-t {pos[0]:.6f} {pos[1]:.6f} {pos[2]:.6f}"
        lo = opening_lamp(ies, f"lamp{k}", mult, color, work, env, piece, strip)
        (work / f"lamp{k}_open.rad").write_text(lo["text"])
        open_txt.append(f"!xform -n lamp{k} {t} lamp{k}_open.rad\n")
        shutil.copy(ies, work / f"lamp{k}p.ies")
        subprocess.run(["ies2rad", "-dm", "-i", str(LAMP_RADIUS), "-c", *map(str, color),
                        "-m", str(mult), "-o", f"lamp{k}p", f"lamp{k}p.ies"],
                       cwd=work, env=env, check=True, capture_output=True)
        point_txt.append(f"!xform -n lamp{k}p {t} lamp{k}p.rad\n")
        probes = np.concatenate([[np.zeros(3)]] + [face_probes(f) for f in lo["faces"]])
        tris = np.concatenate([face_triangles(f) for f in lo["faces"]])
        lamps.append({"name": lamp["name"], "file": ies, "position": np.array(lamp["position"]),
                      "probes": from_rad(probes + pos), "tris": from_rad(tris + pos),
                      "pieces": lo["pieces"], "shape": lo["shape"], "warnings": lo["warnings"],
                      "faces": len(lo["faces"])})
    octrees = {}
    for kind, txt in (("open", open_txt), ("point", point_txt)):
        (work / f"scene_{kind}.rad").write_text("\n".join(txt))
        with open(work / f"scene_{kind}.oct", "wb") as f:
            subprocess.run(["oconv", f"scene_{kind}.rad"], cwd=work, env=env, stdout=f,
                           check=True)
        octrees[kind] = work / f"scene_{kind}.oct"
    return {"scene": scene, "lamps": lamps, "octrees": octrees}


def nf_acceptable(scene: dict, lamps: list, ti: int, p: np.ndarray, margin: float,
                  rng) -> bool:
    """`acceptable` with area lamps: the point is no nearer than NF_MIN_DIST to an opening and
    sees each lamp's whole opening (centre, corners, edge midpoints, the photometric centre) or
    none of it, and so do the 8 points `margin` around it; no sight line to a lamp passes
    through another lamp's opening."""
    for lamp in lamps:
        if point_triangle_distance(p, lamp["tris"]).min() < NF_MIN_DIST:
            return False
    if not acceptable({**scene, "lamp_positions": []}, ti, p, margin, rng):
        return False
    n = scene["normals"][ti]
    helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    ring = [p + OFFSET * n + margin * (math.cos(a) * u + math.sin(a) * v)
            for a in np.arange(8) * (2 * math.pi / 8)]
    origins = np.array([p + OFFSET * n, *ring])
    for k, lamp in enumerate(lamps):
        others = [m["tris"] for j, m in enumerate(lamps) if j != k]
        seen_all = []
        for q in lamp["probes"]:
            to = q - origins
            dist = np.linalg.norm(to, axis=1)
            dirs = to / dist[:, None]
            t, _ = first_hits(scene, origins, dirs)
            if others:
                t_other, _ = first_hits({"tris": np.concatenate(others)}, origins, dirs)
                if np.any(t_other < dist):
                    return False
            seen_all.append(t > dist - 1e-3)
        seen = np.array(seen_all)
        if seen.any() and not seen.all():
            return False
    return True


def nf_candidates(scene: dict, lamps: list):
    """Surface points hit from each lamp: straight down and up, and at 20, 40 and 60 degrees
    off in 8 azimuths (under, beside and above the lamps)."""
    out = []
    for lamp in lamps:
        o = lamp["position"]
        dirs = [np.array([0, -1.0, 0]), np.array([0, 1.0, 0])]
        for tilt in (20, 40, 60):
            for az in np.arange(8) * 45 + 22.5 * (tilt == 40):
                a, b = math.radians(tilt), math.radians(az)
                for s in (-1, 1):
                    dirs.append(np.array([math.sin(a) * math.cos(b), s * math.cos(a),
                                          math.sin(a) * math.sin(b)]))
        dirs = np.array(dirs)
        t, idx = first_hits(scene, np.repeat(o[None], len(dirs), axis=0), dirs)
        for d, tt, j in zip(dirs, t, idx):
            if np.isfinite(tt) and np.dot(d, scene["normals"][j]) < 0:
                out.append((int(j), o + tt * d))
    return out


def nf_choose_points(scene: dict, lamps: list, counts: dict, seed: int):
    """Candidates: points aimed at from the lamps, then area-uniform random points per stratum
    (NF_CANDIDATES times the count: `make_nearfield` keeps the first that are lit). Returns the
    points and their strata ("aimed" or the stratum)."""
    rng = np.random.default_rng(seed)
    chosen = []
    for ti, p in nf_candidates(scene, lamps):
        kind = surface_kind(scene, ti)
        if nf_acceptable(scene, lamps, ti, p, margin_of(kind), rng):
            chosen.append((p, scene["normals"][ti], kind, scene["names"][scene["object"][ti]]))
    labels = ["aimed"] * len(chosen)
    for stratum, count, got in stratified_points(
            scene, counts, rng, lambda ti, p, margin: nf_acceptable(scene, lamps, ti, p, margin, rng),
            NF_CANDIDATES):
        chosen += got
        labels += [stratum] * len(got)
        if len(got) < count:
            print(f"note: {len(got)} of {count} {stratum} candidates")
    return chosen, labels


def nf_rtrace(octree: Path, rays: np.ndarray, ds: float, env: dict, cwd: Path) -> np.ndarray:
    """Direct illuminance, lux (Rec. 709 Y), of `rtrace -I -ab 0` at rows x y z nx ny nz."""
    return lux(run_rtrace([*NF_FLAGS, "-ds", f"{ds:g}"], octree, rays, env, cwd)) @ REC709


def nf_summary(points, opening, point) -> dict:
    """Per surface kind: (point - opening) / opening where the opening model gives > 1 lx."""
    kinds = {}
    for (_, _, kind, _), o, q in zip(points, opening, point):
        kinds.setdefault(kind, []).append((o, q))
        kinds.setdefault("all", []).append((o, q))
    out = {}
    for kind, rows in sorted(kinds.items()):
        o = np.array([r[0] for r in rows])
        q = np.array([r[1] for r in rows])
        lit = o > 1.0
        rel = q[lit] / o[lit] - 1
        out[kind] = {"points": len(rows), "lit": int(lit.sum()),
                     "mean_rel": float(rel.mean()) if lit.any() else None,
                     "mean_abs_rel": float(np.abs(rel).mean()) if lit.any() else None,
                     "min_rel": float(rel.min()) if lit.any() else None,
                     "max_rel": float(rel.max()) if lit.any() else None,
                     "max_abs_rel": float(np.abs(rel).max()) if lit.any() else None}
    return out


def make_nearfield(name: str, out_dir: Path, env: dict, workroot: Path, check: bool) -> dict:
    work = workroot / name
    work.mkdir(parents=True, exist_ok=True)
    built = nf_build(name, work, env, NF_PIECE, NF_STRIP)
    scene, lamps = built["scene"], built["lamps"]
    t0 = time.time()
    cands, labels = nf_choose_points(scene, lamps, NF_ROOMS[name], seed=sum(map(ord, name)))
    t_points = time.time() - t0
    rays = rays_of(cands)
    t0 = time.time()
    opening = nf_rtrace(built["octrees"]["open"], rays, NF_DS, env, work)
    t_open = time.time() - t0
    t0 = time.time()
    point = nf_rtrace(built["octrees"]["point"], rays, NF_DS, env, work)
    t_point = time.time() - t0
    # Keep the lit candidates (opening model >= NF_MIN_LUX; a dark point has no relative
    # error to test): every aimed one, then the first `count` of each stratum.
    keep, taken = [], {}
    for k, (label, o) in enumerate(zip(labels, opening)):
        if o < NF_MIN_LUX:
            continue
        if label != "aimed":
            if taken.get(label, 0) >= NF_ROOMS[name][label]:
                continue
            taken[label] = taken.get(label, 0) + 1
        keep.append(k)
    for stratum, count in NF_ROOMS[name].items():
        if taken.get(stratum, 0) < count:
            print(f"warning: {name}: only {taken.get(stratum, 0)} of {count} lit {stratum} "
                  "points")
    aimed = sum(labels[k] == "aimed" for k in keep)
    points = [cands[k] for k in keep]
    rays, opening, point = rays[keep], opening[keep], point[keep]
    dist = np.array([min(point_triangle_distance(p + OFFSET * n, lamp["tris"]).min()
                         for lamp in lamps) for p, n, _, _ in points])
    summary = nf_summary(points, opening, point)
    res = {"points": len(points), "aimed_points": aimed, "candidates": len(cands),
           "per_kind": {k: v["points"] for k, v in summary.items() if k != "all"},
           "lamps": [{"name": m["name"], "file": os.path.relpath(m["file"], REPO),
                      "position": [float(v) for v in m["position"]], "ies2rad": m["shape"],
                      "emitting_faces": m["faces"], "pieces": m["pieces"],
                      "ies2rad_warnings": m["warnings"]} for m in lamps],
           "point_vs_opening": summary,
           "distance_to_opening_m": [float(dist.min()), float(dist.max())],
           "seconds_points": round(t_points, 1), "seconds_rtrace_opening": round(t_open, 1),
           "seconds_rtrace_point": round(t_point, 1), "triangles": int(len(scene["tris"]))}
    if check:  # convergence: -ds and the piece size halved
        fine = work / "fine"
        fine.mkdir(exist_ok=True)
        b2 = nf_build(name, fine, env, NF_PIECE / 2, NF_STRIP / 2)
        t0 = time.time()
        again = nf_rtrace(b2["octrees"]["open"], rays, NF_DS / 2, env, fine)
        lit = opening > 1.0
        rel = again[lit] / opening[lit] - 1
        res["convergence"] = {"ds": NF_DS / 2, "piece_m": NF_PIECE / 2, "strip_m": NF_STRIP / 2,
                              "points": int(lit.sum()), "mean_rel": float(rel.mean()),
                              "max_abs_rel": float(np.abs(rel).max()),
                              "seconds": round(time.time() - t0, 1)}
    path = out_dir / f"{name}.csv"
    with open(path, "w") as f:
        f.write(f"# Radiance near-field reference for bench/scenes/{name}.toml: made by "
                f"make_references.py nearfield (see README.md, Near field)\n")
        f.write(f"# {radiance_version(env)}; direct light only: rtrace -I -h "
                f"{' '.join(NF_FLAGS)} -ds {NF_DS:g}\n")
        f.write("# direct_lux: luminous-opening model, ies2rad -dm -c 1 1 1 -m MULT (no -i), "
                f"emitting faces cut into pieces <= {NF_PIECE:g} m, disks into area-exact "
                f"strips of {NF_STRIP:g} m; direct_point_lux: point model, ies2rad -i "
                f"{LAMP_RADIUS} (as the other references)\n")
        f.write("# lux = direct_lux (no inter-reflection: compare with a direct-only bake); "
                "position 1 mm off the surface along the normal; Rec. 709 Y, 179 lm/W; "
                "lamp_dist_m: distance to the nearest luminous opening\n")
        f.write("x,y,z,nx,ny,nz,surface,object,lux,direct_lux,direct_point_lux,lamp_dist_m\n")
        for (p, n, kind, obj), o, q, d in zip(points, opening, point, dist):
            x = p + OFFSET * n
            f.write(f"{x[0]:.4f},{x[1]:.4f},{x[2]:.4f},{n[0]:.5f},{n[1]:.5f},{n[2]:.5f},"
                    f"{kind},{obj},{o:.3f},{o:.3f},{q:.3f},{d:.3f}\n")
    print(f"{name}: wrote {path} ({len(points)} points, {aimed} aimed from the lamps; rtrace "
          f"{t_open:.0f} s opening, {t_point:.0f} s point)")
    for kind, s in summary.items():
        if s["lit"]:
            print(f"  {kind:10s} {s['lit']:3d} lit: point vs opening mean {s['mean_rel']:+.2%}, "
                  f"min {s['min_rel']:+.2%}, max {s['max_rel']:+.2%}")
    if "convergence" in res:
        c = res["convergence"]
        print(f"  convergence (-ds {c['ds']:g}, pieces {c['piece_m']:g} m): mean "
              f"{c['mean_rel']:+.4%}, max |rel| {c['max_abs_rel']:.4%}")
    return res


# Validation of the method against closed forms (`nearfield-validate`)


def lambert_ies(path: Path, dims, kind: str, intensity: float = 1000.0) -> None:
    """Synthetic LM-63-2002 file of a uniform-luminance opening.

    `flat`: I(gamma) = I0 cos(gamma), downward only (a Lambertian disk or rectangle, width,
    length, height = dims as the file writes them); `box`: I = L A_proj(gamma, C) of a box
    with luminance L = intensity / (length x width) on every face, C 0-90 (quadrant)."""
    if kind == "flat":
        gam = np.arange(0, 90.01, 0.5)
        horiz = np.array([0.0])
        cd = np.maximum(intensity * np.cos(np.radians(gam)), 0)[None]
        cd[0, -1] = 0.0
    else:
        w, l, h = dims
        lum = intensity / (l * w)
        gam = np.arange(0, 180.01, 1.0)
        horiz = np.arange(0, 90.01, 1.0)
        g, c = np.radians(gam)[None], np.radians(horiz)[:, None]
        # C0 along the length (x), C90 along the width (y): the faces' projected areas.
        cd = lum * (np.abs(np.sin(g) * np.cos(c)) * w * h + np.abs(np.sin(g) * np.sin(c)) * l * h
                    + np.abs(np.cos(g)) * l * w)
    lines = ["IESNA:LM-63-2002", f"[TEST] synthetic uniform-luminance opening ({kind})",
             "[MANUFAC] luxbake make_references.py", "TILT=NONE",
             f"1 -1 1 {len(gam)} {len(horiz)} 1 2 {dims[0]} {dims[1]} {dims[2]}", "1 1 0"]
    lines += [" ".join(f"{v:g}" for v in gam), " ".join(f"{v:g}" for v in horiz)]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in cd]
    path.write_text("\n".join(lines) + "\n")


def rect_corner(L: float, a: float, b: float, h: float) -> float:
    """Illuminance under a Lambertian a x b rectangle of luminance L, on the normal through a
    corner at distance h (the point's plane parallel to the rectangle)."""
    A, B = a / h, b / h
    return L / 2 * (A / math.sqrt(1 + A * A) * math.atan(B / math.sqrt(1 + A * A))
                    + B / math.sqrt(1 + B * B) * math.atan(A / math.sqrt(1 + B * B)))


def box_quadrature(L: float, dims, p: np.ndarray, n: np.ndarray, order: int = 96) -> float:
    """Illuminance at p (normal n) from a box of luminance L on every face, centred at the
    origin (x: length, y: width, z: height), by a Gauss-Legendre rule on each face it sees."""
    lx, wy, hz = dims
    half = np.array([lx, wy, hz]) / 2
    x, wts = np.polynomial.legendre.leggauss(order)
    total = 0.0
    for axis in range(3):
        for sign in (-1, 1):
            if (p[axis] - sign * half[axis]) * sign <= 0:
                continue  # the point is behind this face
            o = [k for k in range(3) if k != axis]
            uu, vv = np.meshgrid(x * half[o[0]], x * half[o[1]], indexing="ij")
            ww = np.outer(wts, wts) * half[o[0]] * half[o[1]]
            q = np.zeros(uu.shape + (3,))
            q[..., axis] = sign * half[axis]
            q[..., o[0]], q[..., o[1]] = uu, vv
            d = q - p
            r = np.linalg.norm(d, axis=-1)
            cos_p = np.clip(d @ n / r, 0, None)
            cos_f = np.clip(-d[..., axis] * sign / r, 0, None)
            total += float((L * cos_p * cos_f / r ** 2 * ww).sum())
    return total


def nf_point(octree: Path, rays, ds, env, cwd) -> np.ndarray:
    return nf_rtrace(octree, np.atleast_2d(np.asarray(rays, dtype=np.float64)), ds, env, cwd)


def nearfield_validation(env: dict, workroot: Path) -> dict:
    """Uniform-luminance openings through ies2rad + rtrace against closed forms."""
    work = workroot / "nf_validate"
    work.mkdir(parents=True, exist_ok=True)
    ratios = [0.25, 0.5, 1, 2, 5]
    res = {"settings": {"flags": NF_FLAGS, "ds": NF_DS, "piece_m": NF_PIECE,
                        "strip_m": NF_STRIP}, "cases": []}

    def scene_with(lamp_rad: str, tag: str) -> Path:
        (work / f"{tag}.rad").write_text(lamp_rad)
        with open(work / f"{tag}.oct", "wb") as f:
            subprocess.run(["oconv", f"{tag}.rad"], cwd=work, env=env, stdout=f, check=True)
        return work / f"{tag}.oct"

    def variants(ies: Path, tag: str):
        raw = subprocess.run(["ies2rad", "-dm", "-c", "1", "1", "1", "-o", tag, ies.name],
                             cwd=work, env=env, check=True, capture_output=True)
        del raw
        yield "ies2rad as written", scene_with((work / f"{tag}.rad").read_text(), f"{tag}_raw"), \
            NF_DS
        for scale, label in ((1, "pieces"), (0.5, "pieces/2, -ds/2")):
            lo = opening_lamp(ies, f"{tag}_p{scale}", 1.0, [1, 1, 1], work, env,
                              NF_PIECE * scale, NF_STRIP * scale)
            yield label, scene_with(lo["text"], f"{tag}_p{scale}"), NF_DS * scale

    # 1. Lambertian disk, D = 0.2 m, I0 = 1000 cd: on the axis E = I0 / (a^2 + h^2).
    D, I0 = 0.2, 1000.0
    a = D / 2
    ies = work / "lambert_disk.ies"
    lambert_ies(ies, (-D, -D, 0), "flat", I0)
    face_z = -0.00025  # ies2rad gives a flat opening 0.5 mm thickness: the lower face
    for label, octree, ds in variants(ies, "disk"):
        rows = []
        for q in ratios:
            h = q * D
            got = float(nf_point(octree, [0, 0, face_z - h, 0, 0, 1], ds, env, work)[0])
            want = I0 / (a * a + h * h)
            rows.append({"h_over_D": q, "h_m": h, "radiance_lux": got, "closed_form_lux": want,
                         "rel": got / want - 1})
        res["cases"].append({"case": "Lambertian disk D 0.2 m, on the axis", "variant": label,
                             "rows": rows})
    # 2. Lambertian rectangles, normal through a corner.
    for (wd, ln), what in (((0.06, 0.6), "linear 0.6 x 0.06 m"),
                           ((0.3, 0.3), "square 0.3 x 0.3 m")):
        ies = work / f"lambert_rect_{ln}x{wd}.ies"
        lambert_ies(ies, (wd, ln, 0), "flat", I0)
        L = I0 / (wd * ln)
        Dm = max(wd, ln)
        for label, octree, ds in variants(ies, f"rect{ln}"):
            rows = []
            for q in ratios:
                h = q * Dm
                # corner of the lower face: x = length / 2, y = width / 2 (Radiance frame)
                got = float(nf_point(octree, [ln / 2, wd / 2, face_z - h, 0, 0, 1], ds, env,
                                     work)[0])
                want = rect_corner(L, ln, wd, h)
                centre = float(nf_point(octree, [0, 0, face_z - h, 0, 0, 1], ds, env, work)[0])
                want_c = 4 * rect_corner(L, ln / 2, wd / 2, h)
                rows.append({"h_over_D": q, "h_m": h, "corner_radiance_lux": got,
                             "corner_closed_form_lux": want, "corner_rel": got / want - 1,
                             "centre_radiance_lux": centre, "centre_closed_form_lux": want_c,
                             "centre_rel": centre / want_c - 1})
            res["cases"].append({"case": f"Lambertian rectangle {what}, normal through a "
                                 "corner and through the centre", "variant": label,
                                 "rows": rows})
    # 3. Uniform-luminance box 0.4 x 0.4 x 0.1 m with luminous sides (rw_1's kind), against a
    #    96 x 96 Gauss-Legendre rule per visible face: below, beside (facing a side), above.
    dims = (0.4, 0.4, 0.1)  # length (x, C0), width (y, C90), height (z)
    ies = work / "lambert_box.ies"
    lambert_ies(ies, (dims[1], dims[0], dims[2]), "box", I0)
    L = I0 / (dims[0] * dims[1])
    probes = []
    for q in ratios:
        h = q * 0.4
        probes.append((q, "below", np.array([0.05, 0.1, -0.05 - h]), np.array([0, 0, 1.0])))
        probes.append((q, "beside", np.array([0.2 + h, 0.07, 0.02]), np.array([-1.0, 0, 0])))
        probes.append((q, "above, tilted", np.array([0.1, -0.1, 0.05 + h]),
                       np.array([0.3, 0, -1.0]) / math.hypot(0.3, 1.0)))
    for label, octree, ds in variants(ies, "box"):
        rows = []
        for q, where, p, n in probes:
            got = float(nf_point(octree, [*p, *n], ds, env, work)[0])
            want = box_quadrature(L, dims, p, n) * 1.0
            rows.append({"h_over_D": q, "where": where, "radiance_lux": got,
                         "quadrature_lux": want, "rel": got / want - 1})
        res["cases"].append({"case": "uniform-luminance box 0.4 x 0.4 x 0.1 m (I = L A_proj)",
                             "variant": label, "rows": rows})
    # The quadrature itself: 96 against 128 nodes per side.
    worst = max(abs(box_quadrature(L, dims, p, n, 96) / box_quadrature(L, dims, p, n, 128) - 1)
                for _, _, p, n in probes)
    res["box_quadrature_96_vs_128_max_rel"] = worst
    for case in res["cases"]:
        rels = [r.get("rel", r.get("corner_rel")) for r in case["rows"]] + \
            [r["centre_rel"] for r in case["rows"] if "centre_rel" in r]
        case["max_abs_rel"] = float(max(abs(v) for v in rels))
        print(f"{case['case']} [{case['variant']}]: max |rel| {case['max_abs_rel']:.3%} ("
              + ", ".join(f"{r['h_over_D']}: {r.get('rel', r.get('corner_rel')):+.3%}"
                          for r in case["rows"]) + ")")
    return res


# ---------------------------------------------------------------------------------------------


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", nargs="?", default="scenes",
                    choices=["scenes", "validate", "nearfield", "retrace"])
    ap.add_argument("--scenes", default="chairs_01,chairs_05,sofa_01,floor,sphere")
    ap.add_argument("--rooms", default=",".join(NF_ROOMS),
                    help="nearfield: the rooms (bench/scenes/<room>.toml)")
    ap.add_argument("--skip-validation", action="store_true",
                    help="nearfield: leave nearfield_validation.json as it is")
    ap.add_argument("--skip-convergence", action="store_true",
                    help="nearfield: no rerun with -ds and the pieces halved")
    ap.add_argument("--out", type=Path, default=HERE)
    ap.add_argument("--ab", type=int, default=REFERENCE["ab"])
    ap.add_argument("--ad", type=int, default=REFERENCE["ad"])
    ap.add_argument("--lw", type=float, default=REFERENCE["lw"])
    ap.add_argument("--from", dest="source", type=Path,
                    help="retrace: the reference CSV whose dark points are traced again")
    ap.add_argument("--dark-below", type=float, default=5.0,
                    help="retrace: points with less total lux than this are traced again")
    ap.add_argument("--ad-dark", type=int, default=65536,
                    help="retrace: hemisphere samples of the second trace")
    ap.add_argument("--trace-offset", type=float,
                    help="scenes, retrace: trace from this far off the surface, in m (default: "
                    "1 mm, the CSV's positions), from the exact surface points")
    ap.add_argument("--surface",
                    help="retrace: only the dark points of this surface kind (e.g. furniture)")
    ap.add_argument("--keep", type=Path, help="keep the Radiance files in this folder")
    args = ap.parse_args()
    # Made before any trace, so that hours of rtrace are never lost to a missing folder.
    args.out.mkdir(parents=True, exist_ok=True)
    env = radiance_env()
    settings = {"ab": args.ab, "ad": args.ad, "lw": args.lw}
    if args.what == "scenes" and args.trace_offset is not None:
        settings["trace_offset"] = args.trace_offset
    workroot = args.keep or Path(tempfile.mkdtemp(prefix="luxbake-radiance-"))
    workroot.mkdir(parents=True, exist_ok=True)
    started = time.time()
    meta = {"radiance": radiance_version(env), "python": platform.python_version(),
            "numpy": np.__version__, "machine": platform.processor() or platform.machine()}
    try:
        import importlib.metadata as md
        meta["pyradiance"] = md.version("pyradiance")
    except Exception:  # noqa: BLE001
        pass
    if args.what == "scenes":
        log = {"meta": meta, "settings": settings, "common_flags": COMMON, "scenes": {}}
        for name in args.scenes.split(","):
            log["scenes"][name] = make_scene(name, args.out, env, workroot, settings)
        log["seconds"] = round(time.time() - started, 1)
        (args.out / "scenes.json").write_text(json.dumps(log, indent=2) + "\n")
    elif args.what == "retrace":
        if args.source is None or "," in args.scenes:
            sys.exit("error: retrace needs --from CSV and one scene in --scenes")
        settings.update(dark_below=args.dark_below, ad_dark=args.ad_dark, surface=args.surface,
                        trace_offset=args.trace_offset)
        log = {"meta": meta, "settings": settings, "common_flags": COMMON,
               "retraced": retrace_dark(args.scenes, args.source, args.out, env, workroot,
                                        settings)}
        log["seconds"] = round(time.time() - started, 1)
        (args.out / f"retrace_{scene_stem(args.scenes)}.json").write_text(json.dumps(log, indent=2) + "\n")
    elif args.what == "nearfield":
        log = {"meta": meta, "flags": NF_FLAGS, "ds": NF_DS, "piece_m": NF_PIECE,
               "strip_m": NF_STRIP, "min_distance_m": NF_MIN_DIST, "rooms": {}}
        for name in args.rooms.split(","):
            log["rooms"][name] = make_nearfield(name, args.out, env, workroot,
                                                not args.skip_convergence)
        log["seconds_rooms"] = round(time.time() - started, 1)
        (args.out / "nearfield.json").write_text(json.dumps(log, indent=2) + "\n")
        if not args.skip_validation:
            t0 = time.time()
            val = {"meta": meta, **nearfield_validation(env, workroot)}
            val["seconds"] = round(time.time() - t0, 1)
            (args.out / "nearfield_validation.json").write_text(json.dumps(val, indent=2) + "\n")
    else:
        log = {"meta": meta, "settings": settings, "common_flags": COMMON}
        log["direct"] = direct_check(env, workroot)
        log["closed_box"] = [
            closed_box(env, workroot, 0.5, settings["ab"], 1024, 8),
            closed_box(env, workroot, 0.8, settings["ab"], 1024, 8),
            closed_box(env, workroot, 0.8, 60, 1024, 8),
        ]
        log["convergence"] = convergence(env, workroot, "chairs_05", 40, settings,
                                         {"ab": 30, "ad": 16384, "lw": settings["lw"]})
        log["seconds"] = round(time.time() - started, 1)
        (args.out / "validation.json").write_text(json.dumps(log, indent=2) + "\n")
    if not args.keep:
        shutil.rmtree(workroot, ignore_errors=True)


if __name__ == "__main__":
    main()
