#!/usr/bin/env python3
"""Dump an HDF5 file as JSON with h5py, for tests/it/output.rs.

Usage: python3 tests/h5read.py FILE

Prints {"attrs": {...}, "datasets": {"/path": {...}}, "groups": ["/events", ...]}.
Floats are given as their IEEE-754 bit patterns (unsigned 64-bit integers) so the Rust side can
compare bit-exactly, NaN included. Each value is tagged with how h5py returned it:
  {"str": "..."}                     a Python str (variable-length UTF-8 string)
  {"bytes": "..."}                   bytes (a fixed-length string: what we must NOT write)
  {"f64_bits": n} / {"int": n}       a scalar
  dataset: {"dtype": "float64", "shape": [n], "f64_bits": [...]} or "int": [...] or "str": [...],
           and "storage_size": the bytes its data takes in the file (h5py get_storage_size())
Exit status 3 when h5py is not importable (the test then skips, or fails under CI).
"""
import json
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:  # pragma: no cover
    print(f"h5read.py: cannot import h5py/numpy: {e}", file=sys.stderr)
    sys.exit(3)


def scalar(v):
    if isinstance(v, str):
        return {"str": v}
    if isinstance(v, bytes):
        return {"bytes": v.decode("utf-8", "replace")}
    if isinstance(v, (float, np.floating)):
        return {"f64_bits": int(np.array(v, dtype="<f8").view("<u8"))}
    if isinstance(v, (int, np.integer)):
        return {"int": int(v)}
    if isinstance(v, np.ndarray):
        return {"array": [scalar(x) for x in v.tolist()]}
    return {"repr": repr(v)}


def attrs(obj):
    return {k: scalar(obj.attrs[k]) for k in obj.attrs}


def dataset(d):
    out = {"dtype": str(d.dtype), "shape": list(d.shape), "attrs": attrs(d),
           "chunks": list(d.chunks) if d.chunks else None, "compression": d.compression,
           "storage_size": d.id.get_storage_size()}
    if d.dtype.kind == "f":
        out["f64_bits"] = [int(x) for x in np.asarray(d[()], dtype="<f8").view("<u8")]
    elif d.dtype.kind in "iu":
        out["int"] = [int(x) for x in d[()]]
    else:
        vals = d.asstr()[()] if h5py.check_string_dtype(d.dtype) else d[()]
        out["str"] = [str(x) for x in vals]
    return out


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    result = {"datasets": {}, "groups": []}
    with h5py.File(sys.argv[1], "r") as f:
        result["attrs"] = attrs(f)

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                result["datasets"]["/" + name] = dataset(obj)
            else:
                result["groups"].append("/" + name)
                result.setdefault("group_attrs", {})["/" + name] = attrs(obj)

        f.visititems(visit)
    json.dump(result, sys.stdout)
    print()


if __name__ == "__main__":
    main()
