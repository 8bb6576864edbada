"""`moonbot render-one` end to end: the files it writes decode back to the rendered arrays, the
pose in gt.json re-projects the model onto the mask, outputs are independent of the thread
count, and bad input gives a clear error naming the field or file."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner
from PIL import Image

from moonbot.bop import sample_surface
from moonbot.cli import main
from moonbot.config.load import load_config
from moonbot.scene import compose_scene
from moonbot.scene.bag_mesh import filled_cuboid
from moonbot.scene.collision import transform
from moonbot.writer import depth_to_png16

pytestmark = pytest.mark.unit

SMALL = ["--set", "camera.width=160", "--set", "camera.height=120", "--set", "render.spp=2"]
FILES = ("rgb.png", "depth.npy", "depth.png", "depth_preview.png", "mask.png", "amodal_001.png", "gt.json")


def render_one(out: Path, *args: str) -> Path:
    result = CliRunner().invoke(main, ["render-one", "--out", str(out), *SMALL, *args])
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def view0(tmp_path_factory) -> Path:
    return render_one(tmp_path_factory.mktemp("render-one")) / "view_000"


def test_writes_every_file_and_nothing_else(view0):
    assert sorted(p.name for p in view0.iterdir()) == sorted(FILES)  # no temporaries left


def test_pngs_decode_to_the_arrays(view0):
    """Decoded with Pillow (not the encoder's library): depth.png is the mm rounding of
    depth.npy, the mask holds exactly the instance labels, rgb is 8-bit RGB."""
    depth = np.load(view0 / "depth.npy")
    assert depth.dtype == np.float32 and depth.shape == (120, 160)
    depth_png = np.array(Image.open(view0 / "depth.png"))
    assert depth_png.dtype == np.uint16
    np.testing.assert_array_equal(depth_png, depth_to_png16(depth))
    mask = np.array(Image.open(view0 / "mask.png"))
    assert mask.dtype == np.uint8 and set(np.unique(mask)) == {0, 1}
    gt = json.loads((view0 / "gt.json").read_text())
    assert (mask == 1).sum() == gt["instances"][0]["px_count_visib"] > 500
    rgb = np.array(Image.open(view0 / "rgb.png"))
    assert rgb.shape == (120, 160, 3) and rgb.dtype == np.uint8
    # The sunlit top of the tan bag (albedo ~0.45) is brighter than any regolith (0.12).
    assert rgb[mask == 1].max() > rgb[mask == 0].max()
    preview = np.array(Image.open(view0 / "depth_preview.png"))
    assert preview.dtype == np.uint8 and (preview[depth > 0] > 0).all()


def test_gt_pose_reprojects_the_model_onto_the_mask(view0):
    """Backward: every mask pixel, back-projected with its depth and K and carried into the
    model frame by the inverse of (cam_R_m2c, cam_t_m2c), lies on the sandbag-01 mesh. Forward:
    points spread over the model's surface, projected with the pose and K, land on the mask
    wherever depth.npy says they are visible."""
    gt = json.loads((view0 / "gt.json").read_text())
    K = np.array(gt["cam_K"]).reshape(3, 3)
    inst = gt["instances"][0]
    assert inst["obj_id"] == 1
    R = np.array(inst["cam_R_m2c"]).reshape(3, 3)
    t = np.array(inst["cam_t_m2c"]) / 1000.0
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    vertices, triangles = filled_cuboid()
    mesh = trimesh.Trimesh(vertices.astype(np.float64), triangles, process=False)
    depth = np.load(view0 / "depth.npy")
    mask = np.array(Image.open(view0 / "mask.png")) == 1

    v, u = np.nonzero(mask)
    z = depth[v, u].astype(np.float64)
    cam = np.column_stack([(u + 0.5 - K[0, 2]) / K[0, 0] * z, (v + 0.5 - K[1, 2]) / K[1, 1] * z, z])
    model = (cam - t) @ R  # R^T (x - t), as row vectors
    _, distance, _ = trimesh.proximity.closest_point(mesh, model)
    assert distance.max() < 1e-4  # metres: float32 depth at ~1 m

    surface = sample_surface(vertices, triangles, 0.004)
    # Within 5 mm of the ground the ground's depth equals the bag's to within the tolerance
    # below, so "visible" cannot be told apart there; leave out the points that close to the
    # ground under them (the regolith's cm relief rises that high beside a resting bag).
    spec = compose_scene(load_config(None, {"camera.width": 160, "camera.height": 120, "render.spp": 2}))
    world = transform(surface, spec.bags[0].world_from_model)
    surface = surface[world[:, 2] > spec.ground.height(world[:, 0], world[:, 1]) + 0.005]
    cam_points = surface @ R.T + t
    uv = cam_points @ K.T
    px = np.floor(uv[:, :2] / uv[:, 2:3]).astype(int)
    inside = (px[:, 0] >= 0) & (px[:, 0] < mask.shape[1]) & (px[:, 1] >= 0) & (px[:, 1] < mask.shape[0])
    px, zc = px[inside], cam_points[inside, 2]
    visible = np.abs(depth[px[:, 1], px[:, 0]] - zc) < 2e-3
    assert visible.sum() > 1000
    assert mask[px[visible, 1], px[visible, 0]].all()


def test_bytes_identical_for_one_and_two_threads(tmp_path):
    a = render_one(tmp_path / "a", "--set", "render.threads=1") / "view_000"
    b = render_one(tmp_path / "b", "--set", "render.threads=2") / "view_000"
    for name in FILES[:-1]:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    ga, gb = (json.loads((d / "gt.json").read_text()) for d in (a, b))
    ga.pop("timings_s"), gb.pop("timings_s")
    assert ga.pop("config_hash") != gb.pop("config_hash")  # the thread count is in the config
    assert ga == gb


def test_sheet_shows_the_written_files(view0):
    """sheet.png is a label strip over rgb | depth preview | coloured mask, decoded from the files
    as written."""
    from moonbot.writer import colour_mask
    from moonbot.writer.sheet import LABEL_PX

    sheet = np.array(Image.open(view0.parent / "sheet.png"))
    labels, sheet = sheet[:LABEL_PX], sheet[LABEL_PX:]
    w = 160 + 2  # tile and gap
    assert sheet.shape == (120, 3 * 160 + 2 * 2, 3)
    for tile in range(3):  # each tile has its label, drawn inside its own width
        assert (labels[:, tile * w : tile * w + 160] != labels[0, 0]).any()
    np.testing.assert_array_equal(sheet[:, :160], np.array(Image.open(view0 / "rgb.png")))
    preview = np.array(Image.open(view0 / "depth_preview.png"))
    np.testing.assert_array_equal(sheet[:, w : w + 160], np.repeat(preview[..., None], 3, axis=2))
    mask = np.array(Image.open(view0 / "mask.png"))
    np.testing.assert_array_equal(sheet[:, 2 * w :], colour_mask(mask))
    assert (sheet[:, 2 * w :][mask == 1] > 0).any() and (sheet[:, 2 * w :][mask == 0] == 0).all()


def test_sheet_labels_stay_over_their_tiles():
    """A label longer than its tile is clipped to it: the next tile's label strip stays clear."""
    from moonbot.writer.sheet import LABEL_PX, label_strip

    strip = label_strip(["view 035, az 350°, rgb, and more words than fit", "", ""], 40, 2)
    assert strip.shape == (LABEL_PX, 3 * 40 + 2 * 2, 3)
    assert (strip[:, :40] != strip[0, -1]).any() and (strip[:, 40:] == strip[0, -1]).all()


def test_the_summary_lists_every_file_written_and_says_each_stage(tmp_path):
    """render-one's file list names every file a view folder holds (amodal masks included), and it
    prints a line per stage with the seconds since it started, views in order."""
    result = CliRunner().invoke(main, ["render-one", "--out", str(tmp_path), *SMALL, "--view", "0", "--view", "3"])
    assert result.exit_code == 0, result.output
    listed = {line.split("view_NNN/")[1].split()[0] for line in result.stdout.splitlines() if "view_NNN/" in line}
    written = {re.sub(r"_\d{3}\.", "_NNN.", p.name) for p in (tmp_path / "view_003").iterdir()}
    assert listed == written
    stages = [line.split("] ", 1)[1] for line in result.stderr.splitlines() if line.startswith("[")]
    assert stages[0] == "compose scene" and stages[-1] == "contact sheet"
    assert stages.index("render view 0") < stages.index("encode view 0") < stages.index("render view 3")
    seconds = [float(line[1:].split(" s]")[0]) for line in result.stderr.splitlines() if line.startswith("[")]
    assert seconds == sorted(seconds)


def test_several_views_share_one_scene(tmp_path):
    out = render_one(tmp_path, "--view", "0", "--view", "9", "--view", "35")
    gts = [json.loads((out / f"view_{v:03d}" / "gt.json").read_text()) for v in (0, 9, 35)]
    assert [g["camera_azimuth_deg"] for g in gts] == [0.0, 90.0, 350.0]
    assert gts[0]["timings_s"]["build_bvh"] > 0
    assert gts[1]["timings_s"]["build_bvh"] == 0 == gts[2]["timings_s"]["build_bvh"]
    assert gts[0]["timings_s"]["settle"] > 0 and gts[1]["timings_s"]["settle"] == 0
    assert len({g["render_seed"] for g in gts}) == 3


def test_exr_output_is_the_radiance_behind_rgb_png(tmp_path):
    """With output.exr the view also has rgb.exr (decoded by the OpenEXR package): finite linear
    radiance that gt.json's veiling glare and the core's tone map at its EV100 turn into rgb.png
    byte for byte; the summary lists it and the default exposure is `auto` metering of the
    regolith."""
    import OpenEXR

    from moonbot import _core
    from moonbot.config import load_config
    from moonbot.render.exposure import auto_ev100, regolith_reflectance

    result = CliRunner().invoke(
        main,
        ["render-one", "--out", str(tmp_path), *SMALL, "--set", "output.exr=true", "--set", "sun.elevation_deg=30"],
    )
    assert result.exit_code == 0, result.output
    expected_ev = auto_ev100(regolith_reflectance(load_config(None, {"sun.elevation_deg": 30})), 30.0, 1361.0)
    assert "view_NNN/rgb.exr" in result.output and f"EV100 {expected_ev:.2f} (auto)" in result.output
    view = tmp_path / "view_000"
    assert sorted(p.name for p in view.iterdir()) == sorted(FILES + ("rgb.exr",))
    gt = json.loads((view / "gt.json").read_text())
    assert gt["exposure"]["ev100_setting"] == "auto"
    assert gt["exposure"]["ev100"] == expected_ev
    assert gt["rgb_exr"]["unit"] == "W/(m^2*sr)" and gt["rgb_invalid_pixels"] == 0
    with OpenEXR.File(str(view / "rgb.exr")) as f:
        channels = f.channels()
        hdr = channels["RGB"].pixels if "RGB" in channels else np.stack([channels[c].pixels for c in "RGB"], axis=-1)
    assert hdr.dtype == np.float32 and hdr.shape == (120, 160, 3) and np.isfinite(hdr).all()
    # rgb.exr is the scene radiance; rgb.png adds the lens's veiling glare before the tone map.
    assert gt["exposure"]["veiling_glare_index"] == 0.02
    rgb8, _ = _core.tonemap_reinhard(hdr, gt["exposure"]["scale_sr_m2_w"], gt["exposure"]["veiling_glare_index"])
    np.testing.assert_array_equal(np.array(Image.open(view / "rgb.png")), rgb8)


def test_a_scene_that_does_not_settle_has_no_settle_stage(tmp_path):
    out = render_one(tmp_path, "--set", "bags.settle.enabled=false")
    gt = json.loads((out / "view_000" / "gt.json").read_text())
    assert "settle" not in gt["timings_s"] and gt["timings_s"]["compose"] > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--set", "camera.width=0"], "camera.width: must be >= 1"),
        (["--set", "sun.elevation_deg=95"], "sun.elevation_deg: must be <= 90"),
        (["--set", "render.spp=two"], "render.spp: must be an integer"),
        (["--set", "bags.colour=1"], "bags.colour: unknown field"),
        (["--set", "meshes.sandbag_01.size_m=[0.3, 0.2]"], "meshes.sandbag_01.size_m: must have 3 items"),
        (["--set", "camera.hfov_deg=.nan"], "camera.hfov_deg: must be finite"),
        (["--set", "terrain.location=moon"], "terrain.location: must be one of flat"),
        (["--view", "36"], "view: must be in 0..35"),
        (["--set", "nonsense"], "--set: expected FIELD=VALUE"),
        (["--set", "sun.elevation_deg=["], "--set sun.elevation_deg: value is not valid YAML"),
        (["--set", "sun.elevation_deg.x=1"], "elevation_deg is not a section"),
    ],
    ids=[
        "width0",
        "elevation95",
        "spp-str",
        "unknown",
        "size-len",
        "hfov-nan",
        "location",
        "view",
        "set",
        "set-yaml",
        "set-section",
    ],
)
def test_bad_input_names_the_field(tmp_path, args, message):
    result = CliRunner().invoke(main, ["render-one", "--out", str(tmp_path), *args])
    assert result.exit_code != 0
    assert message in result.output
    assert "Traceback" not in result.output
    assert not list(tmp_path.rglob("*.png"))  # rejected before anything is rendered


def test_bad_config_file_names_the_file(tmp_path):
    missing = tmp_path / "missing.yaml"
    result = CliRunner().invoke(main, ["render-one", str(missing), "--out", str(tmp_path)])
    assert result.exit_code != 0 and "missing.yaml" in result.output
    broken = tmp_path / "broken.yaml"
    broken.write_text("camera: [unclosed\n")
    result = CliRunner().invoke(main, ["render-one", str(broken), "--out", str(tmp_path)])
    assert result.exit_code != 0 and "broken.yaml: not valid YAML" in result.output


def test_unwritable_output_is_a_clear_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    result = CliRunner().invoke(main, ["render-one", "--out", str(blocker / "sub"), *SMALL])
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert str(blocker) in result.output


def test_help_explains_every_option():
    top = CliRunner().invoke(main, ["--help"])
    assert top.exit_code == 0 and "render-one" in top.output
    sub = CliRunner().invoke(main, ["render-one", "--help"])
    for option in ("--view", "--all-views", "--out", "--set", "CONFIG"):
        assert option in sub.output


def test_installed_command_works_from_any_directory(tmp_path):
    """The console script finds the packaged default config wherever it runs."""
    exe = Path(sys.executable).parent / "moonbot"
    if not exe.exists():
        exe = shutil.which("moonbot")
    assert exe, "the moonbot console script is not installed"
    done = subprocess.run(
        [str(exe), "render-one", "--out", "o", *SMALL], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert "render" in done.stdout and (tmp_path / "o" / "view_000" / "rgb.png").exists()


def test_depth_png_never_wraps():
    depth = np.array([[0.0, 0.0004, 0.0006, 1.2344, 65.535, 65.536, 1e9, np.nan, np.inf, -1.0]], dtype=np.float32)
    np.testing.assert_array_equal(depth_to_png16(depth), [[0, 0, 1, 1234, 65535, 0, 0, 0, 0, 0]])


def test_full_disk_fails_cleanly_and_keeps_the_previous_view(tmp_path):
    """A write that runs out of room (the file-size limit makes writes fail with EFBIG, as a full
    disk fails them with ENOSPC) ends with a clear error naming a file; the complete view already
    in place is untouched and no temporary is left behind."""
    out = render_one(tmp_path / "out")
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    script = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))\n"
        "from moonbot.cli import main\n"
        "sys.argv = ['moonbot', 'render-one', '--out', sys.argv[1], '--set', 'sun.elevation_deg=30',\n"
        "            '--set', 'camera.width=160', '--set', 'camera.height=120']\n"
        "main()\n"
    )
    done = subprocess.run([sys.executable, "-c", script, str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert "view_000/" in done.stderr and "write failed" in done.stderr
    assert "the previous content is kept" in done.stderr and "Traceback" not in done.stderr
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert sorted(p.name for p in out.iterdir()) == ["sheet.png", "view_000"]
