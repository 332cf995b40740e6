"""A sweep's results on disk (zarr), written chunk by chunk as chunks finish.

A store is built complete in a sibling folder ``<name>.partial`` and renamed into place (an
atomic step), so a process killed while creating it leaves either no store or a whole one.
Each chunk's rows are written first and its entry of the ``done`` array (one zarr chunk per
entry, so one file each) afterwards: a process killed at any moment leaves only chunks that are
complete and marked, or unmarked ones that are recomputed. A store remembers a fingerprint of
the call that made it and refuses another call, saying which inputs differ. The chunking is the
store's own (chosen when it was made): results do not depend on it, so a resumed call adopts it
whatever its thread count, chunk size or client.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
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


FORMAT = "trigint ensemble store 2"


def stored_chunk_size(path) -> int | None:
    """The chunk size of the trigint store at `path`, or None if there is none yet."""
    meta = Path(path) / "zarr.json"
    if not meta.exists():
        return None
    try:
        attrs = json.loads(meta.read_text(encoding="utf-8")).get("attributes", {})
    except (OSError, ValueError):
        return None
    size = attrs.get("chunk_size")
    return int(size) if isinstance(size, int) and attrs.get("format") == FORMAT else None


class SweepStore:
    """The zarr group behind ``store=``: result arrays over trajectories plus ``done`` flags."""

    def __init__(self, path, prints: dict, shapes: dict, chunk_size: int, n_chunks: int):
        import zarr

        self.path = Path(path)
        if self.path.exists():
            self.group = zarr.open_group(str(self.path), mode="a") if (self.path / "zarr.json").exists() else None
            attrs = {} if self.group is None else dict(self.group.attrs)
            if attrs.get("format") != FORMAT or "fingerprint" not in attrs:
                what = ("was written by another version of trigint" if "fingerprint" in attrs
                        else "is not a store written by trigint's ensemble()")
                raise ValueError(f"store: {self.path} exists and {what}; choose another path or delete it")
            stored = attrs["fingerprint"]
            differ = sorted(k for k in set(stored) | set(prints) if stored.get(k) != prints.get(k))
            if differ:
                raise ValueError(
                    f"store: {self.path} holds a sweep made by a different call ({', '.join(differ)} "
                    "differ); use another store path or delete this one to start again"
                )
        else:
            self._create(zarr, prints, shapes, chunk_size, n_chunks)
            self.group = zarr.open_group(str(self.path), mode="a")

    def _create(self, zarr, prints, shapes, chunk_size, n_chunks) -> None:
        partial = self.path.with_name(self.path.name + ".partial")
        if partial.exists():  # left by a process killed while creating the store
            shutil.rmtree(partial)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        group = zarr.open_group(str(partial), mode="w")
        for name, (shape, dtype, fill) in shapes.items():
            group.create_array(name, shape=shape, chunks=(chunk_size, *shape[1:]), dtype=dtype, fill_value=fill)
        group.create_array("done", shape=(n_chunks,), chunks=(1,), dtype="bool", fill_value=False)
        group.attrs.update({"fingerprint": prints, "format": FORMAT, "chunk_size": int(chunk_size)})
        os.rename(partial, self.path)

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
