#!/usr/bin/env python3
"""Tiles PNG images (8-bit RGB or RGBA, as `vcmfarm render --preview` writes them) into one
contact sheet, in the order given, COLUMNS to a row, each cell the size of the largest
image with the image in its top-left corner on black. Python 3's standard library only.

    contact_sheet.py OUT.png COLUMNS IN.png...
"""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    pos, idat, width = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise SystemExit(f"{path}: only 8-bit RGB or RGBA without interlacing")
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw, stride = zlib.decompress(idat), width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        filt, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b, c = prev[i], prev[i - channels] if i >= channels else 0
            if filt == 1:
                line[i] = (line[i] + a) & 255
            elif filt == 2:
                line[i] = (line[i] + b) & 255
            elif filt == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif filt == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line[k] for k in range(stride) if k % channels < 3) if channels == 4 else bytes(line))
        prev = line
    return width, height, rows


def write_png(path, width, height, rows):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    raw = b"".join(b"\x00" + row for row in rows)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main():
    if len(sys.argv) < 4:
        raise SystemExit(__doc__)
    out, columns, images = sys.argv[1], int(sys.argv[2]), [read_png(p) for p in sys.argv[3:]]
    cw, ch = max(i[0] for i in images), max(i[1] for i in images)
    nrows = (len(images) + columns - 1) // columns
    sheet = [bytearray(3 * cw * columns) for _ in range(ch * nrows)]
    for k, (w, h, rows) in enumerate(images):
        x0, y0 = (k % columns) * cw, (k // columns) * ch
        for y in range(h):
            sheet[y0 + y][3 * x0:3 * (x0 + w)] = rows[y]
    write_png(out, cw * columns, ch * nrows, [bytes(r) for r in sheet])


if __name__ == "__main__":
    main()
