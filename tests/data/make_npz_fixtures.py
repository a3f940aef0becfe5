#!/usr/bin/env python3
"""Writes the small .npy/.npz fixtures that tests/io/npz_test.cpp reads.

The files reproduce byte for byte what numpy writes (numpy/lib/format.py:
`write_array`, `np.savez`, `np.savez_compressed`), using only the Python standard
library, because numpy was not installable where the fixtures were made. The only
deliberate difference is a fixed zip timestamp, so re-running the script gives
identical files. When numpy is importable the script also checks every fixture
with np.load.

Run from anywhere: python3 tests/data/make_npz_fixtures.py
"""
import os
import pickle
import struct
import warnings
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
ARRAY_ALIGN = 64  # numpy.lib.format.ARRAY_ALIGN
NAMES = ["pelvis", "left_hip", "caf\u00e9", "\U0001F600"]


def npy_bytes(descr, shape, data, fortran_order=False, version=None):
    """Header + data exactly as numpy.lib.format.write_array lays them out."""
    shape_text = "(" + ", ".join(str(d) for d in shape) + ("," if len(shape) == 1 else "") + ")"
    header = "{'descr': %r, 'fortran_order': %r, 'shape': %s, }" % (descr, fortran_order, shape_text)
    if version is None:
        version = (1, 0) if len(header) + 11 < 65536 else (2, 0)
    length_format = "<H" if version == (1, 0) else "<I"
    prefix = 6 + 2 + struct.calcsize(length_format)
    pad = ARRAY_ALIGN - (prefix + len(header) + 1) % ARRAY_ALIGN
    header = (header + " " * (pad % ARRAY_ALIGN) + "\n").encode("utf8" if version == (3, 0) else "latin1")
    return b"\x93NUMPY" + bytes(version) + struct.pack(length_format, len(header)) + header + data


def pack(fmt, values):
    return struct.pack("<%d%s" % (len(values), fmt), *values)


def unicode_data(strings):
    width = max(1, max(len(s) for s in strings))
    return "<U%d" % width, b"".join(s.ljust(width, "\0").encode("utf-32-le") for s in strings)


def members():
    """key -> .npy bytes; tests/io/npz_test.cpp checks these values."""
    names_descr, names = unicode_data(NAMES)
    # A 2x3 float32 array [[0, 1, 2], [3, 4, 5]] stored column-major.
    fortran = pack("f", [0, 3, 1, 4, 2, 5])
    return {
        "f4": npy_bytes("<f4", (2, 3), pack("f", [0.5, -1.25, 2, 3, 4, 1e-3])),
        "f8": npy_bytes("<f8", (2, 2), pack("d", [1.0 / 3, -2, 1e300, 0])),
        "i1": npy_bytes("|i1", (3,), pack("b", [-128, 0, 127])),
        "i2": npy_bytes("<i2", (3,), pack("h", [-32768, 1, 32767])),
        "i4": npy_bytes("<i4", (4,), pack("i", [-1, 0, 1, 2147483647])),
        "i8": npy_bytes("<i8", (2,), pack("q", [-(2 ** 40), 2 ** 62])),
        "u1": npy_bytes("|u1", (2,), pack("B", [0, 255])),
        "b1": npy_bytes("|b1", (3,), pack("?", [True, False, True])),
        # SMPL kintree_table: uint32 with 4294967295 marking the root's missing parent.
        "kintree_table": npy_bytes("<u4", (2, 3), pack("I", [4294967295, 0, 1, 0, 1, 2])),
        "fortran": npy_bytes("<f4", (2, 3), fortran, fortran_order=True),
        "scalar": npy_bytes("<f8", (), pack("d", [2.5])),
        "empty": npy_bytes("<f4", (0, 3), b""),
        "names": npy_bytes(names_descr, (len(NAMES),), names),
    }


def write_npz(path, arrays, compression):
    # As np.savez: zip64 local headers (force_zip64) and "<key>.npy" members.
    with zipfile.ZipFile(path, "w", compression=compression, allowZip64=True) as archive:
        for key, data in arrays.items():
            info = zipfile.ZipInfo(key + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = compression
            with archive.open(info, "w", force_zip64=True) as member:
                member.write(data)


def main():
    arrays = members()
    write_npz(os.path.join(HERE, "numpy_savez.npz"), arrays, zipfile.ZIP_STORED)
    write_npz(os.path.join(HERE, "numpy_savez_compressed.npz"), arrays, zipfile.ZIP_DEFLATED)
    singles = {
        "numpy_save_f4.npy": arrays["f4"],
        "numpy_v2.npy": npy_bytes("<i8", (2,), pack("q", [7, -7]), version=(2, 0)),
        "numpy_v3.npy": npy_bytes("<i8", (2,), pack("q", [7, -7]), version=(3, 0)),
        # np.save of np.array([1, 'a'], dtype=object): a pickle after the header.
        "numpy_object.npy": npy_bytes("|O", (2,), pickle.dumps([1, "a"], protocol=3)),
        "numpy_big_endian.npy": npy_bytes(">f4", (2,), struct.pack(">2f", 1.0, 2.0)),
    }
    for name, data in singles.items():
        with open(os.path.join(HERE, name), "wb") as out:
            out.write(data)
    # Two members of one name (zipfile warns; readers disagree on which wins).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with zipfile.ZipFile(os.path.join(HERE, "duplicate_member.npz"), "w") as archive:
            for value in (1.0, 2.0):
                info = zipfile.ZipInfo("a.npy", date_time=(1980, 1, 1, 0, 0, 0))
                archive.writestr(info, npy_bytes("<f4", (1,), struct.pack("<f", value)))
    try:
        import numpy as np
    except ImportError:
        return
    for name in ("numpy_savez.npz", "numpy_savez_compressed.npz"):
        with np.load(os.path.join(HERE, name)) as loaded:
            assert loaded["kintree_table"].dtype == np.uint32
            assert loaded["fortran"].tolist() == [[0, 1, 2], [3, 4, 5]]
            assert loaded["names"].tolist() == NAMES
    assert np.load(os.path.join(HERE, "numpy_v3.npy")).tolist() == [7, -7]


if __name__ == "__main__":
    main()
