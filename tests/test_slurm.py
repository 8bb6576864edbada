"""The SLURM recipes for real: a one-node SLURM on this machine (cluster/slurm/local-cluster.sh:
Debian's slurmctld, slurmd and munge), on which `sbatch cluster/slurm/moonbot.sbatch` and
`cluster/slurm/launch.py` (dask-jobqueue's SLURMCluster) each render configs/smoke.yaml. Each
run's merged dataset must be byte-identical, file for file, to a LocalCluster run of the same
config.

Skipped where the SLURM and munge programs are not installed (`cluster/slurm/local-cluster.sh
install`; CI installs them). Every wait has a deadline: the cluster's start and stop, each job
(scancelled past it, its log shown) and each test (pytest-timeout); the module's teardown stops
every daemon and job even after a failure."""

from __future__ import annotations

import hashlib
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from moonbot.config import load_config
from moonbot.pipeline.generate import generate

ROOT = Path(__file__).resolve().parents[1]
LOCAL_CLUSTER = ROOT / "cluster" / "slurm" / "local-cluster.sh"
SMOKE = ROOT / "configs" / "smoke.yaml"
PROGRAMS = ("slurmctld", "slurmd", "sbatch", "squeue", "scancel", "sinfo", "scontrol", "munged", "mungekey")
MISSING = [p for p in PROGRAMS if shutil.which(p) is None]
# A smoke run takes about a minute on 2 idle cores; a loaded machine may take several times that.
JOB_LIMIT_S = 900
# The memory a job books: the node's, up to 4 GiB (a smoke worker peaks well under 1 GiB).
JOB_MEMORY_MB = 4096
DASK_SCHEDULER_PORT = 8786  # `dask scheduler`'s default

pytestmark = [
    pytest.mark.integration,
    pytest.mark.slow,
    pytest.mark.skipif(
        bool(MISSING),
        reason=f"SLURM is not installed (no {', '.join(MISSING)}): cluster/slurm/local-cluster.sh install",
    ),
]


class Slurm:
    """A running local cluster: the environment that points SLURM's clients at it, and its node's
    CPUs and memory (MB)."""

    def __init__(self, directory: Path):
        self.directory = directory
        self.env = {
            **os.environ,
            "SLURM_CONF": str(directory / "slurm.conf"),
            "MOONBOT_VENV": sys.prefix,
        }  # the recipes' venv: the one running these tests
        cpus, memory = self.run("sinfo", "-h", "-N", "-o", "%c %m").split()
        self.cpus, self.memory_mb = int(cpus), int(memory)

    def run(self, *command: str, cwd: Path | None = None) -> str:
        done = subprocess.run(command, env=self.env, cwd=cwd, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, f"{' '.join(command)}: {done.stderr}"
        return done.stdout

    def logs(self) -> str:
        """The daemons' last log lines, for a failure's message."""
        return "\n".join(
            f"--- {log}\n" + "\n".join(log.read_text(errors="replace").splitlines()[-15:])
            for log in sorted((self.directory / "log").glob("*.log"))
        )

    def wait(self, job_id: str, limit_s: float, log: Path) -> None:
        """Wait for the job to leave the queue, at most `limit_s`; past it, scancel it and fail.
        Then assert it COMPLETED with exit code 0."""
        deadline = time.monotonic() + limit_s
        while self.run("squeue", "-h", "-j", job_id, "-o", "%T").strip():
            if time.monotonic() > deadline:
                self.run("scancel", "--full", job_id)
                pytest.fail(
                    f"job {job_id} still queued or running after {limit_s} s (scancelled)\n{tail(log)}\n{self.logs()}"
                )
            time.sleep(2)
        # slurmctld keeps a finished job's record for MinJobAge (300 s by default).
        info = dict(
            field.split("=", 1) for field in self.run("scontrol", "-o", "show", "job", job_id).split() if "=" in field
        )
        assert (info["JobState"], info["ExitCode"]) == ("COMPLETED", "0:0"), (
            f"job {job_id}: {info['JobState']}, exit code {info['ExitCode']}\n{tail(log)}\n{self.logs()}"
        )


def tail(path: Path, lines: int = 40) -> str:
    if not path.is_file():
        return f"(no {path})"
    return f"--- {path}\n" + "\n".join(path.read_text(errors="replace").splitlines()[-lines:])


def file_hashes(dataset: Path) -> dict[str, str]:
    """Every file under `dataset` (relative path → sha256), symbolic links as their targets."""
    hashes = {}
    for path in sorted(dataset.rglob("*")):
        rel = path.relative_to(dataset).as_posix()
        if path.is_symlink():
            hashes[rel] = "-> " + os.readlink(path)
        elif path.is_file():
            hashes[rel] = hashlib.sha256(path.read_bytes()).hexdigest()
    return hashes


def assert_same_files(dataset: Path, reference: dict[str, str]) -> None:
    """`dataset` holds exactly the reference's files, each with the same bytes; names the others."""
    got = file_hashes(dataset)
    missing, extra = sorted(reference.keys() - got.keys()), sorted(got.keys() - reference.keys())
    differ = sorted(k for k in got.keys() & reference.keys() if got[k] != reference[k])
    assert not (missing or extra or differ), (
        f"{dataset}: missing {missing[:10]}, extra {extra[:10]}, different bytes {differ[:10]}"
    )


@pytest.fixture(scope="module")
def slurm(tmp_path_factory):
    directory = tmp_path_factory.mktemp("slurm")
    try:
        done = subprocess.run(
            [str(LOCAL_CLUSTER), "start", str(directory)], capture_output=True, text=True, timeout=180
        )
        assert done.returncode == 0, f"local-cluster.sh start: {done.stderr}"
        yield Slurm(directory)
    finally:
        done = subprocess.run([str(LOCAL_CLUSTER), "stop", str(directory)], capture_output=True, text=True, timeout=180)
        assert done.returncode == 0, f"local-cluster.sh stop: {done.stderr}"


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> dict[str, str]:
    """The smoke sweep on a LocalCluster (one worker process a core), merged: its dataset's files."""
    out = tmp_path_factory.mktemp("local")
    result = generate(load_config(SMOKE), out, progress=None)
    assert result.failed == {} and result.rendered == result.tasks
    hashes = file_hashes(out / "dataset")
    assert "manifest.json" in hashes and sum(name.endswith(".png") for name in hashes) >= result.samples
    return hashes


@pytest.mark.timeout(JOB_LIMIT_S + 600)
def test_the_sbatch_recipe_renders_the_local_clusters_bytes(slurm, reference, tmp_path):
    """With Dask's default scheduler port taken, as by a second job on the same node."""
    out = tmp_path / "out"
    log = tmp_path / "job.out"
    with socket.socket() as default_port:
        try:
            default_port.bind(("", DASK_SCHEDULER_PORT))
            default_port.listen()
        except OSError:
            pass  # taken already
        # The directives on the command line override the script's (2 nodes of 32 CPUs, 16 GB).
        job_id = (
            slurm.run(
                "sbatch",
                "--parsable",
                "--nodes=1",
                f"--cpus-per-task={slurm.cpus}",
                f"--mem={min(slurm.memory_mb, JOB_MEMORY_MB)}M",
                "--time=00:30:00",
                f"--output={log}",
                f"--export=ALL,CONFIG={SMOKE},OUT={out}",
                str(ROOT / "cluster" / "slurm" / "moonbot.sbatch"),
                cwd=ROOT,
            )
            .strip()
            .split(";")[0]
        )
        slurm.wait(job_id, JOB_LIMIT_S, log)
    assert_same_files(out / "dataset", reference)
    assert (out / "stats" / "tasks.parquet").is_file()  # the job's `moonbot stats`


@pytest.mark.timeout(JOB_LIMIT_S + 600)
def test_the_jobqueue_launcher_renders_the_local_clusters_bytes(slurm, reference, tmp_path):
    pytest.importorskip("dask_jobqueue")
    out = tmp_path / "out"
    command = [
        sys.executable,
        str(ROOT / "cluster" / "slurm" / "launch.py"),
        str(SMOKE),
        "--out",
        str(out),
        "--jobs",
        "1",
        "--cpus",
        str(slurm.cpus),
        "--memory",
        f"{min(slurm.memory_mb, JOB_MEMORY_MB)}MB",
        "--walltime",
        "00:30:00",
    ]
    try:
        done = subprocess.run(command, env=slurm.env, capture_output=True, text=True, timeout=JOB_LIMIT_S)
    except subprocess.TimeoutExpired as e:  # its jobs: cancelled by the cluster fixture's stop
        stderr = e.stderr.decode(errors="replace") if isinstance(e.stderr, bytes) else e.stderr
        pytest.fail(f"launch.py still running after {JOB_LIMIT_S} s (killed)\n{stderr}\n{slurm.logs()}")
    logs = "\n".join(tail(p) for p in sorted((out / "logs" / "slurm").glob("*")))
    assert done.returncode == 0, f"launch.py: {done.stdout}\n{done.stderr}\n{logs}\n{slurm.logs()}"
    assert_same_files(out / "dataset", reference)
    # launch.py's cluster.close() cancelled its worker jobs.
    assert slurm.run("squeue", "-h", "-o", "%i").strip() == ""
