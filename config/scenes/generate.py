#!/usr/bin/env python3
"""Writes the built-in example scenes (and the heightfield image one of them uses).

The scenes follow figures of Génevaux et al. 2015. They are generated rather than typed because
some hold a hundred primitives; the output is committed and deterministic (fixed seeds), so
running this again changes nothing unless the script changes.
"""
import json
import math
import random
import struct
import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent


def write(name, scene):
    scene = {"format": "terrain-scene/1", **scene}
    (HERE / f"{name}.json").write_text(json.dumps(scene, indent=1) + "\n")


def r1(v):
    return round(v, 1)


def hills_river():
    """Fig 3: hills crossed by a river carved with a replacement operator."""
    rng = random.Random(3)
    hills = [{"type": "disc", "id": "plain", "center": [0, 0], "radius": 5200, "elevation": 90,
              "noise": {"kind": "fbm", "amplitude": 25, "wavelength": 1600, "octaves": 7, "seed": 1}}]
    for i in range(12):
        x, y = rng.uniform(-2400, 2400), rng.uniform(-2400, 2400)
        if abs(y - 250 * math.sin(x / 700)) < 500:
            y += 900 if y >= 0 else -900
        hills.append({"type": "disc", "center": [r1(x), r1(y)], "radius": r1(rng.uniform(700, 1300)),
                      "elevation": r1(rng.uniform(140, 260)),
                      "noise": {"kind": "fbm", "amplitude": r1(rng.uniform(40, 90)),
                                "wavelength": r1(rng.uniform(500, 900)), "octaves": 8, "seed": 10 + i}})
    pieces = []
    xs = [-3000, -1800, -600, 600, 1800, 3000]
    pts = [(x, 250 * math.sin(x / 700), 80 - (x + 3000) / 6000 * 25) for x in xs]
    for a, b in zip(pts, pts[1:]):
        mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2 + (380 if len(pieces) % 2 == 0 else -380)
        pieces.append([[r1(a[0]), r1(a[1]), r1(a[2])], [r1(mx), r1(my), r1((a[2] + b[2]) / 2)],
                       [r1(b[0]), r1(b[1]), r1(b[2])]])
    river = {"type": "curve", "id": "river", "falloff": 420, "pieces": pieces,
             # Symmetric profiles at the ends: behind an open curve's end the side of the
             # signed distance flips, which an asymmetric (meander) profile would show as a step.
             "profiles": [{"at": 0, "preset": "stream", "width": 10, "depth": 2},
                          {"at": 0.5, "preset": "meander", "width": 30, "depth": 4, "bank_width": 45,
                           "asymmetry": 0.5},
                          {"at": 1, "preset": "river", "width": 45, "depth": 6, "bank_width": 60}]}
    write("hills-river", {
        "name": "Hills crossed by a river (Génevaux Fig. 3)", "seed": 3,
        "extent": {"min": [-3000, -3000], "max": [3000, 3000]},
        "georeference": {"latitude": 45.9237, "longitude": 6.8694, "heading": 0},
        "root": {"type": "replace", "children": [{"type": "blend", "children": hills}, river]}})


def craters():
    """Fig 12: craters placed by successive replacements (the last one is the most recent)."""
    rng = random.Random(12)
    node = {"type": "disc", "id": "mare", "center": [0, 0], "radius": 6000, "elevation": 0,
            "noise": {"kind": "fbm", "amplitude": 12, "wavelength": 900, "octaves": 9, "seed": 2}}
    for i in range(14):
        r = rng.uniform(180, 900) if i < 10 else rng.uniform(80, 200)
        k = rng.randint(6, 10)
        crater = {"type": "contour", "center": [r1(rng.uniform(-2300, 2300)), r1(rng.uniform(-2300, 2300))],
                  "elevation": r1(rng.uniform(-2, 4)), "orientation": r1(rng.uniform(0, 360)),
                  "radii": [r1(r * rng.uniform(0.9, 1.1)) for _ in range(k)],
                  "profiles": [{"preset": "crater", "depth": r1(r * 0.22), "rim_height": r1(r * 0.07),
                                "rim_width": 0.45}],
                  "falloff": 1.7}
        node = {"type": "replace", "children": [node, crater]}
    write("craters", {"name": "Craters by replacement (Génevaux Fig. 12)", "seed": 12,
                      "extent": {"min": [-2800, -2800], "max": [2800, 2800]},
                      "georeference": {"latitude": 35.0275, "longitude": -111.0225, "heading": 0},
                      "root": node})


def ground(x, y):
    return 160 + 90 * math.sin(x / 1500 + 0.4) * math.cos(y / 1700) + 40 * math.sin((x + y) / 900)


def winding_road():
    """Fig 22 (and Fig 1's scale): a hundred disc hills, a road of twenty quadric pieces levelling
    the terrain by replacement, and discs along it easing the road into the hills."""
    rng = random.Random(22)
    discs = []
    for i in range(100):
        x, y = rng.uniform(-3600, 3600), rng.uniform(-3600, 3600)
        discs.append({"type": "disc", "center": [r1(x), r1(y)], "radius": r1(rng.uniform(600, 1200)),
                      "elevation": r1(ground(x, y)),
                      "noise": {"kind": rng.choice(["fbm", "fbm", "ridged"]),
                                "amplitude": r1(rng.uniform(15, 45)), "wavelength": r1(rng.uniform(300, 800)),
                                "octaves": 7, "seed": 100 + i}})
    # The road: a smooth loop-free trajectory through twenty quadratic pieces.
    pts = []
    for k in range(21):
        t = k / 20
        x = -3400 + 6800 * t
        y = 1400 * math.sin(2.2 * math.pi * t) + 300 * math.sin(7 * t)
        pts.append((x, y))
    z = [ground(x, y) for x, y in pts]
    z = [sum(z[max(0, k - 2):k + 3]) / len(z[max(0, k - 2):k + 3]) for k in range(len(z))]  # gentle grade
    pieces, helpers = [], []
    for k in range(20):
        (ax, ay), (bx, by) = pts[k], pts[k + 1]
        # Control point on the tangent line keeps consecutive pieces C1.
        if k == 0:
            cx, cy = (ax + bx) / 2, (ay + by) / 2
        else:
            px, py = prev_control
            cx, cy = 2 * ax - px, 2 * ay - py
            # Pull the control point towards the chord midpoint so the curve stays tame.
            cx, cy = 0.5 * cx + 0.25 * (ax + bx), 0.5 * cy + 0.25 * (ay + by)
        prev_control = (cx, cy)
        pieces.append([[r1(ax), r1(ay), r1(z[k])], [r1(cx), r1(cy), r1((z[k] + z[k + 1]) / 2)],
                       [r1(bx), r1(by), r1(z[k + 1])]])
        if k % 4 == 2:
            helpers.append({"type": "disc", "center": [r1(bx), r1(by + 160)], "radius": 260,
                            "elevation": r1(z[k + 1] + 4)})
    road = {"type": "curve", "id": "road", "core": 6, "falloff": 70, "pieces": pieces,
            "profiles": [{"preset": "road", "width": 12, "carriageway": 7, "embankment": 14, "crown": 0.1}]}
    write("winding-road", {
        "name": "A winding road levelled into a hundred hills (Génevaux Figs. 1, 22)", "seed": 22,
        # Where the hills leave gaps, the blend falls back to this level: the mean ground height.
        "base_elevation": 150,
        "extent": {"min": [-3600, -3600], "max": [3600, 3600]},
        "georeference": {"latitude": 43.7034, "longitude": 7.2663, "heading": 0},
        "root": {"type": "replace", "children": [{"type": "blend", "children": discs + helpers}, road]}})


def lake_dunes():
    """Fig 21: a lake from a contour primitive, with dunes added by an addition operator."""
    rng = random.Random(21)
    land = {"type": "blend", "children": [
        {"type": "disc", "center": [0, 0], "radius": 5000, "elevation": 110,
         "noise": {"kind": "fbm", "amplitude": 20, "wavelength": 1400, "octaves": 7, "seed": 1}},
        {"type": "disc", "center": [1900, 1700], "radius": 1500, "elevation": 210,
         "noise": {"kind": "ridged", "amplitude": 120, "wavelength": 900, "octaves": 8, "seed": 2}}]}
    lake = {"type": "contour", "id": "lake", "center": [-500, -300], "elevation": 112, "orientation": 20,
            "radii": [r1(1000 * rng.uniform(0.75, 1.25)) for _ in range(12)],
            "profiles": [{"preset": "lake", "depth": 18, "shore_width": 0.3},
                         {"preset": "lake", "depth": 18, "shore_width": 0.55}],
            "falloff": 1.6}
    dunes = {"type": "transform", "translate": [1200, -1600], "rotate": 35, "scale": [1, 3],
             "children": [{"type": "disc", "id": "dunes", "center": [0, 0], "radius": 700, "elevation": 0,
                           "noise": {"kind": "ridged", "basis": "simplex", "amplitude": 9,
                                     "wavelength": 160, "octaves": 4, "seed": 7}}]}
    write("lake-dunes", {
        "name": "A lake and dunes (Génevaux Fig. 21)", "seed": 21,
        "extent": {"min": [-3000, -3000], "max": [3000, 3000]},
        "georeference": {"latitude": 44.5886, "longitude": -1.2131, "heading": 0},
        # The water layer (Génevaux Fig. 20): a level surface over the lake; the water mask is
        # where it has weight and lies above the ground.
        "water": {"type": "disc", "id": "lake-water", "center": [-500, -300], "radius": 3200,
                  "elevation": 108},
        "root": {"type": "add", "children": [{"type": "replace", "children": [land, lake]}, dunes]}})


def mountain_range():
    """Fig 23: about thirty instances of one mountain patch, each placed, turned, scaled and
    warped differently."""
    rng = random.Random(23)
    mountain = {"type": "disc", "center": [0, 0], "radius": 900, "elevation": 250,
                "noise": {"kind": "ridged", "amplitude": 420, "wavelength": 1100, "octaves": 9,
                          "lacunarity": 2.05, "hurst": 0.9, "seed": 5}}
    instances = []
    for i in range(30):
        t = i / 29
        x = -3800 + 7600 * t + rng.uniform(-250, 250)
        y = 900 * math.sin(3.5 * t) + rng.uniform(-700, 700)
        instances.append({"type": "transform", "translate": [r1(x), r1(y)], "rotate": r1(rng.uniform(-180, 180)),
                          "scale": r1(rng.uniform(0.8, 1.6)), "elevation_scale": r1(rng.uniform(0.6, 1.4)),
                          "children": [{"type": "warp", "noise": {"kind": "fbm", "amplitude": 40,
                                                                   "wavelength": 1800, "octaves": 3, "seed": i},
                                        "children": [{"ref": "mountain"}]}]})
    valley = {"type": "disc", "center": [0, 0], "radius": 6500, "elevation": 120,
              "noise": {"kind": "fbm", "amplitude": 30, "wavelength": 1500, "octaves": 7, "seed": 99}}
    write("mountain-range", {
        "name": "A range of thirty instanced, warped mountains (Génevaux Fig. 23)", "seed": 23,
        "extent": {"min": [-4500, -4500], "max": [4500, 4500]},
        "georeference": {"latitude": 46.5375, "longitude": 7.9625, "heading": 15},
        "definitions": {"mountain": mountain},
        "root": {"type": "blend", "children": [valley] + instances}})


def png16(path, width, height, samples):
    raw = b"".join(b"\x00" + b"".join(struct.pack(">H", samples[y * width + x]) for x in range(width))
                   for y in range(height))
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def mesa_image():
    """Fig 8: a real-looking heightfield (a butte with eroded gullies, made here) on a quadrangle,
    with a LoD operator that swaps in fine sand ripples only when sampled finely."""
    n = 129
    samples = []
    for j in range(n):
        for i in range(n):
            u, v = i / (n - 1) - 0.5, j / (n - 1) - 0.5
            r = math.hypot(u, v)
            a = math.atan2(v, u)
            edge = 0.28 + 0.03 * math.sin(7 * a) + 0.015 * math.sin(17 * a)
            h = 1 / (1 + math.exp((r - edge) * 40))             # cliffs
            h = 0.25 * max(0.0, 0.5 - r) + 0.75 * h            # talus apron
            h -= 0.05 * max(0.0, math.sin(23 * a)) * max(0.0, r - edge + 0.05) * 8  # gullies
            samples.append(max(0, min(65535, int(round(max(0.0, h) * 60000)))))
    png16(HERE / "images" / "butte.png", n, n, samples)
    desert = {"type": "disc", "center": [0, 0], "radius": 4000, "elevation": 300,
              "noise": {"kind": "fbm", "amplitude": 15, "wavelength": 1200, "octaves": 6, "seed": 3}}
    butte = {"type": "image", "id": "butte", "image": "images/butte.png",
             "corners": [[-900, 850], [950, 900], [900, -950], [-950, -900]],
             "elevation": 300, "height_scale": 280, "margin": 0.08}
    ripples = {"type": "lod", "coarse_spacing": 8, "fine_spacing": 2, "children": [
        {"type": "disc", "center": [0, 0], "radius": 4000, "elevation": 0},
        {"type": "disc", "center": [0, 0], "radius": 4000, "elevation": 0,
         "noise": {"kind": "ridged", "amplitude": 0.6, "wavelength": 12, "octaves": 3, "seed": 4}}]}
    write("butte", {
        "name": "A butte from a heightfield image, sand ripples by level of detail (Génevaux Figs. 8, 16)",
        "seed": 8, "extent": {"min": [-2000, -2000], "max": [2000, 2000]},
        "georeference": {"latitude": 36.9980, "longitude": -110.0985, "heading": 0},
        # Monument Valley's colours (docs/material.md): red sand and sandstone, no trees, no snow.
        "material": {"grass": "#c8956a", "forest": "#bd8159", "meadow": "#b06f48",
                     "bare_ground": "#a45c38", "scree": "#c28a60", "rock": "#8e4a2d",
                     "sand": "#d8b48a", "snow_line": 2},
        "root": {"type": "add", "children": [
            {"type": "replace", "weight": "keep", "children": [desert, butte]}, ripples]}})


def erosion(children, size, **params):
    return {"type": "erosion", "resolution": 512, "center": [0, 0], "size": size, "diffusion": 6,
            "talus_angle": 65, **params,
            "children": [{"type": "blend", "children": children}]}


def alpine_valleys():
    """An alpine valley between two ridged ranges that fall to the east, their flanks dissected
    by dendritic valleys. The ranges' crests run near the square's north and south edges and the
    valley floor falls to the east as well, so the inner flanks' tributaries join one trunk
    river that leaves by the east edge (with the crests at ±1.5 km and a level floor, most
    valleys ran straight to an edge: R_b 9.0 on two Strahler orders)."""
    rng = random.Random(41)
    peaks = []
    for side in (-1, 1):
        for i in range(7):
            t = i / 6
            x = -2800 + 5600 * t
            y = side * 3200 + 250 * math.sin(3 * t + side) + rng.uniform(-200, 200)
            peaks.append({"type": "disc", "center": [r1(x), r1(y)], "radius": r1(rng.uniform(1100, 1500)),
                          "elevation": r1(rng.uniform(1300, 1900) - 300 * t),
                          "noise": {"kind": "ridged", "amplitude": 600, "wavelength": 1500, "octaves": 6,
                                    "seed": 40 + i + (side + 1) * 10}})
    plain = {"type": "disc", "center": [0, 0], "radius": 7000, "elevation": 400,
             "noise": {"kind": "fbm", "amplitude": 80, "wavelength": 2000, "octaves": 5, "seed": 4}}
    # Blended with the plain, a wide disc centred west of the square tilts the floor east.
    tilt = {"type": "disc", "center": [-9000, 0], "radius": 14000, "elevation": 800}
    write("alpine-valleys", {
        "name": "An alpine valley between two ranges dissected by rivers (erosion)", "seed": 41,
        "extent": {"min": [-4500, -4500], "max": [4500, 4500]},
        "georeference": {"latitude": 46.45, "longitude": 8.05, "heading": 0},
        "root": erosion([plain, tilt] + peaks, 9000, uplift=0.5, strength=0.3, concavity=0.45)})


def river_basin():
    """A basin rimmed by hills on three sides, open to the south: one trunk river and its
    tributaries."""
    rng = random.Random(42)
    rim = []
    for i in range(14):
        a = math.pi * (-0.15 + 1.3 * i / 13)  # from south-east round the north to south-west
        x, y = 3300 * math.cos(a), 3300 * math.sin(a) + 500
        rim.append({"type": "disc", "center": [r1(x), r1(y)], "radius": r1(rng.uniform(1300, 1800)),
                    "elevation": r1(rng.uniform(700, 1000)),
                    "noise": {"kind": "fbm", "amplitude": 250, "wavelength": 1200, "octaves": 6,
                              "seed": 60 + i}})
    floor = {"type": "disc", "center": [0, 0], "radius": 7000, "elevation": 150,
             "noise": {"kind": "fbm", "amplitude": 90, "wavelength": 1600, "octaves": 6, "seed": 5}}
    write("river-basin", {
        "name": "A river basin with tributaries (erosion)", "seed": 42,
        "extent": {"min": [-4000, -4000], "max": [4000, 4000]},
        "georeference": {"latitude": 44.2, "longitude": 4.6, "heading": 0},
        "root": erosion([floor] + rim, 8000, uplift=0.6, strength=0.3, concavity=0.5)})


def coastal_range():
    """A coastal range: ridged hills rising from the sea, drained by short steep rivers."""
    rng = random.Random(43)
    hills = []
    for i in range(8):
        x = -3200 + 6400 * i / 7 + rng.uniform(-200, 200)
        hills.append({"type": "disc", "center": [r1(x), r1(rng.uniform(900, 1900))],
                      "radius": r1(rng.uniform(1400, 2000)), "elevation": r1(rng.uniform(700, 1100)),
                      "noise": {"kind": "ridged", "amplitude": 450, "wavelength": 1100, "octaves": 6,
                                "seed": 80 + i}})
    shelf = {"type": "disc", "center": [0, -5200], "radius": 5600, "elevation": -120,
             "noise": {"kind": "fbm", "amplitude": 40, "wavelength": 1500, "octaves": 4, "seed": 6}}
    land = {"type": "disc", "center": [0, 2600], "radius": 6000, "elevation": 120,
            "noise": {"kind": "fbm", "amplitude": 60, "wavelength": 1800, "octaves": 5, "seed": 7}}
    write("coastal-range", {
        "name": "A coastal range rising from the sea (erosion)", "seed": 43,
        "extent": {"min": [-4000, -4000], "max": [4000, 4000]},
        "georeference": {"latitude": 40.6, "longitude": 14.6, "heading": 0},
        "root": erosion([shelf, land] + hills, 8000, uplift=0.4, strength=0.5, concavity=0.45, sea_level=0)})


def drainage(child, size, **params):
    return {"type": "drainage", "resolution": 512, "center": [0, 0], "size": size, **params,
            "children": [child]}


def river_lake():
    """A river basin: hills ring it but for a gorge in the south, so one trunk river gathers
    every tributary and leaves through the gorge, and the main branches meet in a lake held
    behind a rock sill above it. (With the ring open along the whole south side, three parallel
    rivers drained it, the largest a third of the square, and the short streams of the slopes
    outside the ring joined nothing: R_b 5.35, N2/N3 6.5.)"""
    rng = random.Random(48)
    rim = []
    for i in range(14):
        a = math.pi * (-0.38 + 1.76 * i / 13)  # from south-east round the north to south-west
        x, y = 3600 * math.cos(a) - 300, 3600 * math.sin(a) + 300
        rim.append({"type": "disc", "center": [r1(x), r1(y)], "radius": r1(rng.uniform(1300, 1800)),
                    "elevation": r1(rng.uniform(800, 1150)),
                    "noise": {"kind": "fbm", "amplitude": 250, "wavelength": 1300, "octaves": 6,
                              "seed": 90 + i}})
    floor = {"type": "disc", "center": [0, 0], "radius": 7000, "elevation": 200,
             "noise": {"kind": "fbm", "amplitude": 80, "wavelength": 1700, "octaves": 6, "seed": 9}}
    # Blended with the floor, a wide disc centred north-west of the square tilts it towards the
    # gorge and off the ring's axis, so that the trunk does not run straight down the middle.
    tilt = {"type": "disc", "center": [-5000, 8000], "radius": 14000, "elevation": 300}
    # Less hillslope diffusion than the other valleys: it would round the heads of the channels
    # that the drainage then carves, and their slopes would follow drainage area less.
    valley = erosion([floor] + rim + [tilt], 8000, uplift=0.6, strength=0.3, concavity=0.5,
                     diffusion=1)
    # A glacial basin dug where the branches meet, behind a rock sill at the gorge's head: the
    # drainage keeps it as a lake, and the trunk leaves it over the sill.
    basin = {"type": "add", "children": [
        {"type": "disc", "center": [-300, -1800], "radius": 900, "elevation": -100},
        {"type": "disc", "center": [-300, -2750], "radius": 450, "elevation": 35}]}
    write("river-lake", {
        "name": "A river basin drained through a gorge, its branches meeting in a lake (erosion, "
                "drainage)",
        "seed": 44, "extent": {"min": [-4000, -4000], "max": [4000, 4000]},
        "georeference": {"latitude": 45.9, "longitude": 6.9, "heading": 0},
        "root": drainage({"type": "add", "children": [valley, basin]}, 8000,
                         channel_area=120000, width=4, depth=0.8, lake_depth=2)})


if __name__ == "__main__":
    hills_river()
    craters()
    winding_road()
    lake_dunes()
    mountain_range()
    mesa_image()
    alpine_valleys()
    river_basin()
    coastal_range()
    river_lake()
