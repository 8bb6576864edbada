"""The `moonbot` command line: parses options and dispatches to the stages. No logic here."""

from __future__ import annotations

from pathlib import Path

import click

from moonbot import __version__


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="moonbot")
def main() -> None:
    """moonbot: synthetic BOP datasets of regolith bags on the Moon, ray traced on the CPU.

    Run `moonbot COMMAND --help` for a command's options.
    """


@main.command("render-one")
@click.argument("config_path", metavar="[CONFIG]", required=False,
                type=click.Path(dir_okay=False, path_type=Path))
@click.option("--view", "views", type=int, multiple=True, metavar="N",
              help="Orbit view index to render (0 = start azimuth, steps of orbit.step_deg); "
                   "repeat for several. Default: 0.")
@click.option("--all-views", is_flag=True, help="Render every view of the orbit (one task).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("out/render-one"), show_default=True,
              help="Directory to write into; one view_NNN/ folder per view.")
@click.option("--set", "overrides", multiple=True, metavar="FIELD=VALUE",
              help="Override a config field, e.g. --set sun.elevation_deg=5 (YAML value).")
@click.option("--location", type=click.Choice(["flat", "hilly", "crater", "plane", "slope"]),
              help="Terrain location (shorthand for --set terrain.location=...).")
@click.option("--sheet/--no-sheet", default=True, show_default=True,
              help="Also write sheet.png: per view rgb | depth | mask, read back from the files.")
def render_one(config_path: Path | None, views: tuple[int, ...], all_views: bool, out_dir: Path,
               overrides: tuple[str, ...], location: str | None, sheet: bool) -> None:
    """Render one sample (or one task) of CONFIG on this machine, for debugging a scene.

    CONFIG defaults to the embedded default config. Writes rgb.png (Reinhard, 8-bit sRGB),
    depth.npy (float32 metres), depth.png (uint16 millimetres, 0 = invalid), depth_preview.png,
    mask.png (instance ids, 0 = background) and gt.json (K, poses in mm, timings) per view, and
    a contact sheet, then prints a summary.
    """
    from moonbot.config import ConfigError, load_config, parse_overrides
    from moonbot.pipeline import run_views
    from moonbot.pipeline.summary import format_summary
    from moonbot.writer import write_sheet

    try:
        config = load_config(config_path, parse_overrides(overrides + ((f"terrain.location={location}",)
                                                                         if location else ())))
    except ConfigError as e:
        raise click.ClickException(str(e)) from None
    chosen = list(range(config.orbit.views)) if all_views else list(views or (0,))
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        results = run_views(config, chosen, out_dir)
        if sheet:
            write_sheet([r.out_dir for r in results], out_dir / "sheet.png",
                        config.output.png_compression)
    except (ValueError, OSError) as e:
        raise click.ClickException(str(e)) from None
    click.echo(format_summary(config, results, out_dir / "sheet.png" if sheet else None))


@main.command("meshes")
@click.argument("config_path", metavar="[CONFIG]", required=False,
                type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("out/models"), show_default=True,
              help="Directory for models/, models_eval/ and models_info.json.")
@click.option("--set", "overrides", multiple=True, metavar="FIELD=VALUE",
              help="Override a config field, e.g. --set meshes.sandbag_02.seam_height_m=0.004.")
def meshes(config_path: Path | None, out_dir: Path, overrides: tuple[str, ...]) -> None:
    """Write the three sandbag meshes of CONFIG (`meshes:` section; default: the embedded
    config) as BOP object models in millimetres: models/obj_NNNNNN.ply with normals,
    models_eval/ (surface resampled evenly) and models_info.json (diameter, extents, symmetries
    found numerically within 1 % of the diameter)."""
    from moonbot.bop import write_models
    from moonbot.config import ConfigError, load_config, parse_overrides
    from moonbot.scene.bag_mesh import VARIANTS, variant_meshes

    try:
        config = load_config(config_path, parse_overrides(overrides))
    except ConfigError as e:
        raise click.ClickException(str(e)) from None
    meshes_by_id = variant_meshes(config.meshes)
    try:
        infos = write_models(out_dir, meshes_by_id)
    except OSError as e:
        raise click.ClickException(str(e)) from None
    click.echo(f"{'obj_id':>6}  {'mesh':<11} {'vertices':>8} {'triangles':>9} {'diameter':>9}  symmetries")
    for obj_id, info in infos.items():
        v, t = meshes_by_id[obj_id]
        click.echo(f"{obj_id:>6}  {VARIANTS[obj_id][0]:<11} {len(v):>8} {len(t):>9} "
                   f"{info.diameter:>7.1f}mm  {len(info.symmetries)}")
    click.echo(f"\nwritten {out_dir}/models, models_eval, models_info.json")


if __name__ == "__main__":
    main()
