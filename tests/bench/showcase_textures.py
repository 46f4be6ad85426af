"""Textures of the showcase scene (make_showcase.py), drawn texel by texel and encoded as
PNG with zlib and struct: Python's standard library only, deterministic for a given
random.Random.

Base colour textures hold sRGB-encoded values (glTF 2.0, 3.9.2); normal and
metallic-roughness maps hold linear ones. Every texture tiles: its noise is periodic and
its patterns repeat at the edges, so meshes can repeat it over metres.
"""
import math
import struct
import zlib


# ---- PNG ----------------------------------------------------------------------------------------

def png_bytes(width, height, channels, pixels):
    """An 8-bit PNG (grey, grey+alpha, RGB or RGBA by `channels`) of `pixels`, a bytearray of
    rows top first, each row filtered with the Paeth-free 'Up' filter for compression."""
    colour_type = {1: 0, 2: 4, 3: 2, 4: 6}[channels]
    stride = width * channels
    raw = bytearray()
    previous = bytes(stride)
    for y in range(height):
        row = pixels[y * stride:(y + 1) * stride]
        raw.append(2)  # Up: each byte minus the one above
        raw.extend(bytes((a - b) & 0xFF for a, b in zip(row, previous)))
        previous = row

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + \
        chunk(b"IEND", b"")


def byte(v):
    v = int(v * 255.0 + 0.5)
    return 0 if v < 0 else 255 if v > 255 else v


def srgb_byte(linear):
    """A linear reflectance as an sRGB-encoded byte (base colour textures are sRGB)."""
    c = max(0.0, min(1.0, linear))
    c = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return byte(c)


# ---- noise ----------------------------------------------------------------------------------------

class TileNoise:
    """Value noise on the unit square, periodic in both axes: octave k has a lattice of
    base * 2^k cells, so every texture made from it tiles seamlessly."""

    def __init__(self, rng, base, octaves, gain=0.5):
        self.levels = []
        amplitude, total = 1.0, 0.0
        for k in range(octaves):
            n = base << k
            self.levels.append((n, [rng.random() for _ in range(n * n)], amplitude))
            total += amplitude
            amplitude *= gain
        self.norm = 1.0 / total

    def image(self, size):
        """size x size values in [0, 1], rows top first."""
        out = [0.0] * (size * size)
        for n, lattice, amplitude in self.levels:
            xs = []
            for x in range(size):
                fx = (x + 0.5) * n / size
                i = int(fx)
                t = fx - i
                xs.append((i % n, (i + 1) % n, t * t * (3 - 2 * t)))
            for y in range(size):
                fy = (y + 0.5) * n / size
                j = int(fy)
                t = fy - j
                sy = t * t * (3 - 2 * t)
                r0 = lattice[(j % n) * n:(j % n) * n + n]
                r1 = lattice[((j + 1) % n) * n:((j + 1) % n) * n + n]
                base = y * size
                for x, (i0, i1, sx) in enumerate(xs):
                    a = r0[i0] + (r0[i1] - r0[i0]) * sx
                    b = r1[i0] + (r1[i1] - r1[i0]) * sx
                    out[base + x] += amplitude * (a + (b - a) * sy)
        norm = self.norm
        return [v * norm for v in out]


def hash01(*ints):
    """A deterministic value in [0, 1) of a few integers (a 32-bit integer hash)."""
    h = 0x9E3779B9
    for v in ints:
        h = (h ^ (v & 0xFFFFFFFF)) * 0x85EBCA6B & 0xFFFFFFFF
        h ^= h >> 13
        h = h * 0xC2B2AE35 & 0xFFFFFFFF
        h ^= h >> 16
    return h / 4294967296.0


def smooth_noise2(x, z, seed):
    """Value noise in the plane (not periodic), for the mound's heights."""
    i, j = math.floor(x), math.floor(z)
    fx, fz = x - i, z - j
    sx, sz = fx * fx * (3 - 2 * fx), fz * fz * (3 - 2 * fz)
    a, b = hash01(i, j, seed), hash01(i + 1, j, seed)
    c, d = hash01(i, j + 1, seed), hash01(i + 1, j + 1, seed)
    top = a + (b - a) * sx
    bottom = c + (d - c) * sx
    return top + (bottom - top) * sz


def normal_map(height, size, strength):
    """A tangent-space normal map (RGB bytes) of a periodic height field in texels: red along
    +u (right), green towards decreasing v (up in the image), as glTF and vcmfarm read it."""
    out = bytearray(size * size * 3)
    for y in range(size):
        up, down = ((y - 1) % size) * size, ((y + 1) % size) * size
        row = y * size
        for x in range(size):
            dx = (height[row + (x + 1) % size] - height[row + (x - 1) % size]) * 0.5 * strength
            dy_down = (height[down + x] - height[up + x]) * 0.5 * strength
            # surface z = h(x, y_up) with y_up = -y: normal (-dh/dx, -dh/dy_up, 1)
            nx, ny, nz = -dx, dy_down, 1.0
            inv = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz)
            k = 3 * (row + x)
            out[k] = byte(0.5 + 0.5 * nx * inv)
            out[k + 1] = byte(0.5 + 0.5 * ny * inv)
            out[k + 2] = byte(0.5 + 0.5 * nz * inv)
    return out


def all_textures(rng, size, small):
    """(name, width, channels, pixels) of every texture: the paving and brick maps at
    `size` texels square, the cut-outs and the soil at `small`."""
    paving_c, paving_mr, paving_n = paving_textures(rng, size)
    brick_c, brick_n = brick_textures(rng, size)
    return [
        ("paving_basecolor", size, 3, paving_c),
        ("paving_metallic_roughness", size, 3, paving_mr),
        ("paving_normal", size, 3, paving_n),
        ("brick_basecolor", size, 3, brick_c),
        ("brick_normal", size, 3, brick_n),
        ("leaf_basecolor", small, 4, leaf_texture(rng, small)),
        ("frond_basecolor", small, 4, frond_texture(rng, small)),
        ("trellis_basecolor", small, 4, trellis_texture(rng, small)),
        ("soil_basecolor", small, 3, soil_texture(rng, small)),
    ]


# ---- textures -------------------------------------------------------------------------------------

def paving_textures(rng, size):
    """Sandstone flagstones in courses of 0.4 m on a 2.4 m tile: base colour, a
    metallic-roughness map (G roughness, B metallic 0) and a normal map."""
    rows = 6
    lengths = [0.4, 0.6, 0.8, 1.2, 0.6, 0.8]
    offsets = [rng.random() for _ in range(rows)]
    noise = TileNoise(rng, 8, 5).image(size)
    grain = TileNoise(rng, 64, 2).image(size)
    grout = 0.012 / 2.4  # half-width of a joint in tile units
    colour = bytearray(size * size * 3)
    mr = bytearray(size * size * 3)
    height = [0.0] * (size * size)
    for y in range(size):
        fy = (y + 0.5) / size
        row = int(fy * rows)
        fr = fy * rows - row
        dist_y = min(fr, 1 - fr) / rows
        length = lengths[row] / 2.4
        for x in range(size):
            fx = ((x + 0.5) / size + offsets[row]) % 1.0
            stone = int(fx / length)
            fs = fx / length - stone
            dist = min(dist_y, min(fs, 1 - fs) * length)
            i = y * size + x
            n, g = noise[i], grain[i]
            if dist < grout:
                h = 0.0
                c = (0.16 + 0.05 * n, 0.15 + 0.05 * n, 0.13 + 0.04 * n)
                rough = 0.95
            else:
                tone = hash01(row, stone, 7)
                bevel = min(1.0, (dist - grout) / (2.5 * grout))
                h = 0.4 + 0.6 * bevel + 0.25 * (n - 0.5) + 0.1 * g
                base = 0.34 + 0.16 * tone + 0.12 * (n - 0.5) + 0.05 * (g - 0.5)
                warm = 0.04 * hash01(row, stone, 11)
                c = (base + warm + 0.03, base + 0.01, base * 0.86)
                rough = 0.55 + 0.25 * n + 0.1 * tone
            height[i] = h
            k = 3 * i
            colour[k], colour[k + 1], colour[k + 2] = srgb_byte(c[0]), srgb_byte(c[1]), srgb_byte(c[2])
            mr[k], mr[k + 1], mr[k + 2] = 255, byte(rough), 0
    return colour, mr, normal_map(height, size, 3.0 * size / 512)


def brick_textures(rng, size):
    """Running-bond brick: 4 bricks of 0.25 m a row, 12 courses of 0.075 m on a
    1 m x 0.9 m tile; base colour and normal map."""
    courses, per_row = 12, 4
    noise = TileNoise(rng, 8, 5).image(size)
    grain = TileNoise(rng, 64, 2).image(size)
    mortar_u, mortar_v = 0.005 / 1.0, 0.005 / 0.9
    colour = bytearray(size * size * 3)
    height = [0.0] * (size * size)
    for y in range(size):
        fy = (y + 0.5) / size
        course = int(fy * courses)
        fc = fy * courses - course
        dv = min(fc, 1 - fc) / courses
        shift = 0.5 / per_row if course % 2 else 0.0
        for x in range(size):
            fx = ((x + 0.5) / size + shift) % 1.0
            brick = int(fx * per_row)
            fb = fx * per_row - brick
            du = min(fb, 1 - fb) / per_row
            i = y * size + x
            n, g = noise[i], grain[i]
            if du < mortar_u or dv < mortar_v:
                h = 0.1 * n
                m = 0.42 + 0.1 * n
                c = (m, m * 0.97, m * 0.9)
            else:
                tone = hash01(course, brick, 3)
                edge = min(1.0, min((du - mortar_u) / mortar_u, (dv - mortar_v) / mortar_v) / 1.5)
                h = 0.5 + 0.5 * edge + 0.3 * (g - 0.5)
                r = 0.30 + 0.16 * tone + 0.1 * (n - 0.5) + 0.05 * (g - 0.5)
                c = (r, r * (0.42 + 0.1 * hash01(course, brick, 5)), r * 0.30)
            height[i] = h
            k = 3 * i
            colour[k], colour[k + 1], colour[k + 2] = srgb_byte(c[0]), srgb_byte(c[1]), srgb_byte(c[2])
    return colour, normal_map(height, size, 2.5 * size / 512)


def leaf_texture(rng, size):
    """One leaf, stalk at the bottom edge, tip at the top; alpha 0 around it."""
    noise = TileNoise(rng, 4, 3).image(size)
    out = bytearray(size * size * 4)
    for y in range(size):
        s = 1.0 - (y + 0.5) / size  # 0 at the stalk, 1 at the tip
        if s < 0.1:
            half = 0.025
        else:
            t = (s - 0.1) / 0.9
            half = 0.44 * math.sin(math.pi * t ** 0.75) ** 0.85
        for x in range(size):
            u = (x + 0.5) / size - 0.5
            i = y * size + x
            k = 4 * i
            a = abs(u)
            # serrated edge: small teeth along the margin
            teeth = 0.018 * abs(math.sin(40.0 * s))
            if a > half - teeth:
                continue
            n = noise[i]
            vein = a < 0.012 or (abs(((s - 1.6 * a) * 9.0) % 1.0 - 0.5) < 0.04 and s > 0.12)
            g = 0.16 + 0.10 * n + 0.06 * s
            c = (g * 0.45, g, g * 0.22) if not vein else (g * 0.75, g * 1.25, g * 0.4)
            out[k], out[k + 1], out[k + 2], out[k + 3] = srgb_byte(c[0]), srgb_byte(c[1]), srgb_byte(c[2]), 255
    return out


def frond_texture(rng, size):
    """A fern frond: a stem up the middle, paired leaflets slanting to the tip, shorter
    towards it; holes between them."""
    noise = TileNoise(rng, 4, 3).image(size)
    out = bytearray(size * size * 4)
    pairs = 14
    slant = math.radians(55)
    ca, sa = math.cos(slant), math.sin(slant)
    for y in range(size):
        s = 1.0 - (y + 0.5) / size
        for x in range(size):
            u = (x + 0.5) / size - 0.5
            a = abs(u)
            inside = a < 0.012 * (1.2 - s) and s < 0.98
            if not inside:
                # the leaflet whose base is nearest, in leaflet-local coordinates
                for j in (-1, 0, 1):
                    k = int(s * pairs + 0.5) + j
                    if k < 1 or k >= pairs:
                        continue
                    base_s = k / pairs
                    length = 0.46 * (1.0 - 0.8 * base_s)
                    width = 0.045 * (1.0 - 0.6 * base_s)
                    ds = s - base_s
                    along = a * sa + ds * ca
                    across = -a * ca + ds * sa
                    if 0.0 < along < length and abs(across) < width * math.sin(math.pi * along / length) ** 0.6:
                        inside = True
                        break
            if not inside:
                continue
            i = y * size + x
            n = noise[i]
            g = 0.15 + 0.09 * n + 0.05 * s
            k4 = 4 * i
            out[k4], out[k4 + 1], out[k4 + 2], out[k4 + 3] = srgb_byte(g * 0.5), srgb_byte(g), srgb_byte(g * 0.25), 255
    return out


def trellis_texture(rng, size):
    """Diagonal lattice slats of weathered grey-green paint; holes between them."""
    noise = TileNoise(rng, 8, 4).image(size)
    out = bytearray(size * size * 4)
    cells, slat = 2, 0.16
    for y in range(size):
        fy = (y + 0.5) / size
        for x in range(size):
            fx = (x + 0.5) / size
            p = ((fx + fy) * cells) % 1.0
            q = ((fx - fy) * cells) % 1.0
            on_p = min(p, 1 - p) < slat / 2
            on_q = min(q, 1 - q) < slat / 2
            if not (on_p or on_q):
                continue
            i = y * size + x
            n = noise[i]
            # the slat on top at a crossing is a shade lighter
            v = 0.34 + 0.12 * n + (0.04 if on_p else 0.0)
            k = 4 * i
            out[k], out[k + 1], out[k + 2], out[k + 3] = srgb_byte(v * 0.82), srgb_byte(v * 0.92), srgb_byte(v * 0.8), 255
    return out


def soil_texture(rng, size):
    """Dark garden soil with moss and pebbles."""
    noise = TileNoise(rng, 8, 5).image(size)
    moss = TileNoise(rng, 4, 3).image(size)
    fine = TileNoise(rng, 128, 1).image(size)
    out = bytearray(size * size * 3)
    for i in range(size * size):
        n, m, f = noise[i], moss[i], fine[i]
        if f > 0.8:
            c = (0.25 + 0.1 * n, 0.23 + 0.1 * n, 0.2 + 0.08 * n)  # pebble
        elif m > 0.58:
            g = 0.08 + 0.06 * n
            c = (g * 0.7, g * 1.3, g * 0.35)
        else:
            b = 0.06 + 0.05 * n + 0.02 * f
            c = (b * 1.2, b * 0.9, b * 0.65)
        k = 3 * i
        out[k], out[k + 1], out[k + 2] = srgb_byte(c[0]), srgb_byte(c[1]), srgb_byte(c[2])
    return out
