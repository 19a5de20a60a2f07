"""Independent writers (numpy + gzip/zlib/struct, not our C++ exporter) for the volume
formats the importers read: NRRD, MetaImage, PNG and TIFF slices. Arrays are indexed
[z][y][x] as the files store them (x fastest)."""
import gzip
import struct
import zlib

import numpy as np

NRRD_TYPE = {np.dtype(np.uint8): "uint8", np.dtype(np.int16): "int16",
             np.dtype(np.uint16): "uint16", np.dtype(np.float32): "float"}
MET_TYPE = {np.dtype(np.uint8): "MET_UCHAR", np.dtype(np.int16): "MET_SHORT",
            np.dtype(np.uint16): "MET_USHORT", np.dtype(np.float32): "MET_FLOAT"}


def _bytes(arr, big):
    a = np.ascontiguousarray(arr)
    return a.astype(a.dtype.newbyteorder(">" if big else "<")).tobytes()


def write_nrrd(path, arr, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), directions=None,
               encoding="raw", big=False, detached=False, data_suffix=".raw", extra=()):
    """Writes arr (nz, ny, nx). directions: 3 vectors per index axis (x, y, z), default
    diagonal from spacing. detached: header `path` + data file next to it."""
    path = str(path)
    if directions is None:
        directions = [(spacing[0], 0, 0), (0, spacing[1], 0), (0, 0, spacing[2])]
    nz, ny, nx = arr.shape
    data = _bytes(arr, big)
    if encoding == "gzip":
        data = gzip.compress(data)
    lines = ["NRRD0004", "# written by fixtures_volumes.py", f"type: {NRRD_TYPE[arr.dtype]}", "dimension: 3",
             "space: left-posterior-superior", f"sizes: {nx} {ny} {nz}",
             "space directions: " + " ".join("(%r,%r,%r)" % tuple(float(c) for c in d) for d in directions),
             "kinds: domain domain domain", f"endian: {'big' if big else 'little'}", f"encoding: {encoding}",
             "space origin: (%r,%r,%r)" % tuple(float(c) for c in origin)]
    lines += list(extra)
    if detached:
        name = path.rsplit("/", 1)[-1].rsplit(".", 1)[0] + data_suffix
        lines.append(f"data file: {name}")
        with open(path.rsplit("/", 1)[0] + "/" + name, "wb") as f:
            f.write(data)
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")
    else:
        with open(path, "wb") as f:
            f.write(("\n".join(lines) + "\n\n").encode())
            f.write(data)


def write_metaimage(path, arr, spacing=(1.0, 1.0, 1.0), offset=(0.0, 0.0, 0.0), msb=False,
                    compressed=False, detached=False, extra=()):
    """.mha (attached) or .mhd + .raw/.zraw (detached)."""
    path = str(path)
    nz, ny, nx = arr.shape
    data = _bytes(arr, msb)
    if compressed:
        data = zlib.compress(data)
    lines = ["ObjectType = Image", "NDims = 3", "BinaryData = True",
             f"BinaryDataByteOrderMSB = {'True' if msb else 'False'}",
             f"CompressedData = {'True' if compressed else 'False'}"]
    if compressed:
        lines.append(f"CompressedDataSize = {len(data)}")
    lines += ["TransformMatrix = 1 0 0 0 1 0 0 0 1", "Offset = %r %r %r" % tuple(map(float, offset)),
              "CenterOfRotation = 0 0 0", "AnatomicalOrientation = RAI",
              "ElementSpacing = %r %r %r" % tuple(map(float, spacing)), f"DimSize = {nx} {ny} {nz}",
              f"ElementType = {MET_TYPE[arr.dtype]}"]
    lines += list(extra)
    if detached:
        name = path.rsplit("/", 1)[-1].rsplit(".", 1)[0] + (".zraw" if compressed else ".raw")
        lines.append(f"ElementDataFile = {name}")
        with open(path.rsplit("/", 1)[0] + "/" + name, "wb") as f:
            f.write(data)
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")
    else:
        lines.append("ElementDataFile = LOCAL")
        with open(path, "wb") as f:
            f.write(("\n".join(lines) + "\n").encode())
            f.write(data)


def write_png(path, img, bad_text_crc=False):
    """Greyscale PNG, 8 or 16 bit (img: 2-D uint8/uint16); with a tEXt comment whose CRC is
    wrong when bad_text_crc (libpng warns about it and decodes the image)."""
    h, w = img.shape
    depth = 16 if img.dtype == np.uint16 else 8
    rows = img.astype(">u2" if depth == 16 else "u1")
    raw = b"".join(b"\x00" + rows[r].tobytes() for r in range(h))

    def chunk(t, d, crc=None):
        crc = zlib.crc32(t + d) if crc is None else crc
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", crc & 0xFFFFFFFF)

    text = chunk(b"tEXt", b"Comment\0scanner note", crc=0) if bad_text_crc else b""
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, 0, 0, 0, 0)) + text
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def write_tiff(path, img, pages=1):
    """Baseline little-endian uncompressed greyscale TIFF, one strip, 8 or 16 bit; `pages`
    copies of the image as a multi-page TIFF (each page an IFD followed by its strip)."""
    h, w = img.shape
    bits = 16 if img.dtype == np.uint16 else 8
    data = img.astype("<u2" if bits == 16 else "u1").tobytes()
    entries = [(256, 4, w), (257, 4, h), (258, 3, bits), (259, 3, 1), (262, 3, 1), (273, 4, 0),
               (277, 3, 1), (278, 4, h), (279, 4, len(data))]
    ifd_size = 2 + 12 * len(entries) + 4
    out = b"II*\x00" + struct.pack("<I", 8)
    for page in range(pages):
        ifd_off = len(out)
        data_off = ifd_off + ifd_size
        next_ifd = data_off + len(data) if page + 1 < pages else 0
        out += struct.pack("<H", len(entries))
        for tag, typ, val in entries:
            if tag == 273:
                val = data_off
            out += struct.pack("<HHI", tag, typ, 1) + (struct.pack("<HH", val, 0) if typ == 3 else struct.pack("<I", val))
        out += struct.pack("<I", next_ifd) + data
    with open(path, "wb") as f:
        f.write(out)


def read_nrrd(path):
    """Minimal independent NRRD reader (attached, raw/gzip) → (array zyx, fields)."""
    with open(path, "rb") as f:
        blob = f.read()
    head, data = blob.split(b"\n\n", 1)
    fields = {}
    for line in head.decode().splitlines()[1:]:
        if line.startswith("#") or ":=" in line:
            continue
        k, v = line.split(": ", 1)
        fields[k] = v
    nx, ny, nz = map(int, fields["sizes"].split())
    dt = {"uint8": "u1", "int16": "i2", "uint16": "u2", "float": "f4"}[fields["type"]]
    dt = np.dtype(dt).newbyteorder("<" if fields.get("endian", "little") == "little" else ">")
    if fields["encoding"] == "gzip":
        data = gzip.decompress(data)
    return np.frombuffer(data, dtype=dt).reshape(nz, ny, nx), fields
