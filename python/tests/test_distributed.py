"""shadenet.distributed on a local Ray cluster: tiles assembled bit-identically to a single
process, a killed worker's tile retried and reported, bad input refused before any output."""

import os
import subprocess

import numpy as np
import pytest

import shadenet
from shadenet import distributed as dist

ray = pytest.importorskip("ray", reason="Ray is not installed (.ci/run installs it)")

#: Small enough for the unoptimised build CI tests; the default scene all the same.
RES = (64, 36)
SPP = 2


@pytest.fixture(scope="module")
def cluster():
    """A local two-CPU cluster, its workers separate processes."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def shadenet_bin():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return os.environ.get("SHADENET_BIN", os.path.join(root, "target", "debug", "shadenet"))


def cli_render(out, *args):
    """``shadenet render ARGS -o OUT -q`` (the single-process reference); returns ``out``."""
    subprocess.run([shadenet_bin(), "render", *args, "-o", str(out), "-q"], check=True)
    return out


def test_split_frame_tiles_the_frame_exactly():
    for (w, h, n) in [(640, 360, 16), (64, 36, 16), (7, 5, 7), (10, 1, 4), (3, 3, 9), (5, 4, 1)]:
        wins = dist.split_frame(w, h, tiles=n)
        assert len(wins) == n
        cover = np.zeros((h, w), dtype=int)
        for x0, y0, x1, y1 in wins:
            assert x0 < x1 and y0 < y1
            cover[y0:y1, x0:x1] += 1
        assert (cover == 1).all(), (w, h, n)
    assert dist.split_frame(640, 360, tiles=16)[:2] == [(0, 0, 160, 90), (160, 0, 320, 90)]
    assert dist.split_frame(100, 50, tile_size=32) == [
        (0, 0, 32, 32), (32, 0, 64, 32), (64, 0, 96, 32), (96, 0, 100, 32),
        (0, 32, 32, 50), (32, 32, 64, 50), (64, 32, 96, 50), (96, 32, 100, 50),
    ]
    for bad in [dict(tiles=0), dict(tiles=10 * 10 + 1), dict(tile_size=0), {}, dict(tiles=2, tile_size=3)]:
        with pytest.raises(ValueError):
            dist.split_frame(10, 10, **bad)


def test_sixteen_tiles_merge_bit_identically_to_one_process(cluster, tmp_path):
    single = cli_render(tmp_path / "single.exr", "--res", "%dx%d" % RES, "--spp", str(SPP))
    out = tmp_path / "tiles.exr"
    r = dist.render(None, out, tiles=16, res=RES, spp=SPP, progress=False)
    assert r.tasks == 16 and r.retries == {}
    assert len(r.task_seconds) == 16
    # The same file, byte for byte, as the single-process render writes.
    assert out.read_bytes() == single.read_bytes()
    # And the layers returned are the ones in it.
    whole = shadenet.render(res=RES, spp=SPP)
    for name, data in whole["layers"].items():
        assert np.array_equal(r.layers[name].view(np.uint32), data.view(np.uint32)), name


def test_a_killed_worker_is_retried_and_the_image_is_unchanged(cluster, tmp_path, monkeypatch):
    marker = tmp_path / "tile5-failed"
    monkeypatch.setenv(dist.FAIL_TILE_ENV, f"5:{marker}")
    single = cli_render(tmp_path / "single.exr", "--res", "%dx%d" % RES, "--spp", str(SPP))
    out = tmp_path / "retried.exr"
    r = dist.render(None, out, tiles=8, res=RES, spp=SPP, progress=False)
    # The first attempt of tile 5 exited its worker process; Ray ran it again.
    assert marker.exists()
    assert list(r.retries) == [5], r.retries
    assert len(r.retries[5]) == 2
    assert r.retries[5][0][1] != r.retries[5][1][1], "the retry ran in another process"
    assert out.read_bytes() == single.read_bytes()


def test_bad_input_is_refused_and_writes_nothing(cluster, tmp_path):
    out = tmp_path / "out.exr"
    out.write_bytes(b"keep")
    with pytest.raises(shadenet.ShadenetError, match="cannot read the scene .*no/such.toml"):
        dist.render("no/such.toml", out, tiles=4)
    with pytest.raises(ValueError, match="tiles=0"):
        dist.render(None, out, tiles=0, res=RES)
    with pytest.raises(ValueError, match="give tiles=N or tile_size=S"):
        dist.render(None, out, res=RES)
    bad_scene = tmp_path / "bad.toml"
    bad_scene.write_text("[camera]\nres = [\n")
    with pytest.raises(shadenet.ShadenetError, match="bad.toml"):
        dist.render(bad_scene, out, tiles=4)
    assert out.read_bytes() == b"keep"


def test_command_line_entry(cluster, tmp_path):
    out = tmp_path / "cli.exr"
    code = dist.main([
        "-o", str(out), "--tiles", "4", "--res", "%dx%d" % RES, "--spp", "1", "-q",
    ])
    assert code == 0 and out.exists()
    assert dist.main(["no/such.toml", "-o", str(tmp_path / "x.exr"), "-q"]) == 1
    assert not (tmp_path / "x.exr").exists()


def test_renderer_crops_hold_the_full_render_bits():
    r = shadenet.Renderer(res=RES, spp=1)
    assert r.frame == RES and r.spp == 1
    whole = r.render()
    assert whole["window"] == (0, 0) + RES and whole["frame"] == RES
    part = r.render(crop=(10, 5, 30, 20))
    assert part["window"] == (10, 5, 30, 20) and part["frame"] == RES
    for name, data in whole["layers"].items():
        assert part["layers"][name].shape == (15, 20, data.shape[2])
        assert np.array_equal(part["layers"][name].view(np.uint32), data[5:20, 10:30].view(np.uint32))
    # The one-call form takes the crop too.
    once = shadenet.render(res=RES, spp=1, crop=(10, 5, 30, 20))
    assert np.array_equal(once["layers"]["beauty"], part["layers"]["beauty"])
    for bad, want in [((0, 0, 65, 2), "reaches outside"), ((3, 3, 3, 9), "is empty")]:
        with pytest.raises(ValueError, match=want):
            r.render(crop=bad)
    with pytest.raises(TypeError, match="crop"):
        r.render(crop=(1, 2, 3))
    assert shadenet.frame_size(res=(7, 9)) == (7, 9)
    assert shadenet.frame_size() == (640, 360)


def test_frames_of_a_sequence_render_one_task_each(cluster, tmp_path):
    """`frames=[...]`: one task per scene file, each written where the pattern says, each
    the bytes `shadenet render` writes for it."""
    scenes = []
    for k, x in enumerate([-0.5, 0.5]):
        p = tmp_path / f"frame{k}.toml"
        p.write_text(
            "[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nresolution = [24, 16]\n"
            "[render]\nspp = 1\n"
            "[materials.m.inline]\nnodes = [{ name = \"l\", type = \"lambert\" }]\n"
            "outputs = { color = \"l.outColor\" }\n"
            "[meshes.b]\ntype = \"sphere\"\n"
            f"[[instances]]\nmesh = \"b\"\nmaterial = \"m\"\ntranslate = [{x}, 0, 0]\n"
            "[[lights]]\ntype = \"point\"\nposition = [2, 2, 4]\nintensity = 20\n"
        )
        scenes.append(p)
    out = tmp_path / "out"
    out.mkdir()
    r = dist.render(frames=scenes, output=str(out / "{stem}.exr"), progress=False)
    assert r.tasks == 2 and r.retries == {}
    assert r.outputs == [str(out / "frame0.exr"), str(out / "frame1.exr")]
    for scene, written in zip(scenes, r.outputs):
        single = cli_render(tmp_path / (scene.stem + "-cli.exr"), str(scene))
        assert open(written, "rb").read() == single.read_bytes()
    with pytest.raises(ValueError, match="names two frames the same file"):
        dist.render(frames=scenes, output=str(out / "same.exr"), progress=False)
