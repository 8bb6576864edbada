"""What a benchmark result was measured on: the scripts in bench/ (run as scripts, so bench/ is on
sys.path) import it from here; the one copy is moonbot.benchmark.fingerprint, which
`moonbot bench` uses too."""

from moonbot.benchmark.fingerprint import library_versions, machine
from moonbot.host import machine_slug

__all__ = ["library_versions", "machine", "machine_slug"]
