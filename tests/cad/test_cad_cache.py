"""Converted CAD models kept by content (issue 27 point 4, "convert once"): a second read
of a file asks the kernel for no parse (it is given the cached model and shape), and gives
the same faces, left-out faces, notes, mesh and edges; a changed file, a corrupt, foreign or
planted entry is a miss (and is written anew); concurrent writers leave whole entries; the
folder is bounded; ``GSHADE_CACHE_DIR=off`` and ``--no-cache`` write nothing; nothing is
written through a link.

The parts are built with the kernel at test time (tests/support/cad_parts.py).  Whether the file
was parsed is told by the requests sent to the kernel's processes: only "read" parses it
("load" gives a child a cached read).
"""

from __future__ import annotations

import ast
import dataclasses
import doctest
import gc
import hashlib
import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRep import BRep_Builder
from OCP.TopoDS import TopoDS_Compound

from gshade import GshadeError
from gshade.app.cli import build_parser, main
from gshade.cad import cache as cad_cache
from gshade.cad import cache_keys, read_cad
from gshade.cad import process as cad_process
from gshade.cad.edges import shared_edges
from gshade.cad.mesh import mesh_faces
from gshade.runtime import cache_folder

from ..support.cad_parts import filleted_box, no_pcurves, open_wire, sphere_cap, write_shape

DEFLECTION = 0.5


@pytest.fixture(scope="module")
def parts(tmp_path_factory) -> dict[str, Path]:
    """The filleted box beside a face the healing repairs (a note, in BREP) and a face left
    out, as STEP and BREP; the box as IGES; a sphere cap as STEP; (with rhino3dm) a .3dm
    file of a sphere and a box."""
    folder = tmp_path_factory.mktemp("cached-parts")
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    for shape in (filleted_box(), no_pcurves()[0], open_wire()):
        builder.Add(compound, shape)
    files = {
        "step": write_shape(compound, folder / "part.step"),
        "brep": write_shape(compound, folder / "part.brep"),
        "igs": write_shape(filleted_box(), folder / "box.igs"),
        "cap": write_shape(sphere_cap(), folder / "cap.step"),
    }
    try:
        import rhino3dm as r3
    except ImportError:
        return files
    model = r3.File3dm()
    model.Objects.AddBrep(r3.Sphere(r3.Point3d(1, 2, 3), 4.0).ToBrep())
    box = r3.Box(r3.BoundingBox(r3.Point3d(0, 0, 0), r3.Point3d(3, 4, 5)))
    model.Objects.AddBrep(r3.Brep.CreateFromBox(box))
    assert model.Write(str(folder / "ball.3dm"), 7)
    files["3dm"] = folder / "ball.3dm"
    return files


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """An empty cache folder of this test's (its CAD subfolder), no model in use."""
    monkeypatch.setenv("GSHADE_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(cad_cache, "_live", {})
    return tmp_path / "cache" / "cad"


@pytest.fixture
def requests(monkeypatch) -> list[str]:
    """The requests made of the kernel's processes, by name ("read", "load", "keep",
    "mesh_faces", "shared_edges"), as they are made: a child started for an operation is
    given its cached read ("load") within it, so "load" comes after the operation."""
    sent: list[str] = []
    real = cad_process.KernelProcess.request

    def record(self, operation, *args, **kwargs):
        sent.append(operation.rpartition(":")[2])
        return real(self, operation, *args, **kwargs)

    monkeypatch.setattr(cad_process.KernelProcess, "request", record)
    return sent


def same(a, b) -> bool:
    """Equal as data: arrays bitwise (NaN equal to NaN), dataclasses and objects by their
    fields, containers item by item."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            isinstance(a, np.ndarray)
            and isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and a.shape == b.shape
            and a.tobytes() == b.tobytes()
        )
    if type(a) is not type(b):
        return False
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if dataclasses.is_dataclass(a):
        return all(same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    if hasattr(a, "__dict__") and not isinstance(a, (Path, type)):
        return same(vars(a), vars(b))
    if isinstance(a, float):
        return a == b or (a != a and b != b)
    return a == b


def without_shape(model):
    return dataclasses.replace(model, brep=None)


def forget_models_in_use() -> None:
    """As another process would start: no model of this one's in use, none found lately."""
    cad_cache._live.clear()
    cad_cache._recent.clear()
    gc.collect()


KINDS = ["step", "brep", "igs", "3dm"]


@pytest.mark.parametrize("kind", KINDS)
def test_a_second_read_is_a_hit_with_the_same_model_mesh_and_edges(cache, requests, parts, kind):
    if kind not in parts:
        pytest.skip("needs rhino3dm")
    path = parts[kind]
    cold = read_cad(path)
    assert requests == ["read", "keep"]
    assert [p.suffix for p in cache.iterdir()] == [".model"]
    if kind in ("step", "brep"):  # a face left out and (BREP) a healed face: both kept
        assert cold.left_out and (cold.notes or kind == "step")
    cold_mesh, cold_edges = mesh_faces(cold, DEFLECTION), shared_edges(cold, 8)
    for answer in cache.glob("*.answer"):  # the hit's own child meshes: its shape's mesh
        answer.unlink()
    forget_models_in_use()
    requests.clear()

    hit = read_cad(path)
    assert requests == []  # the cached read: no parse, and no kernel until one is needed
    assert hit.brep is not cold.brep and hit.brep.running
    assert same(without_shape(hit), without_shape(cold))
    assert hit.left_out == cold.left_out and hit.notes == cold.notes
    assert same(mesh_faces(hit, DEFLECTION), cold_mesh)  # its child given the cached shape
    assert same(shared_edges(hit, 8), cold_edges)
    assert requests == ["mesh_faces", "load", "shared_edges"]

    forget_models_in_use()  # the kernel's answers were kept too: it is asked nothing
    requests.clear()
    third = read_cad(path)
    assert same(mesh_faces(third, DEFLECTION), cold_mesh)
    assert same(shared_edges(third, 8), cold_edges)
    assert requests == [] and repr(third.brep).endswith("(not started)>")
    mesh_faces(third, DEFLECTION / 2)  # another call is another answer
    assert requests == ["mesh_faces", "load"]


def test_a_model_in_use_shares_its_kernel_process(cache, requests, parts):
    first = read_cad(parts["step"])
    second = read_cad(parts["step"])
    assert requests == ["read", "keep"]
    assert second.brep is first.brep and second is not first
    assert same(without_shape(second), without_shape(first))
    first.brep.close()  # an ended process is not shared: a new one is given the read
    third = read_cad(parts["step"])
    assert third.brep is not first.brep and third.brep.running
    mesh_faces(third, DEFLECTION)
    assert requests == ["read", "keep", "mesh_faces", "load"]


def test_reads_of_a_cached_file_in_one_process_share_its_faces(cache, requests, parts):
    """A batch worker's next scene of a file: the cached read found again (its first
    model's kernel process gone) gives a model of its own with the same face objects, and
    so the scene the same patch objects (what is kept per patch serves it); the entry
    is still checked on disk: a corrupt one is a miss."""
    from gshade.scene import load_scene

    read_cad(parts["step"])  # converted and kept
    forget_models_in_use()
    first = read_cad(parts["step"])
    first.brep.close()  # its kernel process gone: the next read is found in the cache
    second = read_cad(parts["step"])
    assert requests == ["read", "keep"]
    assert second is not first and second.notes is not first.notes
    assert len(second.faces) == len(first.faces) > 0
    assert all(a is b for a, b in zip(first.faces, second.faces, strict=True))
    second.brep.close()
    patches = load_scene(parts["step"]).patches
    assert all(a is b for a, b in zip(patches, load_scene(parts["step"]).patches, strict=True))
    (entry,) = cache.glob("*.model")
    entry.write_bytes(entry.read_bytes()[:-1] + b"?")  # its last byte changed
    third = read_cad(parts["step"])
    assert requests[2:] == ["read", "keep"]  # a miss: read and kept anew
    assert not any(a is b for a, b in zip(first.faces, third.faces, strict=True))


def test_a_changed_file_or_other_options_are_a_miss(cache, requests, parts, tmp_path):
    path = tmp_path / "part.step"
    path.write_bytes(parts["step"].read_bytes())
    before = read_cad(path)
    read_cad(path, sew=True)  # other options: another read
    assert requests == ["read", "keep", "read", "keep"]
    forget_models_in_use()
    requests.clear()
    box = write_shape(filleted_box(), tmp_path / "box.step").read_bytes()
    path.write_bytes(box)
    changed = read_cad(path)
    assert requests == ["read", "keep"]
    assert changed.face_count == 26 != before.face_count
    # the same size and modification time, other bytes (another process: no memory of
    # this one's hashes): the content decides
    stat = path.stat()
    flipped = box.replace(b"Open CASCADE", b"Open_CASCADE")
    assert flipped != box and len(flipped) == len(box)
    path.write_bytes(flipped)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    cache_keys._hashes.clear()
    forget_models_in_use()
    requests.clear()
    read_cad(path)
    assert requests == ["read", "keep"]
    assert len(list(cache.glob("*.model"))) == 4


def test_a_copy_elsewhere_is_a_hit_named_after_itself(cache, requests, parts, tmp_path):
    original = read_cad(parts["step"])
    copy = tmp_path / "copy.step"
    copy.write_bytes(parts["step"].read_bytes())
    forget_models_in_use()
    requests.clear()
    model = read_cad(copy)
    assert requests == []
    assert model.path == copy and original.path == parts["step"]
    assert same(
        dataclasses.replace(without_shape(model), path=original.path), without_shape(original)
    )
    # the child's model is the copy's too: its messages name the copy
    with pytest.raises(GshadeError, match=f"^{copy}: no face 99"):
        mesh_faces(model, DEFLECTION, faces=[99])


def test_a_read_whose_messages_name_its_file_is_kept_for_that_path_only(cache, parts, tmp_path):
    model = without_shape(read_cad(parts["step"]))
    key = cad_cache.model_key(parts["step"], None, None)
    entry = cad_cache.find_model(key, parts["step"])
    naming = dataclasses.replace(model, notes=[f"{parts['step']}: a note naming the file"])
    assert cad_cache.store_model(key, parts["step"], naming, entry.answer, entry.shape)
    assert cad_cache.find_model(key, parts["step"]) is not None
    assert cad_cache.find_model(key, tmp_path / "copy.step") is None


def _entry(cache: Path) -> Path:
    (entry,) = cache.glob("*.model")
    return entry


def _rewritten(change):
    """A corruption that changes an entry's header (a dict) or parts (a list of bytes) and
    keeps every checksum right: only the checks of what it holds can refuse it."""

    def corrupt(path: Path) -> None:
        data = path.read_bytes()
        magic = cache_keys.ENTRY_FORMAT
        end = data.index(b"\n", len(magic))
        header = json.loads(data[len(magic) : end])
        parts, at = [], end + 1
        for size, _ in header["parts"]:
            parts.append(data[at : at + size])
            at += size
        change(header, parts)
        header["parts"] = [[len(p), hashlib.sha256(p).hexdigest()] for p in parts]
        path.write_bytes(magic + json.dumps(header).encode() + b"\n" + b"".join(parts))

    return corrupt


def _evil(header, parts):
    class Planted:
        def __reduce__(self):
            return (os.system, ("echo planted",))

    parts[0] = pickle.dumps(("ok", Planted()))


def _garbage_shape(header, parts):
    parts[1] = parts[1][: len(parts[1]) // 2] + b"\xff" * 64


def _no_shape_faces(header, parts):
    from gshade.cad.cache import shape_bytes

    parts[1] = shape_bytes(sphere_cap())  # a shape, but not this model's


CORRUPTIONS = {
    "garbage": lambda p: p.write_bytes(b"\x00garbage" * 100),
    "empty": lambda p: p.write_bytes(b""),
    "truncated": lambda p: p.write_bytes(p.read_bytes()[:-1000]),
    "a flipped byte": lambda p: p.write_bytes(
        p.read_bytes()[:-500] + bytes([p.read_bytes()[-500] ^ 1]) + p.read_bytes()[-499:]
    ),
    "a header without end": lambda p: p.write_bytes(cache_keys.ENTRY_FORMAT + b"[" * 100_000),
    "another key": _rewritten(lambda h, p: h.update(key="0" * 64)),
    "another face count": _rewritten(lambda h, p: h.update(faces=h["faces"] + 1)),
    "a planted pickle": _rewritten(_evil),
    "a shape the kernel cannot read": _rewritten(_garbage_shape),
    "another model's shape": _rewritten(_no_shape_faces),
}


@pytest.mark.parametrize("corruption", list(CORRUPTIONS))
def test_a_corrupt_or_foreign_entry_is_a_miss_and_written_anew(
    cache, requests, parts, corruption, capfd
):
    fresh = read_cad(parts["step"])
    fresh_mesh = mesh_faces(fresh, DEFLECTION)
    CORRUPTIONS[corruption](_entry(cache))
    for answer in cache.glob("*.answer"):  # the kernel is asked: its shape is needed
        answer.unlink()
    forget_models_in_use()
    requests.clear()
    again = read_cad(parts["step"])
    assert same(without_shape(again), without_shape(fresh))
    assert same(mesh_faces(again, DEFLECTION), fresh_mesh)
    # read afresh: at once (an entry refused here), or when its shape was first needed
    # (one the kernel could not read, or that is not the model's)
    assert requests in (["read", "keep", "mesh_faces"], ["mesh_faces", "load", "read", "keep"])
    assert "planted" not in capfd.readouterr().out
    forget_models_in_use()  # and written anew, whole
    requests.clear()
    model = read_cad(parts["step"])
    assert same(without_shape(model), without_shape(fresh))
    mesh_faces(model, DEFLECTION / 2)
    assert requests == ["mesh_faces", "load"]


def test_a_file_changed_while_its_cached_read_is_in_use_is_one_line(
    cache, requests, parts, tmp_path
):
    """The cached shape cannot be read and the file, read again, is another model than the
    one in use: its kernel operations are refused in one line."""
    path = tmp_path / "part.step"
    path.write_bytes(parts["step"].read_bytes())
    read_cad(path)
    _rewritten(_garbage_shape)(_entry(cache))
    forget_models_in_use()
    model = read_cad(path)
    path.write_bytes(parts["cap"].read_bytes())
    with pytest.raises(GshadeError, match=f"^{path}: the file changed while it was in use"):
        mesh_faces(model, DEFLECTION)
    assert not model.brep.running


@pytest.mark.parametrize("kind", ["symlink", "fifo", "folder"])
def test_an_entry_that_is_not_a_regular_file_is_neither_read_nor_written_through(
    cache, requests, parts, tmp_path, kind
):
    read_cad(parts["step"])
    entry = _entry(cache)
    victim = tmp_path / "victim"
    entry.rename(victim)
    whole = victim.read_bytes()
    if kind == "symlink":  # a whole entry, but through a link: neither read nor followed
        entry.symlink_to(victim)
    elif kind == "fifo":
        os.mkfifo(entry)
    else:
        entry.mkdir()
    forget_models_in_use()
    requests.clear()
    read_cad(parts["step"])  # neither blocks nor fails
    assert requests == ["read", "keep"]
    assert victim.read_bytes() == whole
    if kind == "symlink":  # the link was replaced by the entry, its target left alone
        assert not entry.is_symlink() and entry.read_bytes() == whole
    assert not [p for p in cache.iterdir() if p.name.endswith(".tmp")]


def test_a_linked_cache_subfolder_is_not_written_into(cache, requests, parts, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    cache.parent.mkdir(parents=True)
    cache.symlink_to(elsewhere, target_is_directory=True)
    read_cad(parts["step"])
    forget_models_in_use()
    read_cad(parts["step"])
    assert requests == ["read", "keep", "read", "keep"]
    assert list(elsewhere.iterdir()) == []


def test_concurrent_writers_leave_a_whole_entry(cache, parts, tmp_path):
    """Two processes write one entry 100 times each while this one reads it 300 times: a
    read finds none or the whole entry, never a part; no temporary is left."""
    model = read_cad(parts["step"])
    key = cad_cache.model_key(parts["step"], None, None)
    entry = cad_cache.find_model(key, parts["step"])
    assert entry is not None
    (tmp_path / "answer").write_bytes(entry.answer)
    (tmp_path / "shape").write_bytes(entry.shape)
    code = (
        "import sys; from pathlib import Path; from gshade.cad import cache as cad_cache\n"
        "answer, shape = Path(sys.argv[1]).read_bytes(), Path(sys.argv[2]).read_bytes()\n"
        f"for _ in range(100): cad_cache._write({key!r}, 'model', [answer, shape], "
        f"faces={model.face_count}, names=None)\n"
    )
    command = [sys.executable, "-c", code, str(tmp_path / "answer"), str(tmp_path / "shape")]
    writers = [subprocess.Popen(command) for _ in range(2)]
    bad = 0
    for _ in range(300):
        found = cad_cache.find_model(key, parts["step"])
        bad += found is None or (found.answer, found.shape) != (entry.answer, entry.shape)
    assert [w.wait(timeout=300) for w in writers] == [0, 0]
    assert bad == 0
    assert [p.name for p in cache.iterdir()] == [f"{key}.model"]


def test_two_commands_reading_one_file_at_once(cache, parts):
    """Two ``gshade info`` processes read one file on an empty cache at once: both answer,
    and the entry they leave is whole (a later read is a hit)."""
    command = [sys.executable, "-m", "gshade", "info", str(parts["step"])]
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE) for _ in range(2)]
    outputs = [r.communicate(timeout=300)[0] for r in runs]
    assert [r.returncode for r in runs] == [0, 0] and outputs[0] == outputs[1]
    assert [p.suffix for p in cache.iterdir()] == [".model"]
    cache_keys.fingerprint.cache_clear()  # as the commands found the sources
    key = cad_cache.model_key(parts["step"], None, None)
    assert cad_cache.find_model(key, parts["step"]) is not None


def test_the_folder_is_bounded_and_the_entries_used_longest_ago_go(
    cache, requests, parts, monkeypatch
):
    names = ("step", "igs", "cap")
    keys = {n: cad_cache.model_key(parts[n], None, None) for n in names}
    read_cad(parts["step"])
    read_cad(parts["igs"])
    sizes = {n: (cache / f"{keys[n]}.model").stat().st_size for n in ("step", "igs")}
    # room for the two (and the cap's half for one entry), not for a third
    monkeypatch.setattr(cad_cache, "CACHE_BYTES", sum(sizes.values()) + 1000)
    for age, n in ((2000, "step"), (1000, "igs")):  # the box's read was used longest ago
        entry = cache / f"{keys[n]}.model"
        os.utime(entry, ns=(entry.stat().st_atime_ns, entry.stat().st_mtime_ns - age * 10**9))
    forget_models_in_use()
    requests.clear()
    read_cad(parts["step"])  # a hit: used now, the youngest
    read_cad(parts["cap"])  # a third entry: the one used longest ago goes
    assert requests == ["read", "keep"]
    assert sorted(p.name for p in cache.iterdir()) == sorted(
        f"{keys[n]}.model" for n in ("step", "cap")
    )
    assert sum(p.stat().st_size for p in cache.iterdir()) <= cad_cache.CACHE_BYTES


def test_a_stale_temporary_is_removed_and_a_fresh_one_kept(cache, parts):
    cache.mkdir(parents=True)
    stale, fresh = cache / ".0123456789abcdef.dead.tmp", cache / ".0123456789abcdef.live.tmp"
    for temporary, age in ((stale, 2 * cad_cache._STALE_SECONDS), (fresh, 0)):
        temporary.write_bytes(b"half an entry")
        st = temporary.stat()
        os.utime(temporary, ns=(st.st_atime_ns, st.st_mtime_ns - int(age * 1e9)))
    read_cad(parts["step"])
    assert not stale.exists() and fresh.exists()


def _written(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file())


def test_off_writes_nothing(requests, parts, tmp_path, monkeypatch):
    monkeypatch.setattr(cad_cache, "_live", {})
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "home"
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_CACHE_HOME", str(home / "xdg"))
    monkeypatch.setenv("GSHADE_CACHE_DIR", "off")
    for _ in range(2):
        model = read_cad(parts["step"])
        mesh_faces(model, DEFLECTION)
        del model
        forget_models_in_use()
    assert requests == ["read", "mesh_faces"] * 2
    assert _written(tmp_path) == []
    monkeypatch.delenv("GSHADE_CACHE_DIR")  # the default folder, for contrast
    read_cad(parts["step"])
    assert [p.suffix for p in _written(home)] == [".model"]
    assert _written(home)[0].is_relative_to(home / "xdg" / "gshade" / "cad")


def test_no_cache_writes_nothing_and_is_a_flag_of_the_reading_commands(
    cache, requests, parts, tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    assert main(["info", str(parts["step"]), "--no-cache"]) == 0
    assert requests == ["read"] and _written(tmp_path) == []
    assert os.environ["GSHADE_CACHE_DIR"] == str(cache.parent)  # as it was after
    forget_models_in_use()
    assert main(["info", str(parts["step"])]) == 0  # for contrast: without it, kept
    assert [p.suffix for p in cache.iterdir()] == [".model"]
    parser = build_parser()
    for command in (
        ["render", "s.toml"],
        ["info", "s.toml"],
        ["continuity", "s.toml"],
        ["check"],
        ["batch", "s.toml", "-o", "out"],
        ["figure", "f.toml", "-o", "f.png"],
    ):
        assert parser.parse_args([*command, "--no-cache"]).no_cache
        assert not parser.parse_args(command).no_cache


def test_the_cache_folder_examples(monkeypatch):
    monkeypatch.setenv("GSHADE_CACHE_DIR", "restored after the examples")
    result = doctest.testmod(cache_folder)
    assert result.attempted > 0 and result.failed == 0


#: The kernel process's transport and the cache itself: their source changes no read.
TRANSPORT = {"cad/process.py", "cad/zygote.py", "cad/cache.py", "runtime/cache_folder.py"}


def _imported(start: str, package: Path, skip: set[str]) -> set[str]:
    """The gshade modules ``start`` imports, directly or not (packages' ``__init__``,
    :data:`TRANSPORT` and ``skip`` not followed), as paths relative to the package."""
    found, todo = set(), [start]
    while todo:
        name = todo.pop()
        if name in found or name in TRANSPORT | skip:
            continue
        found.add(name)
        source = package / name
        for node in ast.walk(ast.parse(source.read_text())):
            if not isinstance(node, ast.ImportFrom) or not node.level:
                continue
            base = source.parent
            for _ in range(node.level - 1):
                base = base.parent
            target = base.joinpath(*(node.module or "").split(".")) if node.module else base
            for candidate in [target.with_suffix(".py")] + [
                target / f"{alias.name}.py" for alias in node.names
            ]:
                if candidate.is_file() and candidate.name != "__init__.py":
                    todo.append(candidate.relative_to(package).as_posix())
    return found


@pytest.mark.parametrize(
    ("reader", "modules"),
    [
        ("occt", ["cad/occt.py"]),
        ("3dm", ["cad/rhino.py"]),
        ("occt", ["cad/mesh.py", "cad/edges.py"]),
        ("3dm", ["cad/mesh.py", "cad/edges.py"]),
    ],
)
def test_the_key_holds_the_source_of_every_module_a_read_or_answer_depends_on(reader, modules):
    """An edit to any module the readers, the mesher or the edges import is another key."""
    package = Path(cad_cache.__file__).resolve().parents[1]
    patterns = [*cache_keys.SOURCES, *cache_keys.READER_SOURCES[reader]]
    for module in modules:
        patterns += cache_keys.OPERATION_SOURCES.get(f"gshade.{module[:-3].replace('/', '.')}", ())
    keyed = {p.relative_to(package).as_posix() for g in patterns for p in package.glob(g)}
    other = {"occt": {"cad/rhino.py"}, "3dm": set()}[reader]  # cad.read_cad's other reader
    needed = set().union(*(_imported(m, package, other) for m in modules))
    assert needed - keyed == set()


def test_the_command_line_starts_no_kernel_for_a_cached_file(cache, parts, monkeypatch):
    """The kernel's process is started ahead (while gshade loads) only for a file whose
    read is not cached: a cached one may need no kernel at all."""
    from gshade.cad import zygote as cad_zygote

    started: list[int] = []
    monkeypatch.setattr(cad_zygote, "prestart", lambda: started.append(1))
    assert main(["info", str(parts["cap"])]) == 0
    assert started == [1]
    assert main(["info", str(parts["cap"])]) == 0
    assert started == [1]
    assert main(["info", str(parts["cap"]), "--no-cache"]) == 0  # nothing cached then
    assert started == [1, 1]
