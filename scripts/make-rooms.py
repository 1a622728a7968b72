#!/usr/bin/env python3
"""Writes the interiors of scenes/meeting-room.toml, scenes/stone-church.toml and
scenes/living-room.toml as OBJ models (scenes/models/<name>.obj + .mtl), made of boxes.

They are the kinds of scene a GI technique meets outside a Cornell box: a closed room full of
small furniture lit by ceiling downlights (no light from outside at all), a stone nave with
thick walls lit only by the sun through its windows, and a furnished room lit by the sun
through one window. Lengths in metres, y up. Run it again after changing it:

    python3 scripts/make-rooms.py
"""
import os

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "scenes", "models")


class Model:
    def __init__(self, name):
        self.name = name
        self.lines = []
        self.materials = {}
        self.vertices = 0
        self.triangles = 0
        self.current = None

    def material(self, name, albedo):
        self.materials[name] = albedo
        if self.current != name:
            self.lines.append(f"usemtl {name}")
            self.current = name

    def box(self, lo, hi, faces="xXyYzZ"):
        """An axis-aligned box from lo to hi, faces outward; `faces` picks which of its six
        faces exist (x: -x, X: +x, ...)."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        assert x0 < x1 and y0 < y1 and z0 < z1, (lo, hi)
        quads = {
            "x": [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],
            "X": [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)],
            "y": [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
            "Y": [(x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (x0, y1, z0)],
            "z": [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)],
            "Z": [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
        }
        for f in faces:
            self.quad(quads[f])

    def quad(self, corners):
        for v in corners:
            self.lines.append("v %.4f %.4f %.4f" % v)
        b = self.vertices + 1
        self.vertices += 4
        self.lines.append(f"f {b} {b + 1} {b + 2}")
        self.lines.append(f"f {b} {b + 2} {b + 3}")
        self.triangles += 2

    def wall_with_openings(self, axis, at, thickness, span, height, openings):
        """A wall across `axis` ('x' or 'z') at `at` (its inner face), `thickness` thick,
        over `span` (lo, hi) along the other horizontal axis and `height` (lo, hi), with
        rectangular `openings` [(a0, a1, y0, y1)] cut through it."""
        a_lo, a_hi = span
        y_lo, y_hi = height
        # Split the wall into columns between openings, and each opening's column into the
        # parts below and above it.
        cuts = sorted({a_lo, a_hi, *[o[0] for o in openings], *[o[1] for o in openings]})
        for a0, a1 in zip(cuts, cuts[1:]):
            holes = [o for o in openings if o[0] <= a0 and a1 <= o[1]]
            spans = [(y_lo, y_hi)]
            for _, _, h0, h1 in holes:
                spans = [(s0, min(s1, h0)) for s0, s1 in spans] + [(max(s0, h1), s1) for s0, s1 in spans]
            for s0, s1 in spans:
                if s1 - s0 > 1e-6:
                    self.slab(axis, at, thickness, (a0, a1), (s0, s1))

    def slab(self, axis, at, thickness, span, height):
        a0, a1 = span
        y0, y1 = height
        t0, t1 = sorted((at, at + thickness))
        if axis == "x":
            self.box((t0, y0, a0), (t1, y1, a1))
        else:
            self.box((a0, y0, t0), (a1, y1, t1))

    def write(self):
        os.makedirs(OUT, exist_ok=True)
        with open(os.path.join(OUT, self.name + ".mtl"), "w") as f:
            for name, (r, g, b) in self.materials.items():
                f.write(f"newmtl {name}\nKd {r} {g} {b}\n\n")
        with open(os.path.join(OUT, self.name + ".obj"), "w") as f:
            f.write(f"# written by scripts/make-rooms.py; {self.triangles} triangles\n")
            f.write(f"mtllib {self.name}.mtl\no {self.name}\n")
            f.write("\n".join(self.lines) + "\n")
        print(f"{self.name}: {self.triangles} triangles")


def chair(m, x, z, facing):
    """A chair at (x, z) whose sitter faces +z (facing=1) or -z (facing=-1)."""
    s = 0.22
    for dx in (-s + 0.02, s - 0.02):
        for dz in (-s + 0.02, s - 0.02):
            m.box((x + dx - 0.02, 0.0, z + dz - 0.02), (x + dx + 0.02, 0.43, z + dz + 0.02))
    m.box((x - s, 0.43, z - s), (x + s, 0.48, z + s))
    back_z = z - facing * s
    m.box((x - s, 0.48, min(back_z, back_z + facing * 0.04)), (x + s, 0.95, max(back_z, back_z + facing * 0.04)))


def meeting_room():
    """8 x 2.7 x 5 m, closed on every side; a 5 m table with 16 chairs; lit only by four
    downlights under the ceiling (scenes/meeting-room.toml)."""
    m = Model("meeting-room")
    w, h, d, t = 4.0, 2.7, 2.5, 0.2
    m.material("wall", (0.7, 0.68, 0.65))
    m.box((-w - t, 0.0, -d - t), (-w, h, d + t))
    m.box((w, 0.0, -d - t), (w + t, h, d + t))
    m.box((-w, 0.0, -d - t), (w, h, -d))
    m.box((-w, 0.0, d), (w, h, d + t))
    m.material("ceiling", (0.8, 0.8, 0.8))
    m.box((-w - t, h, -d - t), (w + t, h + t, d + t))
    m.material("carpet", (0.25, 0.28, 0.35))
    m.box((-w - t, -t, -d - t), (w + t, 0.0, d + t))
    m.material("wood", (0.45, 0.3, 0.18))
    m.box((-2.5, 0.72, -0.7), (2.5, 0.77, 0.7))
    for x in (-2.3, 2.3):
        for z in (-0.55, 0.55):
            m.box((x - 0.05, 0.0, z - 0.05), (x + 0.05, 0.72, z + 0.05))
    m.material("chair", (0.15, 0.15, 0.17))
    for i in range(7):
        x = -2.1 + i * 0.7
        chair(m, x, -1.05, 1)
        chair(m, x, 1.05, -1)
    for x, facing in ((-2.95, 1), (2.95, 1)):
        chair(m, x, 0.0, facing)
    m.write()


def stone_church():
    """A nave 8 m wide, 20 m long and 10 m high inside, stone walls 0.8 m thick with five
    tall windows a side and a west door, two rows of pillars; lit only by the sun through
    the openings (scenes/stone-church.toml)."""
    m = Model("stone-church")
    w, h, d, t = 4.0, 10.0, 10.0, 0.8
    m.material("stone", (0.55, 0.5, 0.42))
    windows = [(z - 0.8, z + 0.8, 3.5, 8.5) for z in (-7.0, -3.5, 0.0, 3.5, 7.0)]
    m.wall_with_openings("x", -w - t, t, (-d, d), (0.0, h), windows)
    m.wall_with_openings("x", w, t, (-d, d), (0.0, h), windows)
    # West end (-z) with a door, east end (+z) closed.
    m.wall_with_openings("z", -d - t, t, (-w - t, w + t), (0.0, h), [(-1.0, 1.0, 0.0, 3.5)])
    m.slab("z", d, t, (-w - t, w + t), (0.0, h))
    m.box((-w - t, h, -d - t), (w + t, h + t, d + t))
    m.material("floor", (0.4, 0.38, 0.35))
    m.box((-w - t - 6.0, -0.3, -d - t - 6.0), (w + t + 6.0, 0.0, d + t + 6.0))
    m.material("stone", (0.55, 0.5, 0.42))
    for z in (-6.0, -2.0, 2.0, 6.0):
        for x in (-2.2, 2.2):
            m.box((x - 0.35, 0.0, z - 0.35), (x + 0.35, h, z + 0.35))
    m.material("wood", (0.35, 0.22, 0.12))
    for z in range(-5, 8, 2):
        for x0, x1 in ((-1.9, -0.6), (0.6, 1.9)):
            m.box((x0, 0.0, z - 0.25), (x1, 0.45, z + 0.25))
            m.box((x0, 0.45, z + 0.2), (x1, 0.95, z + 0.25))
    m.write()


def living_room():
    """6 x 2.6 x 5 m with one window wall (a 2.4 x 1.6 m opening facing +x), a sofa, a low
    table, shelves and a rug; lit only by the sun through the window
    (scenes/living-room.toml)."""
    m = Model("living-room")
    w, h, d, t = 3.0, 2.6, 2.5, 0.2
    m.material("wall", (0.8, 0.78, 0.72))
    m.wall_with_openings("x", w, t, (-d - t, d + t), (0.0, h), [(-1.2, 1.2, 0.8, 2.4)])
    m.box((-w - t, 0.0, -d - t), (-w, h, d + t))
    m.box((-w, 0.0, -d - t), (w, h, -d))
    m.box((-w, 0.0, d), (w, h, d + t))
    m.box((-w - t, h, -d - t), (w + t, h + t, d + t))
    m.material("floor", (0.55, 0.4, 0.28))
    m.box((-w - t, -t, -d - t), (w + t + 8.0, 0.0, d + t))
    m.material("sofa", (0.3, 0.35, 0.5))
    m.box((-2.9, 0.0, -1.2), (-2.0, 0.42, 1.2))
    m.box((-2.9, 0.42, -1.2), (-2.7, 0.85, 1.2))
    for z0, z1 in ((-1.4, -1.2), (1.2, 1.4)):
        m.box((-2.9, 0.0, z0), (-2.0, 0.6, z1))
    m.material("wood", (0.5, 0.35, 0.2))
    m.box((-1.5, 0.35, -0.6), (-0.7, 0.4, 0.6))
    for x in (-1.45, -0.75):
        for z in (-0.55, 0.55):
            m.box((x - 0.03, 0.0, z - 0.03), (x + 0.03, 0.35, z + 0.03))
    m.box((-1.0, 0.0, -2.5), (1.6, 2.0, -2.1), faces="xXyYZ")
    for y in (0.4, 0.8, 1.2, 1.6):
        m.material("books", (0.6, 0.25, 0.2))
        m.box((-0.9, y + 0.02, -2.45), (1.5, y + 0.3, -2.2))
        m.material("wood", (0.5, 0.35, 0.2))
    m.material("rug", (0.7, 0.6, 0.4))
    m.box((-2.0, 0.0, -1.5), (0.5, 0.01, 1.5))
    m.write()


if __name__ == "__main__":
    meeting_room()
    stone_church()
    living_room()
