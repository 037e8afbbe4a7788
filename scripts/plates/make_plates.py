#!/usr/bin/env python3
"""Backplates from CC0 / CC-BY panoramas: perspective views looking at the horizon.

Every plate of assets/plates/ is a pinhole view of a 360-degree panorama (a cube map:
six 90-degree faces), rendered with numpy and written with Pillow:

  * the camera: horizontal field of view HFOV_DEG, no roll, turned by a yaw and
    pitched up by an elevation E (the line of sight E degrees above the horizon);
  * the horizon (the panorama's equator: the panoramas are levelled) then falls on
    row  v = H/2 + f*tan(E)  (f = (W/2)/tan(HFOV/2), rows from the top, pixel i
    covering [i, i+1]), which the sidecar NAME.plate.ron records as
    Row(v/H) together with hfov_deg: exact, not estimated;
  * the panorama's texels are read bilinearly in linear light (sRGB decoded, one ray
    per pixel: every source has fewer texels per radian than the plate has pixels, so
    there is nothing to average) and re-encoded to sRGB (the cube faces are already
    display-referred: no tone curve), written as JPEG quality 90, 4:2:0, no metadata.

The sources are git snapshots of public repositories (SOURCES below, with the commit
each blob was read at); the script reads each blob with `git show COMMIT:PATH`, so the
result depends on nothing but those commits, numpy and Pillow.

  git clone https://github.com/mfecane/shadercity ~/src/shadercity   # or any copy holding the commit
  python3 scripts/plates/make_plates.py --repo mfecane/shadercity=$HOME/src/shadercity/.git --out assets/plates

(--repo OWNER/NAME=GIT_DIR for each repository; without it the script looks for
/work/.mirror/OWNER+NAME/repo, then ~/src/NAME/.git.) --only NAME renders one
panorama's plates; --sheet FILE writes a contact sheet of every plate.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import math
import os
import subprocess
import sys

import numpy as np
from PIL import Image, ImageDraw

W, H = 1280, 720
HFOV_DEG = 70.0
JPEG_QUALITY = 90

SHADERCITY = ("mfecane/shadercity", "76f13411d681da5fc7a1449b7431e77d097bf959")

PH = "CC0-1.0"
HUMUS = "CC-BY-3.0"

# name, repository, folder or file in it, kind, licence, author, what it shows,
# views: (yaw degrees, elevation degrees) each.
# Poly Haven authors as credited on polyhaven.com/a/<name>; Humus: Emil Persson.
SOURCES = [
    # --- Humus cube maps (CC-BY 3.0, readme.txt beside the faces) -------------------
    ("humus_brudslojan", SHADERCITY, "assets/cubemaps/Brudslojan", "cube", HUMUS,
     "Emil Persson (Humus)", "conifers at a lake shore, bright sky", [(0, 8)]),
    ("humus_creek", SHADERCITY, "assets/cubemaps/Creek", "cube", HUMUS,
     "Emil Persson (Humus)", "snowy conifer forest, bright overcast", [(30, 6), (200, 16)]),
    ("humus_fishermans_bastion", SHADERCITY, "assets/cubemaps/FishermansBastion", "cube", HUMUS,
     "Emil Persson (Humus)", "towers and roofs over a city, blue sky, cumulus", [(0, 10), (100, 18), (260, 6)]),
    ("humus_larnaca_castle", SHADERCITY, "assets/cubemaps/LarnacaCastle", "cube", HUMUS,
     "Emil Persson (Humus)", "stone fort wall and sea, blue sky with cloud", [(60, 10), (180, 20)]),
    ("humus_nissi_beach", SHADERCITY, "assets/cubemaps/NissiBeach2", "cube", HUMUS,
     "Emil Persson (Humus)", "coast and scrub under structured cumulus", [(0, 12), (90, 6), (200, 22), (300, 14)]),
    # --- Poly Haven panoramas as cube faces (CC0) ------------------------------------
    ("ph_canary_wharf", SHADERCITY, "assets/cubemaps/canary_wharf", "cube", PH,
     "Poly Haven", "office towers, hazy sky", [(0, 14), (200, 24)]),
    ("ph_chinese_garden", SHADERCITY, "assets/cubemaps/chinese_garden", "cube", PH,
     "Poly Haven", "garden trees and pavilion, blue sky", [(40, 10), (220, 18)]),
    ("ph_crystal_falls", SHADERCITY, "assets/cubemaps/crystal_falls", "cube", PH,
     "Poly Haven", "forest canopy over a stream", [(180, 24)]),
    ("ph_dusseldorf_bridge", SHADERCITY, "assets/cubemaps/dusseldorf_bridge", "cube", PH,
     "Poly Haven", "riverside buildings, hazy blue sky", [(0, 6), (150, 16), (270, 26)]),
    ("ph_gray_pier", SHADERCITY, "assets/cubemaps/gray_pier", "cube", PH,
     "Poly Haven", "bare trees over a pond, grey overcast", [(0, 6), (120, 14), (240, 22)]),
    ("ph_kloppenheim_04", SHADERCITY, "assets/cubemaps/kloppenheim_04", "cube", PH,
     "Poly Haven", "open field, misty overcast sky", [(0, 5), (90, 12), (180, 20), (270, 30)]),
    ("ph_misty_pines", SHADERCITY, "assets/cubemaps/misty_pines", "cube", PH,
     "Poly Haven", "pine forest in fog", [(0, 8), (180, 18)]),
    ("ph_modern_buildings", SHADERCITY, "assets/cubemaps/modern_buildings", "cube", PH,
     "Poly Haven", "glass office buildings, blue sky with cirrus", [(240, 22)]),
    ("ph_mossy_forest", SHADERCITY, "assets/cubemaps/mossy_forest", "cube", PH,
     "Poly Haven", "dense broadleaf forest", [(0, 14), (200, 26)]),
    ("ph_neuer_zollhof", SHADERCITY, "assets/cubemaps/neuer_zollhof", "cube", PH,
     "Poly Haven", "riverside buildings, blue sky", [(0, 12), (180, 8), (270, 24)]),
    ("ph_ninomaru_teien", SHADERCITY, "assets/cubemaps/ninomaru_teien", "cube", PH,
     "Poly Haven", "Japanese garden trees, bright sky", [(0, 16), (180, 10)]),
    ("ph_pink_sunrise", SHADERCITY, "assets/cubemaps/pink_sunrise", "cube", PH,
     "Poly Haven", "rocky hill and shrubs, dawn sky", [(90, 10), (270, 20)]),
    ("ph_portland_landing_pad", SHADERCITY, "assets/cubemaps/portland_landing_pad", "cube", PH,
     "Poly Haven", "rooftop with city towers, overcast", [(0, 10), (150, 20), (270, 6)]),
    ("ph_potsdamer_platz", SHADERCITY, "assets/cubemaps/potsdamer_platz", "cube", PH,
     "Poly Haven", "city square with towers, overcast", [(60, 16), (240, 8)]),
    ("ph_rhodes_memorial", SHADERCITY, "assets/cubemaps/rhodes_memorial", "cube", PH,
     "Poly Haven", "trees and distant city, blue sky with cumulus", [(0, 10), (120, 18), (240, 6)]),
    ("ph_river_walk_1", SHADERCITY, "assets/cubemaps/river_walk_1", "cube", PH,
     "Poly Haven", "riverside woodland, foliage", [(0, 16), (180, 8)]),
    ("ph_roof_garden", SHADERCITY, "assets/cubemaps/roof_garden", "cube", PH,
     "Poly Haven", "trees and shrubs, bright sky", [(270, 20)]),
    ("ph_roofless_ruins", SHADERCITY, "assets/cubemaps/roofless_ruins", "cube", PH,
     "Poly Haven", "stone ruins and palms under cloud", [(0, 10), (200, 22)]),
    ("ph_san_giuseppe_bridge", SHADERCITY, "assets/cubemaps/san_giuseppe_bridge", "cube", PH,
     "Poly Haven", "canal houses, blue sky", [(60, 14), (240, 22)]),
    ("ph_schadowplatz", SHADERCITY, "assets/cubemaps/schadowplatz", "cube", PH,
     "Poly Haven", "office buildings, overcast", [(0, 12)]),
    ("ph_shady_patch", SHADERCITY, "assets/cubemaps/shady_patch", "cube", PH,
     "Poly Haven", "trees over a meadow", [(0, 6), (120, 12), (240, 20)]),
    ("ph_sunset_forest", SHADERCITY, "assets/cubemaps/sunset_forest", "cube", PH,
     "Poly Haven", "pine forest edge, evening", [(0, 8), (180, 16)]),
    ("ph_tears_of_steel_bridge", SHADERCITY, "assets/cubemaps/tears_of_steel_bridge", "cube", PH,
     "Poly Haven", "autumn trees and houses, blue sky", [(0, 12), (120, 20), (240, 8)]),
    ("ph_teufelsberg_roof", SHADERCITY, "assets/cubemaps/teufelsberg_roof", "cube", PH,
     "Poly Haven", "hilltop, radomes and tree line, cloudy sky", [(150, 18), (270, 6)]),
    ("ph_the_sky_is_on_fire", SHADERCITY, "assets/cubemaps/the_sky_is_on_fire", "cube", PH,
     "Poly Haven", "low horizon, sunset cloud", [(0, 6), (120, 14)]),
    ("ph_ulmer_muenster", SHADERCITY, "assets/cubemaps/ulmer_muenster", "cube", PH,
     "Poly Haven", "square with trees and buildings, blue sky", [(0, 16), (180, 10)]),
]

FACES = ("posx", "negx", "posy", "negy", "posz", "negz")


def git_blob(git_dir: str, commit: str, path: str) -> bytes:
    return subprocess.run(
        ["git", f"--git-dir={git_dir}", "show", f"{commit}:{path}"],
        check=True, capture_output=True,
    ).stdout


def git_ls(git_dir: str, commit: str, folder: str) -> list[str]:
    out = subprocess.run(
        ["git", f"--git-dir={git_dir}", "ls-tree", "--name-only", commit, folder + "/"],
        check=True, capture_output=True, text=True,
    ).stdout
    return [line.rsplit("/", 1)[-1] for line in out.splitlines()]


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def load_cube(git_dir: str, commit: str, folder: str) -> dict[str, np.ndarray]:
    names = git_ls(git_dir, commit, folder)
    faces = {}
    for face in FACES:
        file = next(n for n in names if n.rsplit(".", 1)[0] == face)
        im = Image.open(io.BytesIO(git_blob(git_dir, commit, f"{folder}/{file}"))).convert("RGB")
        faces[face] = srgb_to_linear(np.asarray(im, dtype=np.float64) / 255.0)
    return faces


def bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """img[h, w, 3] at continuous pixel coordinates (x, y), pixel centres at i + 0.5, clamped."""
    h, w, _ = img.shape
    x = np.clip(x - 0.5, 0.0, w - 1.0)
    y = np.clip(y - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


def sample_cube(faces: dict[str, np.ndarray], d: np.ndarray) -> np.ndarray:
    """Cube map lookup (OpenGL convention; +y up) of unit directions d[..., 3]."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    out = np.zeros(d.shape[:-1] + (3,))
    # (mask, face, sc, tc, ma)
    cases = [
        ((ax >= ay) & (ax >= az) & (x > 0), "posx", -z, -y, ax),
        ((ax >= ay) & (ax >= az) & (x <= 0), "negx", z, -y, ax),
        ((ay > ax) & (ay >= az) & (y > 0), "posy", x, z, ay),
        ((ay > ax) & (ay >= az) & (y <= 0), "negy", x, -z, ay),
        ((az > ax) & (az > ay) & (z > 0), "posz", x, -y, az),
        ((az > ax) & (az > ay) & (z <= 0), "negz", -x, -y, az),
    ]
    for mask, face, sc, tc, ma in cases:
        if not mask.any():
            continue
        img = faces[face]
        h, w, _ = img.shape
        u = (sc[mask] / ma[mask] + 1) * 0.5 * w
        v = (tc[mask] / ma[mask] + 1) * 0.5 * h
        out[mask] = bilinear(img, u, v)
    return out


def view_dirs(yaw_deg: float, elev_deg: float, ss: int = 2) -> np.ndarray:
    """Unit ray directions [H*ss, W*ss, 3] of the plate's camera (x right, y up, z ahead)."""
    f = (W / 2) / math.tan(math.radians(HFOV_DEG) / 2)
    xs = (np.arange(W * ss) + 0.5) / ss
    ys = (np.arange(H * ss) + 0.5) / ss
    px, py = np.meshgrid(xs - W / 2, ys - H / 2)
    cam = np.stack([px / f, -py / f, np.ones_like(px)], axis=-1)
    e, a = math.radians(elev_deg), math.radians(yaw_deg)
    # pitch up about x, then yaw about y
    rx = np.array([[1, 0, 0], [0, math.cos(e), math.sin(e)], [0, -math.sin(e), math.cos(e)]])
    ry = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    d = cam @ (ry @ rx).T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def horizon_row(elev_deg: float) -> float:
    f = (W / 2) / math.tan(math.radians(HFOV_DEG) / 2)
    return (H / 2 + f * math.tan(math.radians(elev_deg))) / H


def render(faces, yaw: float, elev: float) -> Image.Image:
    lin = sample_cube(faces, view_dirs(yaw, elev, 1))
    srgb = linear_to_srgb(lin)
    return Image.fromarray(np.round(srgb * 255).astype(np.uint8), "RGB")


def find_git_dir(repo: str, given: dict[str, str]) -> str:
    if repo in given:
        return given[repo]
    for cand in (f"/work/.mirror/{repo.replace('/', '+')}/repo",
                 os.path.expanduser(f"~/src/{repo.split('/')[1]}/.git")):
        if os.path.isdir(cand):
            return cand
    sys.exit(f"make_plates: no git directory for {repo}: pass --repo {repo}=GIT_DIR")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--out", default="assets/plates")
    ap.add_argument("--repo", action="append", default=[], help="OWNER/NAME=GIT_DIR")
    ap.add_argument("--only", help="render only this panorama's plates")
    ap.add_argument("--sheet", help="also write a contact sheet (PNG) of the plates")
    args = ap.parse_args()
    given = dict(r.split("=", 1) for r in args.repo)
    os.makedirs(args.out, exist_ok=True)
    thumbs = []
    for name, (repo, commit), path, kind, _lic, _author, _what, views in SOURCES:
        if args.only and name != args.only:
            continue
        git_dir = find_git_dir(repo, given)
        faces = load_cube(git_dir, commit, path)
        for k, (yaw, elev) in enumerate(views):
            stem = f"{name}_{k + 1}"
            im = render(faces, yaw, elev)
            jpg = os.path.join(args.out, stem + ".jpg")
            im.save(jpg, "JPEG", quality=JPEG_QUALITY, subsampling=2, optimize=True)
            with open(os.path.join(args.out, stem + ".plate.ron"), "w") as fh:
                fh.write(
                    f"// {name}, yaw {yaw} deg, line of sight {elev} deg above the horizon:\n"
                    f"// the horizon row is exact (scripts/plates/make_plates.py).\n"
                    f"(hfov_deg: {HFOV_DEG:.1f}, horizon: Row({horizon_row(elev):.6f}))\n")
            digest = hashlib.sha256(open(jpg, "rb").read()).hexdigest()[:12]
            print(f"{stem}.jpg  yaw {yaw:>3}  elev {elev:>2}  horizon Row({horizon_row(elev):.4f})  {os.path.getsize(jpg) // 1024} KiB  sha256 {digest}")
            thumbs.append((stem, im.resize((256, 144), Image.BILINEAR)))
    if args.sheet and thumbs:
        cols = 6
        rows = (len(thumbs) + cols - 1) // cols
        sheet = Image.new("RGB", (cols * 260, rows * 162), "black")
        draw = ImageDraw.Draw(sheet)
        for i, (stem, th) in enumerate(thumbs):
            x, y = (i % cols) * 260, (i // cols) * 162
            sheet.paste(th, (x, y + 14))
            draw.text((x + 2, y), stem, fill="white")
        sheet.save(args.sheet)


if __name__ == "__main__":
    main()
