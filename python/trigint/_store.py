"""A sweep's results on disk (zarr), written chunk by chunk as chunks finish.

A store is built complete in a sibling folder ``<name>.partial`` and renamed into place (an
atomic step), so a process killed while creating it leaves either no store or a whole one.
Each chunk's rows are written first and its entry of the ``done`` array (one zarr chunk per
entry, so one file each) afterwards: a process killed at any moment leaves only chunks that are
complete and marked, or unmarked ones that are recomputed. A store remembers a fingerprint of
the call that made it and refuses another call, saying which inputs differ. The chunking is the
store's own (chosen when it was made): results do not depend on it, so a resumed call adopts it
whatever its thread count, chunk size or client.

Damage is detected and, where the data allow, repaired: every zarr chunk of a new store carries
a CRC32C checksum, so a finished chunk that was overwritten, truncated or altered fails to read
(older stores without checksums detect what no longer decompresses); a resumed call recomputes
such a chunk with a warning naming it and keeps every chunk that reads. What cannot be repaired
(metadata that is not JSON, a missing array, a file or a dangling link where the store or its
working folder goes, a folder that cannot be written) is a :class:`StoreError` naming the path,
what is wrong and what to do, raised before anything is computed. A folder whose permissions
allow no writing (``chmod a-w``) counts as read-only whoever runs, root included.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import warnings
from pathlib import Path

import numpy as np

from ._outputs import STATUS_CODES

#: what to do with a store that cannot be repaired
START_AGAIN = "delete it (or move it away) and run the same call again to start over"


class StoreError(ValueError):
    """A ``store=`` path that cannot be used as it is: damaged beyond repair, not writable, or
    blocked by a file or a dangling link. The message names the path, what is wrong and what
    to do.

    >>> import trigint as ti
    >>> issubclass(ti.StoreError, ValueError)
    True
    """


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

        self.zarr = zarr
        self.path = Path(path)
        self.shapes = dict(shapes)
        self.n_chunks = n_chunks
        #: finished chunks found damaged by :meth:`finished` (recomputed)
        self.damaged: list[int] = []
        try:
            check_location(self.path)
        except OSError as exc:  # e.g. a folder on the way that cannot be searched
            raise StoreError(f"store: cannot use {self.path}: {_reason(exc)}; choose another path") from None
        if self.path.exists():
            self.group = self._open(zarr)
            attrs = {} if self.group is None else dict(self.group.attrs)
            if attrs.get("format") != FORMAT or "fingerprint" not in attrs:
                what = ("was written by another version of trigint" if "fingerprint" in attrs
                        else "is not a store written by trigint's ensemble()")
                raise StoreError(f"store: {self.path} exists and {what}; choose another path or delete it")
            stored = attrs["fingerprint"]
            differ = sorted(k for k in set(stored) | set(prints) if stored.get(k) != prints.get(k))
            if differ:
                raise StoreError(
                    f"store: {self.path} holds a sweep made by a different call ({', '.join(differ)} "
                    "differ); use another store path or delete this one to start again"
                )
            self._check_arrays()
        else:
            try:
                self._create(zarr, prints, shapes, chunk_size, n_chunks)
            except OSError as exc:
                raise StoreError(f"store: cannot create {self.path}: {_reason(exc)}; choose a store path in a "
                                 "folder you can write to") from None
            self.group = zarr.open_group(str(self.path), mode="a")

    def _open(self, zarr):
        """The existing group, or None if the folder holds no zarr group at all."""
        meta = self.path / "zarr.json"
        if not meta.exists():
            return None
        try:
            json.loads(meta.read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:
            raise StoreError(f"store: {self.path} is damaged: its metadata {meta} is not valid JSON ({exc}); "
                             f"{START_AGAIN}") from None
        except OSError as exc:
            raise StoreError(f"store: cannot read {meta}: {_reason(exc)}; check the folder's permissions") from None
        try:
            return zarr.open_group(str(self.path), mode="a")
        except Exception as exc:  # zarr raises many kinds for a group it cannot read
            raise StoreError(f"store: {self.path} is damaged: zarr cannot open it ({type(exc).__name__}: {exc}); "
                             f"{START_AGAIN}") from None

    def _check_arrays(self) -> None:
        """Every array the sweep needs is there, readable, with its shape and type."""
        expected = {**self.shapes, "done": ((self.n_chunks,), "bool", False)}
        for name, (shape, dtype, _) in expected.items():
            try:
                array = self.group[name]
            except KeyError:
                raise StoreError(f"store: {self.path} is damaged: the array {name!r} ({self.path / name}) is "
                                 f"missing; {START_AGAIN}") from None
            except Exception as exc:  # its metadata is not JSON, or not zarr's
                raise StoreError(f"store: {self.path} is damaged: the metadata of the array {name!r} "
                                 f"({self.path / name / 'zarr.json'}) cannot be read ({type(exc).__name__}: {exc}); "
                                 f"{START_AGAIN}") from None
            if tuple(array.shape) != tuple(shape) or array.dtype != np.dtype(dtype):
                raise StoreError(f"store: {self.path} is damaged: the array {name!r} has shape {tuple(array.shape)} "
                                 f"and type {array.dtype}, the sweep needs {tuple(shape)} and {np.dtype(dtype)}; "
                                 f"{START_AGAIN}")

    def _create(self, zarr, prints, shapes, chunk_size, n_chunks) -> None:
        partial = self.path.with_name(self.path.name + ".partial")
        if partial.exists():  # left by a process killed while creating the store
            shutil.rmtree(partial)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        group = zarr.open_group(str(partial), mode="w")
        codecs = {"compressors": compressors(zarr)}
        for name, (shape, dtype, fill) in shapes.items():
            group.create_array(name, shape=shape, chunks=(chunk_size, *shape[1:]), dtype=dtype, fill_value=fill,
                               **codecs)
        group.create_array("done", shape=(n_chunks,), chunks=(1,), dtype="bool", fill_value=False, **codecs)
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

    def finished(self, spans: list[slice]) -> dict[int, dict]:
        """{chunk: {array: rows}} for every finished chunk that reads back whole. A finished chunk
        that does not (a checksum or decompression failure, rows never written) is left out, with
        a warning, and listed in ``self.damaged``: the caller recomputes it."""
        chunks = {i: {} for i, flag in enumerate(self.done()) if flag}
        damaged: dict[int, str] = {}
        for name in self.shapes:
            array = self.group[name]
            for i in chunks:
                missing = self._missing_file(array, name, i)
                if missing:
                    damaged.setdefault(i, f"the file {missing} of the array {name!r} is missing")
            try:
                whole = array[:]  # one read when nothing is damaged
            except Exception:
                whole = None
            for i in chunks:
                if whole is not None:
                    chunks[i][name] = whole[spans[i]]
                    continue
                try:
                    chunks[i][name] = array[spans[i]]
                except Exception as exc:  # checksum mismatch, undecodable bytes, unreadable file
                    damaged.setdefault(i, f"the array {name!r} does not read back: {type(exc).__name__}: {exc}")
        for i, rows in chunks.items():
            if i not in damaged and np.any(rows["status"] == STATUS_CODES["interrupted"]):
                damaged[i] = "it is marked finished but holds rows that were never written"
        for i in sorted(damaged):
            del chunks[i]
            span = spans[i]
            warnings.warn(f"store: chunk {i} (trajectories {span.start} to {span.stop - 1}) of {self.path} is damaged "
                          f"({damaged[i]}); it is recomputed, the other chunks are kept", RuntimeWarning, stacklevel=3)
        self.damaged = sorted(damaged)
        return chunks

    def _missing_file(self, array, name: str, i: int) -> Path | None:
        """The file of chunk i of `array` if it is missing. Only for stores with checksums: they
        write every chunk (older stores leave out chunks equal to the fill value)."""
        if not any(type(c).__name__ == "Crc32cCodec" for c in array.compressors):
            return None
        key = array.metadata.encode_chunk_key((i,) + (0,) * (len(array.shape) - 1))
        f = self.path / name / key
        return None if f.is_file() else f

    def prepare(self, remaining: int) -> None:
        """Before computing `remaining` chunks: the store can be written, and damaged chunks are
        unmarked (so that a kill while they are rewritten leaves them to be recomputed)."""
        for folder in [self.path, *(self.path / name for name in [*self.shapes, "done"])]:
            problem = not_writable(folder)
            if problem:
                raise StoreError(
                    f"store: {self.path} cannot be written ({folder}: {problem}); {remaining} of {self.n_chunks} "
                    "chunks remain to be computed. Make it writable, or copy the store to a writable folder and "
                    "pass that path (its finished chunks are kept)"
                )
        try:
            for i in self.damaged:
                self.group["done"][i] = False
        except OSError as exc:
            raise StoreError(f"store: cannot write to {self.path}: {_reason(exc)}; make it writable") from None

    def write(self, index: int, sel: slice, arrays: dict) -> None:
        try:
            with self.zarr.config.set({"array.write_empty_chunks": True}):  # every chunk has its file
                for name, value in arrays.items():
                    self.group[name][sel] = value
            self.group["done"][index] = True
        except OSError as exc:
            raise StoreError(
                f"store: writing chunk {index} to {self.path} failed: {_reason(exc)}; the chunks finished before "
                "are kept: free some space or fix the folder and run the same call again to resume"
            ) from None

    def read(self, names) -> dict:
        return {name: self.group[name][:] for name in names}

    def describe(self) -> str:
        return json.dumps(dict(self.group.attrs), indent=1)


def compressors(zarr) -> tuple:
    """The codecs after the bytes of every chunk: zstd, then a CRC32C checksum that makes any
    change to a finished chunk detectable."""
    return (zarr.codecs.ZstdCodec(level=0), zarr.codecs.Crc32cCodec())


def check_location(path: Path) -> None:
    """Refuses, before anything is computed, a store path that cannot hold a store: a file or a
    dangling link where the store or its working folder goes, a path under a file, or a new
    store in a folder that cannot be written."""
    if path.is_symlink() and not path.exists():
        raise StoreError(f"store: {path} is a symbolic link to {os.readlink(path)}, which does not exist; create "
                         "the folder it points to, remove the link, or choose another path")
    if path.exists():
        if not path.is_dir():
            raise StoreError(f"store: {path} exists and is a file, not a store written by trigint's ensemble(); "
                             "choose another path or move the file away")
        return
    partial = path.with_name(path.name + ".partial")
    if os.path.lexists(partial) and (partial.is_symlink() or not partial.is_dir()):
        raise StoreError(f"store: {partial}, the working folder where the store is built before it is renamed "
                         f"into place, is taken by a {'link' if partial.is_symlink() else 'file'}; move it away or "
                         "delete it, or choose another store path")
    ancestor = path.parent
    while not ancestor.exists():
        if ancestor.is_symlink():
            raise StoreError(f"store: cannot create {path}: {ancestor} is a symbolic link to "
                             f"{os.readlink(ancestor)}, which does not exist; create that folder or fix the link")
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise StoreError(f"store: cannot create {path}: {ancestor} is a file, not a folder; choose a store path "
                         "inside a folder")
    problem = not_writable(ancestor)
    if problem:
        raise StoreError(f"store: cannot create {path}: the folder {ancestor} cannot be written ({problem}); choose "
                         "a store path in a folder you can write to")


def not_writable(folder: Path) -> str | None:
    """Why `folder` cannot be written, or None: no write permission bit at all (honoured even
    for root), or a test file that cannot be created (a read-only mount, permissions)."""
    try:
        mode = folder.stat().st_mode
    except OSError as exc:
        return _reason(exc)
    if not mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH):
        return f"it is marked read-only: mode {stat.filemode(mode)}"
    probe = folder / f".trigint-write-test-{os.getpid()}"
    try:
        probe.touch()
        probe.unlink()
    except OSError as exc:
        return _reason(exc)
    return None


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc) or type(exc).__name__
