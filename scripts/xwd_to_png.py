#!/usr/bin/python3
"""Converts a 24/32-bit TrueColor X window dump (xwd -root) to PNG with Pillow: xwd_to_png.py IN OUT."""
import struct
import sys

from PIL import Image


def main():
    data = open(sys.argv[1], "rb").read()
    header = struct.unpack(">25I", data[:100])
    header_size, width, height = header[0], header[4], header[5]
    bits_per_pixel, bytes_per_line, ncolors = header[11], header[12], header[19]
    byte_order = header[7]  # 0 LSBFirst, 1 MSBFirst
    if bits_per_pixel not in (24, 32):
        raise SystemExit("xwd_to_png: only 24 and 32 bits per pixel dumps are supported")
    offset = header_size + 12 * ncolors
    raw = data[offset:offset + bytes_per_line * height]
    if bits_per_pixel == 24:  # packed 3 bytes per pixel
        mode = "BGR" if byte_order == 0 else "RGB"
    else:
        mode = "BGRX" if byte_order == 0 else "XRGB"
    image = Image.frombuffer("RGB", (width, height), raw, "raw", mode, bytes_per_line, 1)
    # Keep RViz's 3D view only: the rows and columns mostly of its background colour (48, 48, 48).
    pixels = image.load()
    def mostly_background(line):
        return sum(1 for p in line if p == (48, 48, 48)) > 0.3 * len(line)
    columns = [x for x in range(width) if mostly_background([pixels[x, y] for y in range(height)])]
    rows = [y for y in range(height) if mostly_background([pixels[x, y] for x in range(width)])]
    if columns and rows:
        image = image.crop((columns[0], rows[0], columns[-1] + 1, rows[-1] + 1))
    image.save(sys.argv[2], optimize=True)


if __name__ == "__main__":
    main()
