"""A sweep's results on disk (zarr), written chunk by chunk as chunks finish.

Each chunk's rows are written first and its entry of the ``done`` array (one zarr chunk per
entry, so one file each) afterwards: a process killed at any moment leaves only chunks that are
complete and marked, or unmarked ones that are recomputed. A store remembers a fingerprint of
the call that made it and refuses another call, saying which inputs differ.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

STATUS_CODES = {"completed": 0, "blow-up": 1, "interrupted": 2}
STATUS_NAMES = {v: k for k, v in STATUS_CODES.items()}


def fingerprint(parts: dict) -> dict:
    """A SHA-256 digest of each named input (arrays by their bytes, the rest by repr)."""
    out = {}
    for name, value in parts.items():
        digest = hashlib.sha256()
        if isinstance(value, np.ndarray):
            digest.update(str(value.dtype).encode() + str(value.shape).encode())
            digest.update(np.ascontiguousarray(value).tobytes())
        else:
            digest.update(repr(value).encode())
        out[name] = digest.hexdigest()[:16]
    return out


class SweepStore:
    """The zarr group behind ``store=``: result arrays over trajectories plus ``done`` flags."""

    def __init__(self, path, prints: dict, shapes: dict, chunk_size: int, n_chunks: int):
        import zarr

        self.path = Path(path)
        exists = (self.path / "zarr.json").exists()
        self.group = zarr.open_group(str(self.path), mode="a")
        if exists:
            stored = self.group.attrs.get("fingerprint")
            if stored is None:
                raise ValueError(f"store: {self.path} exists but was not written by trigint's ensemble(); "
                                 "choose another path")
            differ = sorted(k for k in set(stored) | set(prints) if stored.get(k) != prints.get(k))
            if differ:
                raise ValueError(
                    f"store: {self.path} holds a sweep made by a different call ({', '.join(differ)} "
                    "differ); use another store path or delete this one to start again"
                )
        else:
            self.group.attrs["fingerprint"] = prints
            self.group.attrs["format"] = "trigint ensemble store 1"
            for name, (shape, dtype, fill) in shapes.items():
                chunks = (chunk_size, *shape[1:])
                self.group.create_array(name, shape=shape, chunks=chunks, dtype=dtype, fill_value=fill)
            self.group.create_array("done", shape=(n_chunks,), chunks=(1,), dtype="bool", fill_value=False)

    def done(self) -> np.ndarray:
        try:
            return np.asarray(self.group["done"][:], dtype=bool)
        except Exception:  # a flag file cut short by a kill: read flag by flag
            flags = []
            for i in range(self.group["done"].shape[0]):
                try:
                    flags.append(bool(self.group["done"][i]))
                except Exception:
                    flags.append(False)
            return np.array(flags, dtype=bool)

    def write(self, index: int, sel: slice, arrays: dict) -> None:
        for name, value in arrays.items():
            self.group[name][sel] = value
        self.group["done"][index] = True

    def read(self, names) -> dict:
        return {name: self.group[name][:] for name in names}

    def describe(self) -> str:
        return json.dumps(dict(self.group.attrs), indent=1)
