#!/usr/bin/env python3
"""Render a moonbot sweep on SLURM through dask-jobqueue: this process runs the Dask scheduler and
the driver (moonbot.pipeline.generate.generate), and keeps JOBS worker jobs queued, each booking
CPUS cores and MEMORY for PROCESSES worker processes of one Dask thread each (the C++ core renders
on the CPUS / PROCESSES cores of its process). Then it collects and prints the run's throughput
(`moonbot stats OUT`).

Run it where sbatch works and for as long as the sweep (a login node under tmux, or better a
small long job), with the repository's venv on a filesystem the compute nodes share:

    pip install dask-jobqueue          # into that venv, once
    .venv/bin/python cluster/slurm/launch.py configs/synbag-1.0.yaml --out /shared/synbag \\
        --jobs 16 --cpus 32 --memory 8GB --walltime 04:00:00 --queue cpu --account moon
    .venv/bin/python cluster/slurm/launch.py ... --print-job-script   # the sbatch script, then exit

Workers retire 10 minutes before their job's walltime (--lifetime) and new jobs replace them, so a
walltime never kills a task midway; rerunning the command resumes where the last run stopped.
The workers and this process read the shared Dask settings from cluster/dask.yaml (DASK_CONFIG).
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DASK_YAML = REPO / "cluster" / "dask.yaml"
os.environ.setdefault("DASK_CONFIG", str(DASK_YAML))  # before dask is imported


def walltime_seconds(walltime: str) -> int:
    """SLURM's [D-]HH:MM:SS or HH:MM walltime in seconds."""
    m = re.fullmatch(r"(?:(\d+)-)?(\d+):(\d{2})(?::(\d{2}))?", walltime)
    if not m:
        raise SystemExit(f"--walltime: expected [D-]HH:MM:SS, got {walltime!r}")
    days, hours, minutes, seconds = (int(g) if g else 0 for g in m.groups())
    if m.group(4) is None:  # HH:MM
        hours, minutes, seconds = hours, minutes, 0
    return ((days * 24 + hours) * 60 + minutes) * 60 + seconds


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("config", type=Path, help="the sweep's config, e.g. configs/synbag-1.0.yaml")
    p.add_argument("--out", type=Path, required=True, help="dataset directory on the shared filesystem")
    p.add_argument("--jobs", type=int, default=4, help="worker jobs kept queued or running (default 4)")
    p.add_argument("--cpus", type=int, required=True, help="CPUs a job books (--cpus-per-task)")
    p.add_argument(
        "--processes",
        type=int,
        default=1,
        help="worker processes a job runs (default 1: one process renders on every CPU of the job; "
        "more needs render.threads = CPUS / PROCESSES in the config)",
    )
    p.add_argument("--memory", required=True, help="memory a job books, e.g. 8GB (about 2 GB a process: README)")
    p.add_argument("--walltime", default="04:00:00", help="a job's walltime, [D-]HH:MM:SS (default 04:00:00)")
    p.add_argument("--queue", help="partition (sbatch -p)")
    p.add_argument("--account", help="account (sbatch -A)")
    p.add_argument("--interface", help="network interface the workers and scheduler use, e.g. ib0")
    p.add_argument("--local-directory", default="$TMPDIR", help="node-local scratch for Dask (default $TMPDIR)")
    p.add_argument("--log-directory", type=Path, help="where SLURM writes the jobs' logs (default OUT/logs/slurm)")
    p.add_argument(
        "--prologue",
        action="append",
        default=[],
        help="a line for the job script before the worker starts (repeatable), e.g. 'module load gcc'",
    )
    p.add_argument("--print-job-script", action="store_true", help="print a worker job's sbatch script and exit")
    args = p.parse_args(argv)
    if args.jobs < 1 or args.cpus < 1 or not 1 <= args.processes <= args.cpus:
        p.error("--jobs and --cpus must be positive and --processes between 1 and --cpus")
    return args


def check_threads(config_path: Path, cpus: int, processes: int) -> None:
    """K processes in one job share its CPUs: the config must give each its share."""
    from moonbot.config import ConfigError, load_config

    try:
        threads = load_config(config_path).render.threads
    except ConfigError as e:
        raise SystemExit(str(e)) from None
    if processes > 1 and threads * processes != cpus:
        raise SystemExit(
            f"{config_path}: render.threads: {processes} processes a job on {cpus} CPUs need "
            f"render.threads = {cpus // processes}, got {threads} (0 = every CPU of the job, each)"
        )


def make_cluster(args: argparse.Namespace):
    from dask_jobqueue import SLURMCluster

    wall = walltime_seconds(args.walltime)
    lifetime = wall - 600 if wall > 1200 else int(wall * 0.9)
    log_directory = args.log_directory or args.out / "logs" / "slurm"
    return SLURMCluster(
        cores=args.processes,  # Dask threads a job: one a worker process, one task at a time each
        processes=args.processes,
        job_cpu=args.cpus,  # what SLURM books: the core's threads follow the job's cpuset
        memory=args.memory,
        walltime=args.walltime,
        queue=args.queue,
        account=args.account,
        interface=args.interface,
        local_directory=args.local_directory,
        log_directory=str(log_directory),
        python=sys.executable,  # the venv's Python, at the same path on every node
        job_script_prologue=[f"export DASK_CONFIG={DASK_YAML}", *args.prologue],
        worker_extra_args=["--lifetime", f"{lifetime}s", "--lifetime-stagger", "120s"],
    )


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    check_threads(args.config, args.cpus, args.processes)
    cluster = make_cluster(args)
    try:
        if args.print_job_script:
            print(cluster.job_script())
            return 0
        from distributed import Client

        from moonbot.cli import main as moonbot_cli
        from moonbot.pipeline.generate import generate

        # Keep JOBS jobs: a job whose workers retired (walltime) is replaced by a new one.
        cluster.adapt(minimum_jobs=args.jobs, maximum_jobs=args.jobs)
        with Client(cluster) as client:
            print(f"dashboard: {client.dashboard_link}", flush=True)
            result = generate(args.config, args.out, client=client)
        print(
            f"{result.rendered} tasks rendered ({result.samples} samples) in {result.seconds:.1f} s; "
            f"{result.complete_before} were complete already",
            flush=True,
        )
        for task_id, error in sorted(result.failed.items()):
            print(f"failed: {task_id}: {error}", file=sys.stderr)
        moonbot_cli(["stats", str(args.out)], standalone_mode=False)
        return 1 if result.failed else 0
    finally:
        cluster.close()


if __name__ == "__main__":
    sys.exit(main())
