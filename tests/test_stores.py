"""Nothing lost: every way a store can be damaged or unwritable ends in recovery (a finished
chunk that no longer reads back is recomputed, the others kept) or in a StoreError naming the
path, what is wrong and what to do, raised before anything is computed."""

import json
import os
import shutil
import stat
import warnings
from concurrent.futures import Future
from pathlib import Path

import numpy as np
import pytest

import trigint as ti

H = 2 * np.pi / 3 / 50
PROB = ti.problems.fpu(m=3, omega=50.0)
Q0, P0 = ti.problems.fpu_initial(m=3, omega=50.0)
HS = H * np.linspace(0.95, 1.05, 6)  # 6 trajectories in 3 chunks of 2


class Counting:
    """An executor that runs each chunk at once and counts them."""

    def __init__(self):
        self.calls = 0

    def submit(self, fn, *args, **kwargs):
        self.calls += 1
        future = Future()
        future.set_result(fn(*args, **kwargs))
        return future


def sweep(store, client=None):
    return ti.ensemble(PROB, "B", Q0, P0, h=HS, t_end=5.0, chunk_size=2, save_every=50, store=store,
                       client=client, progress=False)


@pytest.fixture(scope="module")
def reference():
    return sweep(None)


@pytest.fixture()
def finished(tmp_path, reference):
    """A complete store of the sweep (equal to the run without a store)."""
    path = tmp_path / "sweep.zarr"
    assert sweep(path).identical(reference)
    return path


def _chunk_file(store: Path, array: str, chunk: int) -> Path:
    """The file of chunk `chunk` (along the trajectories) of `array`."""
    top = store / array / "c" / str(chunk)
    files = [top] if top.is_file() else [f for f in sorted(top.rglob("*")) if f.is_file()]
    assert len(files) == 1, files
    return files[0]


def _overwrite(f: Path):
    f.write_bytes(b"not a zarr chunk" * 8)


def _truncate(f: Path):
    f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])


def _flip(f: Path):
    data = bytearray(f.read_bytes())
    data[len(data) // 2] ^= 0x10
    f.write_bytes(bytes(data))


@pytest.mark.parametrize("damage", [_overwrite, _truncate, _flip], ids=["overwritten", "truncated", "bit-flip"])
@pytest.mark.parametrize("array", ["max_deviation", "q", "status"])
def test_a_damaged_finished_chunk_is_recomputed_and_the_others_kept(finished, reference, damage, array):
    damage(_chunk_file(finished, array, 1))
    client = Counting()
    with pytest.warns(RuntimeWarning, match=rf"store: chunk 1 \(trajectories 2 to 3\) of .*sweep.zarr is damaged "
                                            rf"\(the array '{array}' does not read back: .*\); it is recomputed, "
                                            "the other chunks are kept"):
        again = sweep(finished, client)
    assert client.calls == 1  # chunk 1 only
    assert again.identical(reference)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # repaired: nothing damaged, nothing computed
        client = Counting()
        assert sweep(finished, client).identical(reference) and client.calls == 0


def test_chunks_carry_a_crc32c_checksum(finished):
    meta = json.loads((finished / "q" / "zarr.json").read_text())
    assert [c["name"] for c in meta["codecs"]] == ["bytes", "zstd", "crc32c"]
    done = json.loads((finished / "done" / "zarr.json").read_text())
    assert done["codecs"][-1]["name"] == "crc32c"


def _unfinish(store: Path, *chunks: int):
    """Clears the `done` flags of `chunks`, as a kill before they were written leaves them."""
    import zarr

    group = zarr.open_group(str(store), mode="a")
    for i in chunks:
        group["done"][i] = False


def test_a_store_without_checksums_still_opens_resumes_and_recovers(tmp_path, reference, monkeypatch):
    """A store made before chunks had checksums (zstd only): it resumes, and a chunk that no
    longer decompresses is recomputed."""
    from trigint import _store

    path = tmp_path / "old.zarr"
    with monkeypatch.context() as m:
        m.setattr(_store, "compressors", lambda zarr: (zarr.codecs.ZstdCodec(level=0),))
        sweep(path)
    meta = json.loads((path / "q" / "zarr.json").read_text())
    assert [c["name"] for c in meta["codecs"]] == ["bytes", "zstd"]
    _unfinish(path, 2)
    _truncate(_chunk_file(path, "max_deviation", 0))
    client = Counting()
    with pytest.warns(RuntimeWarning, match=r"chunk 0 \(trajectories 0 to 1\) .* is damaged"):
        again = sweep(path, client)
    assert client.calls == 2  # chunk 0 (damaged) and chunk 2 (not finished)
    assert again.identical(reference)


def test_a_finished_chunk_whose_rows_were_never_written_is_recomputed(tmp_path, reference, monkeypatch):
    """In a store without checksums a missing chunk file is not damage in itself (such stores
    leave out chunks equal to the fill value), but a finished chunk whose status reads as the
    fill value ('interrupted') was never written: recomputed."""
    from trigint import _store

    path = tmp_path / "old.zarr"
    with monkeypatch.context() as m:
        m.setattr(_store, "compressors", lambda zarr: (zarr.codecs.ZstdCodec(level=0),))
        sweep(path)
    _chunk_file(path, "status", 2).unlink()
    client = Counting()
    with pytest.warns(RuntimeWarning, match=r"chunk 2 .* marked finished but holds rows that were never written"):
        assert sweep(path, client).identical(reference)
    assert client.calls == 1


@pytest.mark.parametrize("array", ["q", "energies", "initial_energies"])
def test_a_finished_chunk_whose_file_is_missing_is_recomputed(finished, reference, array):
    """Stores with checksums write every chunk, so a missing chunk file is damage, even where
    the fill value (NaN) would read back silently."""
    _chunk_file(finished, array, 0).unlink()
    client = Counting()
    with pytest.warns(RuntimeWarning, match=rf"chunk 0 .* is damaged \(the file .* of the array '{array}' is "
                                            r"missing\); it is recomputed"):
        assert sweep(finished, client).identical(reference)
    assert client.calls == 1


def _refused(store, *fragments):
    client = Counting()
    with pytest.raises(ti.StoreError) as info:
        sweep(store, client)
    assert client.calls == 0  # refused before anything was computed
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, message
    return message


def test_group_metadata_that_is_not_json(finished):
    (finished / "zarr.json").write_text("{not json")
    _refused(finished, f"store: {finished} is damaged: its metadata {finished / 'zarr.json'} is not valid JSON",
             "delete it (or move it away) and run the same call again to start over")


def test_array_metadata_that_is_not_json(finished):
    (finished / "p" / "zarr.json").write_text("\x00\x01")
    _refused(finished, f"store: {finished} is damaged: the metadata of the array 'p' ({finished / 'p' / 'zarr.json'})"
                       " cannot be read", "start over")


@pytest.mark.parametrize("array", ["q", "done"])
def test_a_missing_array(finished, array):
    shutil.rmtree(finished / array)
    _refused(finished, f"store: {finished} is damaged: the array '{array}' ({finished / array}) is missing",
             "start over")


def test_an_array_of_the_wrong_shape(finished):
    import zarr

    group = zarr.open_group(str(finished), mode="a")
    del group["steps_done"]
    group.create_array("steps_done", shape=(5,), dtype="int64", fill_value=0)
    _refused(finished, "the array 'steps_done' has shape (5,) and type int64, the sweep needs (6,) and int64")


def test_a_stray_file_where_the_working_folder_goes(tmp_path):
    store = tmp_path / "new.zarr"
    (tmp_path / "new.zarr.partial").write_text("someone's notes")
    _refused(store, f"store: {store}.partial, the working folder where the store is built", "is taken by a file",
             "move it away or delete it")
    assert (tmp_path / "new.zarr.partial").read_text() == "someone's notes"  # not deleted


def test_a_dangling_symbolic_link(tmp_path):
    store = tmp_path / "link.zarr"
    os.symlink(tmp_path / "elsewhere" / "gone", store)
    _refused(store, f"store: {store} is a symbolic link to {tmp_path / 'elsewhere' / 'gone'}, which does not exist",
             "create the folder it points to, remove the link")


def test_a_store_path_that_is_a_file(tmp_path):
    store = tmp_path / "results.zarr"
    store.write_text("x")
    _refused(store, f"store: {store} exists and is a file", "choose another path or move the file away")


def test_a_store_path_under_a_file(tmp_path):
    (tmp_path / "plain").write_text("x")
    store = tmp_path / "plain" / "deeper" / "s.zarr"
    _refused(store, f"store: cannot create {store}: {tmp_path / 'plain'} is a file, not a folder")


def _read_only(folder: Path):
    """Removes every write permission bit below `folder`. trigint treats a folder without write
    bits as read-only whoever runs (root included, for whom chmod alone would not stop writes),
    so this is a reliable read-only store under any user; a real read-only mount is caught by
    the same check's test write."""
    for root, dirs, _ in os.walk(folder):
        for d in dirs:
            p = Path(root) / d
            p.chmod(p.stat().st_mode & ~0o222)
    folder.chmod(folder.stat().st_mode & ~0o222)


def _writable_again(folder: Path):
    folder.chmod(folder.stat().st_mode | stat.S_IWUSR)
    for root, dirs, _ in os.walk(folder):
        for d in dirs:
            p = Path(root) / d
            p.chmod(p.stat().st_mode | stat.S_IWUSR)


def test_a_read_only_store_with_work_left_is_refused_before_computing(tmp_path, reference):
    store = tmp_path / "part.zarr"
    sweep(store)
    _unfinish(store, 1, 2)
    _read_only(store)
    try:
        _refused(store, f"store: {store} cannot be written ({store}: it is marked read-only: mode dr-x",
                 "2 of 3 chunks remain to be computed", "copy the store to a writable folder and pass that path")
    finally:
        _writable_again(store)
    client = Counting()
    assert sweep(store, client).identical(reference) and client.calls == 2


def test_a_finished_read_only_store_can_still_be_read(finished, reference):
    _read_only(finished)
    try:
        client = Counting()
        assert sweep(finished, client).identical(reference) and client.calls == 0
    finally:
        _writable_again(finished)


def test_a_new_store_in_a_read_only_folder(tmp_path):
    folder = tmp_path / "archive"
    folder.mkdir()
    _read_only(folder)
    try:
        store = folder / "sub" / "s.zarr"
        _refused(store, f"store: cannot create {store}: the folder {folder} cannot be written",
                 "choose a store path in a folder you can write to")
        assert list(folder.iterdir()) == []
    finally:
        _writable_again(folder)


def test_a_write_that_fails_midway_keeps_the_finished_chunks(tmp_path, reference, monkeypatch):
    """After the first chunk is written, the chunk folder of one array turns into a file (as a
    failing disk refuses writes): a StoreError says what failed; once the folder is back, the
    same call resumes from the chunk that was kept."""
    from trigint import _store

    store = tmp_path / "s.zarr"
    write = _store.SweepStore.write

    def write_then_break(self, index, sel, arrays):
        write(self, index, sel, arrays)
        (store / "energies" / "c" / "1").write_text("in the way")  # where chunk 1 goes

    with monkeypatch.context() as m:
        m.setattr(_store.SweepStore, "write", write_then_break)
        with pytest.raises(ti.StoreError, match=rf"store: writing chunk 1 to {store} failed: .*; the chunks "
                                                "finished before are kept"):
            sweep(store)
    (store / "energies" / "c" / "1").unlink()
    client = Counting()
    assert sweep(store, client).identical(reference)
    assert client.calls == 2


@pytest.mark.parametrize("store", [123, ["a.zarr"], b"x.zarr"])
def test_a_store_that_is_not_a_path(store):
    with pytest.raises(TypeError, match=r"^store: expected a folder path \(a str or pathlib.Path\), got "):
        sweep(store)
