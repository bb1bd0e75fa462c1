"""The Python API against the CLI it wraps: the same networks shaded and the same scene
rendered give the same bits; errors raise the right exception with shadenet's message.

The CLI is the debug binary of the same checkout: ``SHADENET_BIN``, else
``$CARGO_TARGET_DIR/debug/shadenet``, else ``<repo>/target/debug/shadenet`` (build it with
``cargo build`` first). Grids are small: the dev build is not optimized.
"""

from __future__ import annotations

import os
import pathlib
import subprocess

import numpy as np
import pytest

import shadenet

REPO = pathlib.Path(__file__).resolve().parents[2]
MARBLE = REPO / "examples" / "networks" / "marble.json"


def cli_binary() -> pathlib.Path:
    """The `shadenet` CLI to compare against; fails (not skips) when it is not built."""
    candidates = []
    if os.environ.get("SHADENET_BIN"):
        candidates.append(pathlib.Path(os.environ["SHADENET_BIN"]))
    if os.environ.get("CARGO_TARGET_DIR"):
        candidates.append(pathlib.Path(os.environ["CARGO_TARGET_DIR"]) / "debug" / "shadenet")
    candidates.append(REPO / "target" / "debug" / "shadenet")
    for c in candidates:
        if c.is_file():
            return c
    pytest.fail(
        "the shadenet CLI is not built (looked at: "
        + ", ".join(map(str, candidates))
        + "); run `cargo build` or set SHADENET_BIN"
    )


def run_cli(*args: str) -> None:
    """Runs the CLI quietly in the repository; fails the test with its stderr on error."""
    p = subprocess.run(
        [str(cli_binary()), *args], cwd=REPO, capture_output=True, text=True, timeout=300
    )
    assert p.returncode == 0, f"shadenet {' '.join(args)} failed:\n{p.stderr}"


def bits(a: np.ndarray) -> np.ndarray:
    """The float32 bit patterns (NaN-safe, -0 distinct from 0)."""
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def assert_same_bits(got: dict, want: dict, what: str) -> None:
    assert sorted(got) == sorted(want), what
    for k in want:
        assert got[k].shape == want[k].shape, f"{what}: {k}"
        differ = int(np.count_nonzero(bits(got[k]) != bits(want[k])))
        assert differ == 0, f"{what}: layer {k}: {differ} samples differ"


# ---- (a) shading: bit-identical to `shadenet shade -o x.exr` --------------------------


@pytest.mark.parametrize("backend", ["interp", "jit", "jit-batch"])
@pytest.mark.parametrize(
    "extra",
    [
        {},
        {"lights": ["spot:0,0,2:0,0,-1:30:60:1,0.5,0.25", "ambient:0.1"]},
        {"mask": ["diffuse"]},
    ],
    ids=["default-light", "lights", "mask"],
)
def test_shade_is_the_cli_shade_bit_for_bit(tmp_path, backend, extra):
    w, h = 13, 7  # rows that end inside a packet of four
    exr = tmp_path / "shade.exr"
    args = ["shade", str(MARBLE), "-o", str(exr), "--res", f"{w}x{h}", "--backend", backend, "-q"]
    for light in extra.get("lights", []):
        args += ["--light", light]
    if "mask" in extra:
        args += ["--components", ",".join(extra["mask"])]
    run_cli(*args)
    cli = shadenet.read_exr(exr)

    mat = shadenet.compile(MARBLE)
    out = mat.shade(shadenet.grid(w, h), backend=backend, **extra)
    got = {k: v.reshape(h, w, -1) for k, v in out.items()}
    assert_same_bits(got, cli["layers"], f"marble {backend} {extra}")
    # The layers carry the outputs' channel names, in the EXR's order.
    for o in mat.outputs:
        assert cli["channels"][o["name"]] == o["channels"]
        for c in o["components"]:
            assert cli["channels"][f"{o['name']}.{c}"] == o["channels"]
    # Not all zero: the comparison saw an image.
    assert np.count_nonzero(out["color"]) > 0


def test_gpu_shade_is_the_cli_gpu_shade(tmp_path):
    w, h = 13, 7
    mat = shadenet.compile(MARBLE)
    try:
        out = mat.shade(shadenet.grid(w, h), backend="gpu")
    except shadenet.ShadenetError as e:
        assert "the GPU back end cannot start" in str(e)
        pytest.skip(f"no GPU adapter: {e}")
    exr = tmp_path / "gpu.exr"
    run_cli("shade", str(MARBLE), "-o", str(exr), "--res", f"{w}x{h}", "--backend", "gpu", "-q")
    got = {k: v.reshape(h, w, -1) for k, v in out.items()}
    assert_same_bits(got, shadenet.read_exr(exr)["layers"], "marble gpu")


def test_grid_is_the_cli_grid_and_defaults_fill_the_rest():
    g = shadenet.grid(4, 2)
    assert sorted(g) == sorted(shadenet.FRAGMENT_FIELDS)
    # Pixel (x=1, y=0): uv = ((1 + ½)/4, 1 − ½/2), P = uv − ½, seed = the pixel index.
    np.testing.assert_array_equal(g["uv"][1], np.float32([0.375, 0.75]))
    np.testing.assert_array_equal(g["P"][1], np.float32([-0.125, 0.25, 0.0]))
    np.testing.assert_array_equal(g["seed"], np.arange(8, dtype=np.uint32))
    mat = shadenet.compile(MARBLE)
    full = mat.shade(g, backend="interp")
    # The defaults of the fields the grid shares with them (N, Ng, I, dPdu, dPdv, seed)
    # reproduce it: only P, uv, dPdx, dPdy and time given.
    some = {k: g[k] for k in ("P", "uv", "dPdx", "dPdy", "time")}
    assert_same_bits(mat.shade(some, backend="interp"), full, "defaults")
    # Float64 input and (n, 1) columns are converted.
    some = dict(some, P=g["P"].astype(np.float64), time=g["time"][:, None])
    assert_same_bits(mat.shade(some, backend="interp"), full, "float64")


def test_threads_share_a_material_and_get_the_serial_bits():
    import threading

    mat = shadenet.compile(MARBLE)
    g = shadenet.grid(9, 5)
    want = {b: mat.shade(g, backend=b) for b in ("interp", "jit", "jit-batch")}
    fresh = shadenet.compile(MARBLE)  # its back ends compiled by the threads, concurrently
    got = {}

    def work(i, backend):
        got[i] = (backend, fresh.shade(g, backend=backend), fresh.stats["jit"])

    threads = [threading.Thread(target=work, args=(i, b))
               for i, b in enumerate(["jit", "jit-batch", "interp", "jit", "jit-batch", "interp"])]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(got) == 6
    for backend, out, jit in got.values():
        assert_same_bits(out, want[backend], f"thread {backend}")
        assert jit == got[0][2]


def test_no_fragments_give_empty_layers():
    out = shadenet.compile(MARBLE).shade({"P": np.zeros((0, 3))})
    assert out["color"].shape == (0, 3) and out["veins"].shape == (0, 1)


# ---- (b) rendering: the layers `shadenet render -o x.exr` writes -----------------------


def test_render_is_the_cli_render_bit_for_bit(tmp_path):
    exr = tmp_path / "render.exr"
    run_cli("render", "--res", "64x36", "--spp", "1", "-o", str(exr), "-q")
    cli = shadenet.read_exr(exr)

    r = shadenet.render(res=(64, 36), spp=1)
    assert list(r["layers"])[0] == "beauty"
    assert r["channels"] == {k: cli["channels"][k] for k in r["layers"]}
    assert_same_bits(r["layers"], cli["layers"], "default scene")
    assert r["layers"]["beauty"].shape == (36, 64, 4)
    assert r["stats"]["spp"] == 1 and r["stats"]["camera_rays"] == 64 * 36
    assert np.count_nonzero(r["layers"]["beauty"][:, :, :3]) > 0

    # write_exr writes what render returned; read back, the same bits.
    again = tmp_path / "again.exr"
    shadenet.write_exr(again, r["layers"], r["channels"])
    back = shadenet.read_exr(again)
    assert back["channels"] == r["channels"]
    assert_same_bits(back["layers"], r["layers"], "write_exr round trip")


def test_render_passes_and_backend(tmp_path):
    exr = tmp_path / "p.exr"
    run_cli("render", "--res", "16x9", "--spp", "1", "--passes", "diffuse,depth",
            "--backend", "interp", "-o", str(exr), "-q")
    r = shadenet.render(res=(16, 9), spp=1, passes=["diffuse", "depth"], backend="interp",
                        threads=1)
    assert list(r["layers"]) == ["beauty", "diffuse", "depth"]
    assert r["stats"]["threads"] == 1 and r["stats"]["backend"] == "interp"
    assert_same_bits(r["layers"], shadenet.read_exr(exr)["layers"], "passes")


# ---- (c) MaterialX ---------------------------------------------------------------------


@pytest.mark.skipif(
    not os.environ.get("SHADENET_MTLX_LIBRARIES"),
    reason="SHADENET_MTLX_LIBRARIES is not set (the MaterialX data libraries: "
    "`pip install materialx`, its MaterialX/libraries folder)",
)
def test_mtlx_path_and_text_compile_and_shade_as_the_cli(tmp_path):
    doc = REPO / "examples" / "materials" / "marble.mtlx"
    from_path = shadenet.compile(doc)
    assert from_path.name == "marble"
    from_text = shadenet.compile(doc.read_text(), name="marble")
    assert from_text.ir == from_path.ir
    assert from_path.stats["ops_after"] <= from_path.stats["ops_before"]

    w, h = 8, 5
    exr = tmp_path / "m.exr"
    run_cli("shade", str(doc), "-o", str(exr), "--res", f"{w}x{h}", "-q")
    out = from_path.shade(shadenet.grid(w, h))
    got = {k: v.reshape(h, w, -1) for k, v in out.items()}
    assert_same_bits(got, shadenet.read_exr(exr)["layers"], "marble.mtlx")


def test_mtlx_text_without_libraries_names_them(monkeypatch):
    monkeypatch.delenv("SHADENET_MTLX_LIBRARIES", raising=False)
    monkeypatch.delenv("MATERIALX_SEARCH_PATH", raising=False)
    with pytest.raises(shadenet.ShadenetError, match="MaterialX data libraries were not found"):
        shadenet.compile('<?xml version="1.0"?><materialx version="1.38"/>')


# ---- compile: IR and statistics -------------------------------------------------------


def test_compile_ir_and_stats_are_compile_s():
    mat = shadenet.compile(MARBLE)
    assert mat.name == "marble"

    def cli(*args: str) -> str:
        p = subprocess.run([str(cli_binary()), "compile", str(MARBLE), *args], cwd=REPO,
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr
        return p.stdout

    assert mat.ir == cli()
    assert mat.ir_before == cli("--emit", "ir:before")
    # `--stats` without the times (the only thing that changes from run to run).
    untimed = lambda text: [line.rsplit(None, 1)[0] if line.endswith("ms") else line
                            for line in text.splitlines() if not line.startswith(("total", "jit"))]
    cli_stats = cli("--stats")
    s = mat.stats
    assert untimed(s["report"]) == untimed(cli_stats.split("jit: ")[0])
    assert f"total: {s['ops_before']} → {s['ops_after']} ops in " in cli_stats
    assert s["ops_after"] < s["ops_before"]
    assert [x["pass"] for x in s["passes"]] == [
        "specialize", "fold", "dead_branch", "unroll", "cse", "dce", "hoist"]
    jit_line = next(line for line in cli_stats.splitlines() if line.startswith("jit: "))
    assert s["jit"].split(";")[0] == jit_line[len("jit: "):].split(";")[0]  # "140 ops"
    assert s["jit"].split("; ")[-1] == jit_line.split("; ")[-1]  # IR and code size
    # Text compiles to the same program; name= renames it.
    text = shadenet.compile(MARBLE.read_text(), name="m2")
    assert text.name == "m2" and text.ir == mat.ir.replace('"marble"', '"m2"', 1)


# ---- (d) errors ------------------------------------------------------------------------


def test_errors_are_shadenet_errors_with_the_full_message(tmp_path):
    assert issubclass(shadenet.ShadenetError, Exception)
    with pytest.raises(shadenet.ShadenetError, match=r"cannot read network no/such\.json"):
        shadenet.compile("no/such.json")
    with pytest.raises(shadenet.ShadenetError,
                       match=r"<network text>: malformed network: .* at line 1 column 11"):
        shadenet.compile('{"nodes": [')
    bad = tmp_path / "bad.json"
    bad.write_text('{\n  "nodes": [\n    {"name": 1}\n  ]\n}\n')
    with pytest.raises(shadenet.ShadenetError) as e:
        shadenet.compile(bad)
    assert str(e.value).startswith(f"{bad}: malformed network: ")
    assert "line 3 column" in str(e.value)
    with pytest.raises(shadenet.ShadenetError, match="unknown node type `nope`"):
        shadenet.compile('{"nodes": [{"name": "a", "type": "nope"}]}')
    with pytest.raises(TypeError, match="source"):
        shadenet.compile(42)
    with pytest.raises(ValueError, match="MaterialX documents only"):
        shadenet.compile(MARBLE, material="m")
    with pytest.raises(shadenet.ShadenetError, match=r"no/scene\.toml"):
        shadenet.render("no/scene.toml")
    with pytest.raises(shadenet.ShadenetError, match=r"no/such\.exr"):
        shadenet.read_exr(tmp_path / "no" / "such.exr")


def test_bad_fragments_name_the_key():
    mat = shadenet.compile(MARBLE)
    P = shadenet.grid(3, 2)["P"]
    cases = [
        ({"P": P[:, :2]}, r'fragments\["P"\]: shape \(6, 2\), expected \(n, 3\)'),
        ({"P": P, "N": P[:4]}, r'fragments\["N"\]: 4 rows, but "P" has 6'),
        ({"P": P, "uv": np.zeros((6, 3))}, r'fragments\["uv"\]: shape \(6, 3\), expected \(n, 2\)'),
        ({"P": P, "time": np.zeros((6, 2))}, r'fragments\["time"\]: shape \(6, 2\), expected \(n,\)'),
        ({"N": P}, r'"P" is required'),
        ({"P": P, "colour": P}, r'unknown key "colour"'),
        ({"P": P, "seed": -np.ones(6, dtype=np.int64)}, r'fragments\["seed"\]: values must be'),
    ]
    for frags, msg in cases:
        with pytest.raises(ValueError, match=msg):
            mat.shade(frags)
    nan = P.copy()
    nan[4, 1] = np.nan
    with pytest.raises(ValueError, match=r'fragments\["Ng"\]: row 4 holds NaN'):
        mat.shade({"P": P, "Ng": nan})
    with pytest.raises(TypeError, match="expected a dict"):
        mat.shade([P])
    with pytest.raises(TypeError, match=r'fragments\["seed"\]: expected integers'):
        mat.shade({"P": P, "seed": np.zeros(6)})


def test_bad_options_raise_value_errors():
    mat = shadenet.compile(MARBLE)
    g = shadenet.grid(2, 2)
    with pytest.raises(ValueError, match=r'unknown backend "cuda": expected interp, jit, jit-batch or gpu'):
        mat.shade(g, backend="cuda")
    with pytest.raises(ValueError, match=r'lights\[1\] "laser:1": expected point:'):
        mat.shade(g, lights=["ambient:1", "laser:1"])
    with pytest.raises(ValueError, match=r"mask: .*`glow`"):
        mat.shade(g, mask=["glow"])
    with pytest.raises(ValueError, match=r'unknown backend "cuda"'):
        shadenet.render(res=(4, 4), spp=1, backend="cuda")
    with pytest.raises(ValueError, match="jit-batch.*not available to render"):
        shadenet.render(res=(4, 4), spp=1, backend="jit-batch")
    with pytest.raises(ValueError, match="--spp must be 1 to"):
        shadenet.render(res=(4, 4), spp=10**9)
    with pytest.raises(shadenet.ShadenetError, match="unknown render component `sparkle`"):
        shadenet.render(res=(4, 4), spp=1, passes=["sparkle"])
    with pytest.raises(ValueError, match="threads=100000"):
        shadenet.render(res=(4, 4), spp=1, threads=100000)
    with pytest.raises(TypeError, match="res"):
        shadenet.render(res="64x36")


def test_write_exr_is_atomic_and_checks_shapes(tmp_path):
    a = np.arange(24, dtype=np.float32).reshape(2, 4, 3)
    path = tmp_path / "x.exr"
    shadenet.write_exr(path, {"c": a, "d": a[:, :, 0]})
    back = shadenet.read_exr(path)
    assert back["channels"] == {"c": ["R", "G", "B"], "d": ["Y"]}
    assert_same_bits(back["layers"], {"c": a, "d": a[:, :, :1]}, "round trip")
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r'layers\["d"\]: 3x2, but the first layer is 4x2'):
        shadenet.write_exr(path, {"c": a, "d": a[:, :3]})
    with pytest.raises(shadenet.ShadenetError, match="cannot write"):
        shadenet.write_exr(tmp_path / "no" / "dir" / "y.exr", {"c": a})
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.exr"]


def test_rsl_shader_files_compile_and_shade_as_the_cli_does(tmp_path):
    """A `.sl` path compiles like a network: its IR is the CLI's and its outputs Ci, Oi."""
    mat = shadenet.compile(REPO / "examples" / "shaders" / "plastic.sl")
    assert mat.name == "plastic"
    out = mat.shade(shadenet.grid(8, 4), lights=["point:1,1,2:3"])
    assert out["Ci"].shape == (32, 3) and out["Oi"].shape == (32, 3)
    assert np.all(out["Oi"] == 1.0) and np.all(out["Ci"] > 0)
    bad = tmp_path / "bad.sl"
    bad.write_text("surface s() { Ci = colr(1); }\n")
    with pytest.raises(shadenet.ShadenetError, match=r"unknown function `colr`"):
        shadenet.compile(str(bad))
