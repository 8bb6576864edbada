"""The `moonbot` command line: parses options and dispatches to the stages. No logic here."""

from __future__ import annotations

from pathlib import Path

import click

from moonbot import __version__
from moonbot.config.schema import LOCATIONS, TEST_GROUNDS

# Arguments and options that several commands take alike, declared once.
_CONFIG_ARGUMENT = click.argument("config_path", metavar="CONFIG", type=click.Path(dir_okay=False, path_type=Path))
_OPTIONAL_CONFIG_ARGUMENT = click.argument(
    "config_path", metavar="[CONFIG]", required=False, type=click.Path(dir_okay=False, path_type=Path)
)
_DATASET_ARGUMENT = click.argument("dataset", type=click.Path(file_okay=False, exists=True, path_type=Path))
_OUT_ARGUMENT = click.argument("out_dir", metavar="OUT", type=click.Path(file_okay=False, path_type=Path))


def _overrides_option(help_text: str = "Override a config field."):
    """--set FIELD=VALUE, repeatable, passed as `overrides` (a tuple of str)."""
    return click.option("--set", "overrides", multiple=True, metavar="FIELD=VALUE", help=help_text)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="moonbot")
def main() -> None:
    """moonbot: synthetic BOP datasets of regolith bags on the Moon, ray traced on the CPU.

    Run `moonbot COMMAND --help` for a command's options.
    """


@main.command("render-one")
@_OPTIONAL_CONFIG_ARGUMENT
@click.option(
    "--view",
    "views",
    type=int,
    multiple=True,
    metavar="N",
    help="Orbit view index to render (0 = start azimuth, steps of orbit.step_deg); repeat for several. Default: 0.",
)
@click.option("--all-views", is_flag=True, help="Render every view of the orbit (one task).")
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/render-one"),
    show_default=True,
    help="Directory to write into; one view_NNN/ folder per view.",
)
@_overrides_option("Override a config field, e.g. --set sun.elevation_deg=5 (YAML value).")
@click.option(
    "--location",
    type=click.Choice(LOCATIONS + TEST_GROUNDS),
    help="Terrain location (shorthand for --set terrain.location=...).",
)
@click.option(
    "--dem",
    "dem_file",
    type=click.Path(dir_okay=False, path_type=Path),
    help="A LocalDem .npz from `moonbot terrain import`: render at that site "
    "(shorthand for --set terrain.location=dem --set terrain.dem_file=...).",
)
@click.option(
    "--dust",
    is_flag=True,
    help="Stir up dust beside the target: ejecta fragments and a fine-dust cloud "
    "(shorthand for --set dust.enabled=true; settings in the config's dust section).",
)
@click.option(
    "--sheet/--no-sheet",
    default=True,
    show_default=True,
    help="Also write sheet.png: per view rgb | depth | mask, read back from the files.",
)
def render_one(
    config_path: Path | None,
    views: tuple[int, ...],
    all_views: bool,
    out_dir: Path,
    overrides: tuple[str, ...],
    location: str | None,
    dem_file: Path | None,
    dust: bool,
    sheet: bool,
) -> None:
    """Render one sample (or one task) of CONFIG on this machine, for debugging a scene.

    CONFIG defaults to the embedded default config. Writes rgb.png (Reinhard, 8-bit sRGB),
    depth.npy (float32 metres), depth.png (uint16 millimetres, 0 = invalid), depth_preview.png,
    mask.png (instance ids, 0 = background), amodal_NNN.png (each bag alone) and gt.json (K,
    poses in mm, timings) per view, and a contact sheet; says each stage as it starts (on
    stderr, with the seconds since the start), then prints a summary.
    """
    from moonbot.config import ConfigError, load_config, parse_overrides
    from moonbot.pipeline import run_views
    from moonbot.pipeline.progress import StageClock
    from moonbot.pipeline.summary import format_summary
    from moonbot.writer import write_sheet

    try:
        settings = parse_overrides(overrides)
        if location:
            settings["terrain.location"] = location
        if dem_file is not None:  # a path, not a YAML value
            settings.update({"terrain.location": "dem", "terrain.dem_file": str(dem_file)})
        if dust:
            settings["dust.enabled"] = True
        config = load_config(config_path, settings)
    except ConfigError as e:
        raise click.ClickException(str(e)) from None
    chosen = list(range(config.orbit.views)) if all_views else list(views or (0,))
    stage = StageClock(lambda text: click.echo(text, err=True))
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        results = run_views(config, chosen, out_dir, on_stage=stage)
        if sheet:
            stage("contact sheet")
            write_sheet([r.out_dir for r in results], out_dir / "sheet.png", config.output.png_compression)
    except (ValueError, OSError) as e:
        raise click.ClickException(str(e)) from None
    click.echo(format_summary(config, results, out_dir / "sheet.png" if sheet else None))


@main.command("meshes")
@_OPTIONAL_CONFIG_ARGUMENT
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/models"),
    show_default=True,
    help="Directory for models/, models_eval/ and models_info.json.",
)
@click.option(
    "--mesh",
    "mesh_file",
    type=click.Path(dir_okay=False, path_type=Path),
    help="A mesh file of your own (.obj, .ply, .glb, .gltf): shorthand for --set bags.mesh=FILE; "
    "declare its unit and up axis in meshes.user.",
)
@_overrides_option("Override a config field, e.g. --set meshes.sandbag_02.seam_height_m=0.004.")
def meshes(config_path: Path | None, out_dir: Path, mesh_file: Path | None, overrides: tuple[str, ...]) -> None:
    """Write the bag meshes of CONFIG (the three sandbags of its `meshes:` section and each
    mesh of your own in meshes.user; default: the embedded config) as BOP object models in
    millimetres: models/obj_NNNNNN.ply with normals, models_eval/ (surface resampled evenly)
    and models_info.json (diameter, extents, discrete and continuous symmetries found
    numerically within 1 % of the diameter). A mesh of your own is checked and repaired first,
    and what was done is printed."""
    from moonbot.bop import write_models
    from moonbot.config import ConfigError, load_config, parse_overrides
    from moonbot.scene.bag_mesh import dataset_meshes
    from moonbot.scene.user_mesh import describe

    try:
        settings = parse_overrides(overrides)
        if mesh_file is not None:  # a path, not a YAML value
            settings["bags.mesh"] = str(mesh_file)
        config = load_config(config_path, settings)
        for entry in config.meshes.user:
            for line in describe(entry):
                click.echo(line)
        meshes_by_id = dataset_meshes(config.meshes)
        infos = write_models(out_dir, meshes_by_id)
    except (ConfigError, ValueError, OSError) as e:  # a bad field or mesh file, named in the message
        raise click.ClickException(str(e)) from None
    names = config.meshes.objects()
    width = max(11, *(len(n) for n in names.values()))
    click.echo(f"{'obj_id':>6}  {'mesh':<{width}} {'vertices':>8} {'triangles':>9} {'diameter':>9}  symmetries")
    for obj_id, info in infos.items():
        v, t = meshes_by_id[obj_id]
        axes = "".join(f", continuous about {[round(float(c), 3) for c in a]}" for a, _ in info.continuous)
        click.echo(
            f"{obj_id:>6}  {names[obj_id]:<{width}} {len(v):>8} {len(t):>9} "
            f"{info.diameter:>7.1f}mm  {len(info.symmetries)}{axes}"
        )
    click.echo(f"\nwritten {out_dir}/models, models_eval, models_info.json")


@main.group("terrain")
def terrain() -> None:
    """Terrain data: real lunar DEMs as local East-North-Up height grids."""


@terrain.command("import")
@click.argument("dem_path", metavar="FILE", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--lat", "lat_deg", type=float, required=True, help="Latitude of the crop centre (the ENU origin), degrees."
)
@click.option("--lon", "lon_deg", type=float, required=True, help="Longitude of the crop centre, degrees east.")
@click.option("--size-m", type=float, required=True, help="Side of the square crop, metres.")
@click.option(
    "--spacing-m", type=float, default=None, help="Grid spacing, metres. Default: the DEM's pixel size at the centre."
)
@click.option(
    "--curvature/--no-curvature",
    default=True,
    show_default=True,
    help="Heights as the true ENU up (the sphere falls away ~d²/2R), or a flat-earth patch (height differences only).",
)
@click.option(
    "--scale",
    type=float,
    default=1.0,
    show_default=True,
    help="Multiply heights (after the file's own scale/offset) by this: 1000 for "
    "SLDEM2015 km floats, 0.5 for LOLA int16 without GDAL metadata.",
)
@click.option("--offset", type=float, default=0.0, show_default=True, help="Then add this many metres.")
@click.option(
    "--nodata", type=float, default=None, help="Raw sample value that marks voids (overrides the file's GDAL_NODATA)."
)
@click.option(
    "--png-range",
    type=(float, float),
    default=None,
    metavar="MIN MAX",
    help="16-bit PNG: heights in metres of samples 0 and 65535.",
)
@click.option(
    "--png-pixel-m", type=float, default=None, metavar="M", help="16-bit PNG: ground size of a pixel, metres."
)
@click.option(
    "--png-center",
    type=(float, float),
    default=None,
    metavar="LAT LON",
    help="16-bit PNG: lat/lon of the image centre. Default: --lat/--lon.",
)
@click.option(
    "--out",
    "out_path",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="The .npz to write (moonbot.terrain.dem.LocalDem; parent folders are created).",
)
def terrain_import(
    dem_path: Path,
    lat_deg: float,
    lon_deg: float,
    size_m: float,
    spacing_m: float | None,
    curvature: bool,
    scale: float,
    offset: float,
    nodata: float | None,
    png_range: tuple[float, float] | None,
    png_pixel_m: float | None,
    png_center: tuple[float, float] | None,
    out_path: Path,
) -> None:
    """Crop a square around (--lat, --lon) from a DEM FILE (GeoTIFF, or a 16-bit PNG with
    --png-range and --png-pixel-m), fill its voids and resample it onto a local ENU grid;
    write it as a LocalDem .npz and print a summary."""
    from moonbot.terrain.dem import import_dem, summary

    try:
        dem = import_dem(
            dem_path,
            lat_deg,
            lon_deg,
            size_m,
            spacing_m=spacing_m,
            curvature=curvature,
            scale=scale,
            offset=offset,
            nodata=nodata,
            png_range=png_range,
            png_pixel_m=png_pixel_m,
            png_center=png_center,
        )
        out_path.parent.mkdir(parents=True, exist_ok=True)
        dem.save(out_path)
    except (ValueError, OSError) as e:
        raise click.ClickException(str(e)) from None
    click.echo(summary(dem, out_path))


@main.command("stats")
@_OUT_ARGUMENT
@click.option(
    "--reference",
    "reference_path",
    type=click.Path(exists=True, path_type=Path),
    help="Scaling efficiency against a previous run's OUT (its samples/s per worker) or a "
    "bench/results/generate-*.json record (its 1-worker run with the same render threads).",
)
@click.option(
    "--reference-rate",
    type=click.FloatRange(min=0, min_open=True),
    metavar="SAMPLES_PER_S",
    help="Or the samples/s of one worker (e.g. from a benchmark) to compare with.",
)
def stats(out_dir: Path, reference_path: Path | None, reference_rate: float | None) -> None:
    """Collect the throughput of a `moonbot generate --out OUT` run: every finished task's
    stats.json into OUT/stats/tasks.jsonl and tasks.parquet; print samples/s overall, per host,
    per worker, per core, the stage breakdown and efficiencies; plot OUT/stats/throughput.svg.
    Formulas: moonbot/pipeline/stats/aggregate.py."""
    from moonbot.pipeline.stats import format_summary, run_stats

    if reference_path is not None and reference_rate is not None:
        raise click.UsageError("give --reference or --reference-rate, not both")
    try:
        summary = run_stats(
            out_dir,
            reference_path,
            reference_rate,
            on_skipped=lambda d: click.echo(f"skipped {d}: not a complete task (no sound DONE.json)", err=True),
        )
    except (ValueError, OSError) as e:  # StatsError is a ValueError
        raise click.ClickException(str(e)) from None
    click.echo(format_summary(summary))
    click.echo(f"\nwritten {out_dir / 'stats'}/tasks.jsonl, tasks.parquet, placements.jsonl, throughput.svg")


@main.command("plan")
@_CONFIG_ARGUMENT
@click.option(
    "--bench-record",
    type=click.Path(dir_okay=False, path_type=Path),
    help="A generate benchmark record to estimate from (default: the one in ./bench/results/ of a "
    "machine with this CPU and core count, else another machine's).",
)
def plan(config_path: Path, bench_record: Path | None) -> None:
    """Print CONFIG's sweep — scenes, tasks and samples per split — and the disk and time it will
    take, without rendering anything. The time is scaled from a generate benchmark record, whose
    machine is named beside this one's."""
    from moonbot.config import ConfigError, load_config
    from moonbot.sweep.plan import default_record, estimate, provenance, split_plans

    try:
        config = load_config(config_path)
    except ConfigError as e:
        raise click.ClickException(str(e)) from None
    plans = split_plans(config)
    click.echo(f"{'split':<10} {'scenes':>7} {'tasks':>7} {'samples':>9}")
    for p in plans:
        click.echo(f"{p.name:<10} {p.scenes:>7} {p.tasks:>7} {p.samples:>9}")
    click.echo(
        f"{'total':<10} {sum(p.scenes for p in plans):>7} {sum(p.tasks for p in plans):>7} "
        f"{sum(p.samples for p in plans):>9}"
    )
    record = bench_record or default_record()
    found = estimate(plans, record)
    if found is None:
        click.echo(f"no generate benchmark record ({record} unreadable): run bench/bench_generate.py for estimates")
        return
    size = found.bytes
    click.echo(
        "disk    ~"
        + (f"{size / 1e9:.1f} GB" if size >= 1e9 else f"{size / 1e6:.1f} MB")
        + " of task directories (the merged dataset copies them unless merged with --link)"
    )
    hours = found.seconds / 3600
    click.echo(
        "time    ~"
        + (
            f"{hours:.1f} h"
            if hours >= 1
            else f"{found.seconds / 60:.1f} min"
            if found.seconds >= 60
            else f"{found.seconds:.1f} s"
        )
        + f" rendering only, on the recorded machine ({found.workers} worker × {found.threads} render "
        "threads, the fastest layout it measured"
        + (f", priced on {found.mix_tasks} tasks of the sweep's mix)" if found.mix_tasks else ")")
    )
    for line in provenance(found):
        click.echo(line)


@main.command("generate")
@_CONFIG_ARGUMENT
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Dataset directory: tasks/ (one directory per finished task) and what merge builds.",
)
@click.option("--workers", type=int, help="Worker processes of the local cluster (default: one per core).")
@click.option(
    "--threads",
    type=int,
    help="Render threads per task (default: cores / workers locally, render.threads on a given cluster).",
)
@click.option("--scheduler", help="Address of a running Dask scheduler to use instead of a local cluster.")
@click.option("--scheduler-file", type=click.Path(dir_okay=False), help="A Dask scheduler file to connect through.")
@click.option(
    "--resume",
    is_flag=True,
    help="Render only the tasks missing from --out (the default anyway: finished tasks are never redone).",
)
@click.option(
    "--merge/--no-merge",
    default=True,
    show_default=True,
    help="Merge the complete tasks into the BOP dataset --out/dataset at the end.",
)
@click.option(
    "--task-timeout",
    type=click.FloatRange(min=0),
    metavar="SECONDS",
    help="A task that enters no new stage (render view k, encode view k, ...) for this long is hung: "
    "its worker is restarted and it runs again, and after 3 hangs it is reported failed. "
    "Default: 300 s, more for views of over 5 megapixel-samples, and at least 10x the longest "
    "stage of the tasks finished so far; 0: never.",
)
def generate(
    config_path: Path,
    out_dir: Path,
    workers: int | None,
    threads: int | None,
    scheduler: str | None,
    scheduler_file: str | None,
    resume: bool,
    merge: bool,
    task_timeout: float | None,
) -> None:
    """Render CONFIG's sweep into --out on a Dask cluster (a local one unless told otherwise).

    A progress line per finished task, and every 30 s without one, names the running tasks with
    their ages and stages. Ctrl-C or SIGTERM stops the run cleanly (the cluster closed, its scratch
    space and unfinished tasks' temporaries removed) and prints the `moonbot merge` command that
    makes a dataset of the complete tasks; exit status 130 or 143."""
    from moonbot.bop.merge import MergeError
    from moonbot.config import ConfigError, load_config
    from moonbot.pipeline.generate import generate as run

    del resume  # every run resumes: the task directories are the record of what is done
    try:
        config = load_config(config_path)
    except ConfigError as e:
        raise click.ClickException(str(e)) from None
    try:
        result = run(
            config,
            out_dir,
            workers=workers,
            threads=threads,
            scheduler=scheduler,
            scheduler_file=scheduler_file,
            merge=merge,
            task_timeout=task_timeout,
        )
    except (OSError, MergeError) as e:
        raise click.ClickException(str(e)) from None
    if result.interrupted:
        import shlex
        import signal

        out, missing = shlex.quote(str(out_dir)), result.tasks - result.complete
        click.echo(
            f"interrupted by {result.interrupted} after {result.seconds:.1f} s: {result.complete} of "
            f"{result.tasks} tasks complete in {out_dir / 'tasks'}, nothing merged; the cluster's scratch "
            "space and the unfinished tasks' temporaries are removed\n"
            f"  moonbot merge {out}    # a BOP dataset of the complete tasks, in {out_dir / 'dataset'}\n"
            f"  moonbot generate {shlex.quote(str(config_path))} --out {out}    # renders the {missing} "
            "others (complete tasks are never redone)",
            err=True,
        )
        raise SystemExit(128 + signal.Signals[result.interrupted].value)
    click.echo(
        f"{result.rendered} tasks rendered ({result.samples} samples) in {result.seconds:.1f} s; "
        f"{result.complete_before} were complete already; {result.placed} scene layouts placed "
        f"and settled, {result.placed_before} kept from an earlier run"
    )
    if result.merge is not None:
        m = result.merge
        click.echo(
            f"dataset {m.dataset}: {m.scenes} scenes, {m.images} images"
            + (f"; {len(m.missing)} tasks missing" if m.missing else "")
        )
    if result.failed:
        for task_id, error in sorted(result.failed.items()):
            click.echo(f"failed: {task_id}: {error}", err=True)
        raise click.ClickException(f"{len(result.failed)} of {result.tasks} tasks failed; rerun to retry them")


@main.command("merge")
@_OUT_ARGUMENT
@click.option(
    "--dataset",
    "dataset_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="The BOP dataset to build (replaced whole). Default: OUT/dataset.",
)
@click.option(
    "--config",
    "config_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="The sweep's config: names missing tasks, goes into dataset_info.json "
    "(default: OUT/config.json when present).",
)
@click.option(
    "--link",
    is_flag=True,
    help="Hard-link the task files instead of copying them (no extra disk; copies across file systems).",
)
@click.option("--workers", type=int, help="Processes building scenes (default: one per core).")
def merge(out_dir: Path, dataset_dir: Path | None, config_path: Path | None, link: bool, workers: int | None) -> None:
    """Merge the complete tasks of OUT/tasks into one BOP dataset (scenes, models, camera.json,
    dataset_info.json, YOLO labels, manifest.json), rebuilt whole and renamed into place.

    Exit status: 0 when every task is merged, 3 when some are missing or unusable (the rest is
    merged and they are listed), 1 when nothing could be merged (the previous dataset is kept)."""
    from moonbot.bop.merge import EXIT_INCOMPLETE, MergeError, merge_dataset
    from moonbot.config import ConfigError, load_config
    from moonbot.yolo.export import write_yolo

    try:
        config = load_config(config_path) if config_path is not None else None
        report = merge_dataset(out_dir, dataset_dir, config, link=link, workers=workers, exporters=(write_yolo,))
    except (ConfigError, MergeError, OSError) as e:
        raise click.ClickException(str(e)) from None
    click.echo(
        f"merged {report.tasks} tasks: {report.scenes} scenes, {report.images} images, "
        f"{report.instances} instances in {', '.join(report.splits)} -> {report.dataset} "
        f"({report.files} files, {report.bytes / 1e6:.1f} MB, {report.seconds:.1f} s"
        f"{', models reused' if report.models_reused else ''})"
    )
    if report.amodal_outside_px:
        click.echo(f"warning: {report.amodal_outside_px} visible pixels lie outside their amodal masks", err=True)
    for task_id in report.extra:
        click.echo(f"not in the sweep (ignored): {task_id}", err=True)
    for name, reason in report.invalid.items():
        click.echo(f"unusable: {name}: {reason}", err=True)
    invalid = set(report.invalid)
    for task_id in report.missing:
        if task_id not in invalid:
            click.echo(f"missing: {task_id}", err=True)
    if not report.complete:
        click.echo(
            f"incomplete: {len(report.missing)} tasks missing, {len(report.invalid)} unusable; "
            "generate again and re-run merge",
            err=True,
        )
        click.get_current_context().exit(EXIT_INCOMPLETE)


@main.group("export")
def export() -> None:
    """A merged dataset in other tools' formats: COCO files per split, BOP-webdataset shards."""


@export.command("coco")
@_DATASET_ARGUMENT
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Folder for instances_<split>.json (file names in them are relative to DATASET).",
)
def export_coco(dataset: Path, out_dir: Path) -> None:
    """One COCO instance-segmentation file per split of DATASET (visible masks as RLE, amodal
    boxes, categories = obj_ids), for detectron2 or mmdetection with DATASET as image root."""
    from moonbot.bop.reader import DatasetError
    from moonbot.export.coco import write_split_cocos

    try:
        written = write_split_cocos(dataset, out_dir)
    except (DatasetError, OSError) as e:
        raise click.ClickException(str(e)) from None
    for split, path in written.items():
        click.echo(f"{split}: {path}")


@export.command("shards")
@_DATASET_ARGUMENT
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Folder for <split>_web/ (shard-NNNNNN.tar and key_to_shard.json), each replaced whole.",
)
@click.option("--shard-size", type=click.IntRange(min=1), default=1000, show_default=True, help="Images per shard.")
@click.option(
    "--shuffle-seed",
    type=click.IntRange(min=0, max=2**32 - 1),
    default=None,
    help="Shuffle the images across shards with this seed (default: dataset order).",
)
def export_shards(dataset: Path, out_dir: Path, shard_size: int, shuffle_seed: int | None) -> None:
    """BOP-webdataset shards of every split of DATASET, as bop_toolkit's bop_webdataset reads them
    (rgb.png: pass rgb_suffix=".png")."""
    from moonbot.bop.reader import DatasetError
    from moonbot.export.webdataset import write_shards

    try:
        written = write_shards(dataset, out_dir, shard_size, shuffle_seed)
    except (DatasetError, OSError) as e:
        raise click.ClickException(str(e)) from None
    for split in written:
        click.echo(f"{split.split}: {split.images} images in {split.shards} shards -> {split.folder}")


@main.command("baseline")
@_DATASET_ARGUMENT
@click.option("--split", default="test", show_default=True, help="The split whose instances to estimate.")
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Results CSV to write (default: DATASET/eval/baseline_<split>.csv).",
)
@click.option("--workers", type=click.IntRange(min=1), help="Processes (default: one per core).")
def baseline(dataset: Path, split: str, out: Path | None, workers: int | None) -> None:
    """Zero-shot poses for every instance of DATASET's split from its mesh, depth, visible mask
    and cam_K (principal-axes hypotheses refined by point-to-plane ICP), as a BOP results CSV
    for `moonbot eval`."""
    from moonbot.baseline import default_workers, run_baseline
    from moonbot.bop.reader import DatasetError

    def progress(done: int, total: int) -> None:
        if done == total or done % 50 == 0:
            click.echo(f"[{done}/{total}] images", err=True)

    try:
        report = run_baseline(dataset, split, out, workers or default_workers(), progress=progress)
    except DatasetError as e:
        raise click.ClickException(str(e)) from None
    click.echo(
        f"{report.estimated} of {report.instances} instances estimated ({report.skipped} with too few "
        f"visible pixels), {report.seconds:.1f} s of estimation; wrote {report.out}"
    )


@main.group("bench")
def bench() -> None:
    """Benchmarks: throughput of the fixed benchmark config against its limit, comparisons, and realism
    against reference photos."""


def _int_list(ctx, param, value: str) -> list[int]:
    try:
        out = sorted({int(v) for v in value.split(",") if v.strip()})
    except ValueError:
        raise click.BadParameter(f"expected comma-separated integers, got {value!r}") from None
    if not out or out[0] < 1:
        raise click.BadParameter(f"expected positive integers, got {value!r}")
    return out


@bench.command("throughput")
@click.option(
    "--config",
    "config_path",
    type=click.Path(dir_okay=False, exists=True, path_type=Path),
    help="The benchmark config (default: configs/bench/throughput-v1.yaml of the checkout).",
)
@click.option(
    "--levels",
    default="draft,default,high,path",
    show_default=True,
    help="Quality levels to run, comma-separated (moonbot/benchmark/levels.py).",
)
@click.option(
    "--workers",
    "workers",
    default="1",
    show_default=True,
    callback=_int_list,
    help="Worker counts to run, comma-separated (a sweep gives the scaling efficiency), e.g. 1,2.",
)
@click.option(
    "--threads",
    type=click.IntRange(min=1),
    help="Render threads a worker (default: cores // the largest worker count).",
)
@_overrides_option("Override a config field (recorded in the result; such runs are not the benchmark's).")
@click.option(
    "--repeats",
    type=click.IntRange(min=1),
    default=3,
    show_default=True,
    help="Timed repeats of each limit measurement (median).",
)
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Result file (default: bench/results/<machine>-<date>.json; an SVG is written beside it).",
)
def bench_throughput(
    config_path: Path | None,
    levels: str,
    workers: list[int],
    threads: int | None,
    overrides: tuple[str, ...],
    repeats: int,
    out: Path | None,
) -> None:
    """Run the fixed benchmark through `generate` on a local cluster at each quality level and
    worker count: samples/s, seconds per stage, rays/s, peak memory, bytes a sample, the ratio
    to the limit (Embree and the encoders alone on the same scenes, rays and files) and the full
    SynBag-1.0 sweep's projected time and disk; written as JSON with the machine's fingerprint.
    Definitions: moonbot/benchmark/throughput.py."""
    from moonbot.benchmark.compare import format_record, write_svg
    from moonbot.benchmark.levels import parse_levels
    from moonbot.benchmark.throughput import run_throughput
    from moonbot.config import ConfigError, parse_overrides

    try:
        names = parse_levels(levels)
        settings = parse_overrides(overrides)
        record, path = run_throughput(
            config_path, names, workers, threads, settings, out, repeats, say=lambda text: click.echo(text, err=True)
        )
        write_svg([(path.stem, record)], path.with_suffix(".svg"), f"moonbot bench throughput: {path.stem}")
    except (ConfigError, ValueError, OSError) as e:
        raise click.ClickException(str(e)) from None
    click.echo(format_record(record, path.stem))
    click.echo(f"\nwritten {path} and {path.with_suffix('.svg').name} ({record['seconds_total']:.0f} s)")


@bench.command("realism")
@click.option(
    "--photos",
    type=click.Path(file_okay=False, exists=True, path_type=Path),
    required=True,
    help="Folder of reference photos with SOURCES.csv (columns file, approx_sun_elevation_deg '~a-b').",
)
@click.option(
    "--regions",
    type=click.Path(dir_okay=False, exists=True, path_type=Path),
    help="Per-photo ground regions, CSV file,x0,y0,x1,y1 (default: bench/realism-photo-rois.csv).",
)
@click.option("--width", type=click.IntRange(min=64), default=768, show_default=True, help="Render width, pixels.")
@click.option("--height", type=click.IntRange(min=64), default=576, show_default=True, help="Render height, pixels.")
@click.option("--spp", type=click.IntRange(min=1), default=16, show_default=True, help="Samples per pixel.")
@click.option(
    "--light-samples",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="Shadow rays per sample toward the Sun's disk.",
)
@click.option(
    "--bounces",
    type=click.IntRange(min=0),
    default=2,
    show_default=True,
    help="Diffuse bounces (the product's render.bounces default: shadows lit by the sunlit ground).",
)
@click.option("--threads", type=click.IntRange(min=0), default=0, show_default=True, help="Render threads (0 = all).")
@click.option(
    "--pitch-deg",
    type=click.FloatRange(5.0, 60.0),
    default=20.0,
    show_default=True,
    help="Camera look-down angle, degrees.",
)
@click.option(
    "--camera-height-m",
    type=click.FloatRange(0.1, 10.0),
    default=1.5,
    show_default=True,
    help="Camera height above the ground under it, metres.",
)
@click.option(
    "--detail-extent-m",
    type=click.FloatRange(0.0, 50.0),
    default=6.0,
    show_default=True,
    help="Half-width of the terrain's fine tile, metres (0 = the config's).",
)
@click.option(
    "--locations",
    default="flat,hilly,crater",
    show_default=True,
    help="Locations to render, comma-separated (flat is always rendered).",
)
@_overrides_option()
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Result file (default: bench/results/realism-<machine>.json).",
)
@click.option(
    "--sheet",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Side-by-side PNG (default: realism-sheet.png beside the result).",
)
def bench_realism(
    photos: Path,
    regions: Path | None,
    locations: str,
    overrides: tuple[str, ...],
    out: Path | None,
    sheet: Path | None,
    **settings: int | float,
) -> None:
    """Realism: statistics of the ground in Apollo photos against renders at matched geometry and
    Sun (shadow fraction, luma percentiles, spectrum slope, octave contrasts, Laplacian, dark blobs,
    a patch classifier). Definitions: moonbot/benchmark/realism.py."""
    # `settings`: the render and camera options above (--width … --detail-extent-m), each named
    # as its field of realism_bench.Options.
    from moonbot.benchmark.realism_bench import Options, run_realism
    from moonbot.config import ConfigError, parse_overrides

    names = tuple(dict.fromkeys(["flat"] + [n.strip() for n in locations.split(",") if n.strip()]))
    try:
        options = Options(locations=names, overrides=parse_overrides(overrides), **settings)
        record, path = run_realism(photos, regions, options, out, sheet, say=lambda text: click.echo(text, err=True))
    except (ConfigError, ValueError, OSError) as e:
        raise click.ClickException(str(e)) from None
    from moonbot.benchmark.realism_bench import format_summary

    click.echo(format_summary(record))
    click.echo(f"\nwritten {path} ({record['seconds_total']:.0f} s)")


@bench.command("compare")
@click.argument("results", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--plot",
    type=click.Path(dir_okay=False, path_type=Path),
    help="The SVG to write. Default: compare-A-vs-B.svg (the RESULTS' stems) beside the first RESULTS file.",
)
def bench_compare(results: tuple[Path, ...], plot: Path | None) -> None:
    """Print the runs of throughput RESULTS files side by side (different machines or runs) and
    plot samples/s, seconds a sample per stage and the ratio to the limit."""
    from moonbot.benchmark.compare import ResultError, format_comparison, load_result, names_for, write_svg

    if plot is None:
        plot = results[0].parent / ("compare-" + "-vs-".join(p.stem for p in results) + ".svg")
    try:
        named = list(zip(names_for(list(results)), [load_result(p) for p in results]))
        write_svg(named, plot)
    except (ResultError, OSError) as e:
        raise click.ClickException(str(e)) from None
    click.echo(format_comparison(named))
    click.echo(f"\nwritten {plot}")


# What one item of each `moonbot validate` check is (moonbot/eval/validate.py), printed beside its count.
VALIDATE_ITEMS = {
    "manifest": "files listed in manifest.json: size and SHA-256",
    "scenes": "scene folders",
    "depth": "images: depth PNG against the metric .npy, no holes below the horizon",
    "masks": "instances: amodal and visible masks against scene_gt_info.json",
    "pose": "instances with visible pixels: the model at its pose against depth "
    "(fully occluded ones have no pixel to compare)",
}


@main.command("validate")
@_DATASET_ARGUMENT
def validate(dataset: Path) -> None:
    """Check a merged BOP DATASET against itself: manifest checksums, JSON fields, depth PNG against
    the metric .npy, masks against scene_gt_info.json, the models at their poses against depth.
    Exits 1 naming each failing file. The folder of a `moonbot generate --out OUT` run stands for
    its merged dataset, OUT/dataset."""
    import shlex

    from moonbot.eval.validate import validate_dataset
    from moonbot.pipeline.tasks import generate_folder_dataset

    merged = generate_folder_dataset(dataset)
    if merged is not None:
        if not (merged / "manifest.json").is_file():
            raise click.ClickException(
                f"{dataset} is the folder of a `moonbot generate` run whose tasks are not merged into "
                f"{merged}: run `moonbot merge {shlex.quote(str(dataset))}`, then "
                f"`moonbot validate {shlex.quote(str(merged))}`"
            )
        click.echo(f"{dataset} is the folder of a `moonbot generate` run: validating its dataset {merged}", err=True)
        dataset = merged
    report = validate_dataset(dataset)
    for check, n in sorted(report.checked.items()):
        failed = sum(1 for _, c, _ in report.failures if c == check)
        click.echo(f"{check:<10} {n:>8} checked  {failed:>6} failed   {VALIDATE_ITEMS.get(check, '')}".rstrip())
    for path, check, message in report.failures:
        click.echo(f"FAIL {check}: {path}: {message}", err=True)
    if not report.ok:
        raise SystemExit(1)


@main.command("eval")
@_DATASET_ARGUMENT
@click.option(
    "--results",
    "results_path",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Pose estimates as a BOP results CSV (scene_id,im_id,obj_id,score,R,t,time; t in mm).",
)
@click.option("--split", default="test", show_default=True, help="The dataset split the estimates are for.")
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Directory for the tables, per_instance.csv and the plots. Default: DATASET/eval.",
)
@click.option(
    "--min-visib-fract",
    type=click.FloatRange(0.0, 1.0),
    default=0.0,
    show_default=True,
    help="Evaluate only instances with at least this visible fraction (and always px_visib > 0); BOP papers used 0.1.",
)
@click.option(
    "--px-bins",
    default=",".join(map(str, (0, 500, 1000, 2000, 5000, 10000))),
    show_default=True,
    metavar="E0,E1,...",
    help="Lower edges of Table 4's visible-pixel bins; the last bin is open.",
)
@click.option(
    "--allow-unknown",
    is_flag=True,
    help="Warn about, instead of failing on, estimates of images or objects not in the split.",
)
@click.option(
    "--workers",
    type=int,
    default=-1,
    show_default=True,
    help="Threads of each ADD-S nearest-neighbour query (-1: all cores).",
)
def evaluate(
    dataset: Path,
    results_path: Path,
    split: str,
    out_dir: Path | None,
    min_visib_fract: float,
    px_bins: str,
    allow_unknown: bool,
    workers: int,
) -> None:
    """Score pose estimates against DATASET's ground truth as the SynBag paper's Tables 3 and 4:
    ADD, ADD-S, translation error, recall at 10/20 % of the diameter and ADD-S AUC per condition
    (mesh, location, stain, dust) and per visible-pixel bin. Writes table3/table4 .txt and .csv,
    per_instance.csv and two PNG plots, and prints both tables. Definitions, matching and
    exclusions: moonbot/eval/matching.py."""
    from moonbot.bop.reader import DatasetError
    from moonbot.eval.matching import EvalError, unknown_message
    from moonbot.eval.report import run_eval
    from moonbot.eval.results import ResultsError

    try:
        edges = [float(e) for e in px_bins.split(",")]
    except ValueError:
        raise click.BadParameter(f"expected comma-separated numbers, got {px_bins!r}", param_hint="--px-bins") from None

    def progress(done: int, total: int) -> None:
        if done == total or done % max(1, total // 10) == 0:
            click.echo(f"evaluated {done}/{total} images", err=True)

    try:
        report = run_eval(
            dataset, results_path, split, out_dir, min_visib_fract, edges, allow_unknown, workers, progress
        )
    except (ResultsError, DatasetError, EvalError, ValueError, OSError) as e:
        raise click.ClickException(str(e)) from None
    if report.evaluation.unknown:
        click.echo(
            f"warning: {len(report.evaluation.unknown)} estimates ignored, not in split {split!r}:\n"
            + unknown_message(report.evaluation, results_path),
            err=True,
        )
    click.echo(report.table3_text)
    click.echo(report.table4_text)
    click.echo("written " + ", ".join(str(p) for p in report.files))


if __name__ == "__main__":
    main()
