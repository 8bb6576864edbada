"""What the Debian packages of ./dev.sh bring onto a bare Debian 12, measured without installing
anything: `apt-get install --simulate` against a dpkg status that holds only a minimal system (the
packages of Priority `required` and what they depend on, about what the debian:12-slim image
has), then each package apt would install looked up in the package lists (apt-cache show) for
its download and installed size. Needs a Debian 12 machine with current package lists (`apt-get
update`); writes nothing but a temporary status file, and prints a Markdown table.

    python3 bench/install_weight.py > bench/results/install-weight-debian12.md   (then add the notes)
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from pathlib import Path

# dev.sh's APT_PACKAGES other than the image libraries, which the rows below vary.
REST = [
    "build-essential",
    "pkg-config",
    "python3",
    "python3-dev",
    "python3-venv",
    "libembree-dev",
    "libglm-dev",
    "libgeographiclib-dev",
    "libtbb-dev",
    "zlib1g-dev",
]
ROWS = [
    (
        "dev.sh before: OpenImageIO + openimageio-tools, with recommends",
        [],
        ["libopenimageio-dev", "openimageio-tools"],
    ),
    (
        "dev.sh before: OpenImageIO + openimageio-tools, --no-install-recommends",
        ["--no-install-recommends"],
        ["libopenimageio-dev", "openimageio-tools"],
    ),
    (
        "dev.sh now: OpenImageIO alone (pkg-config), --no-install-recommends",
        ["--no-install-recommends"],
        ["libopenimageio-dev"],
    ),
    (
        "libpng + OpenEXR + libtiff instead of OpenImageIO, --no-install-recommends",
        ["--no-install-recommends"],
        ["libpng-dev", "libopenexr-dev", "libtiff-dev"],
    ),
    ("no image library at all, --no-install-recommends", ["--no-install-recommends"], []),
]


def stanzas(status: str) -> dict[str, str]:
    """Installed packages of a dpkg status file: name → its stanza."""
    out = {}
    for stanza in status.strip().split("\n\n"):
        name = re.search(r"^Package: (.*)$", stanza, re.M)
        if name and re.search(r"^Status: .* installed$", stanza, re.M):
            out[name.group(1)] = stanza
    return out


def minimal_status(installed: dict[str, str]) -> str:
    """The stanzas of the Priority-required packages and their Depends/Pre-Depends closure, taken
    from this machine's status (every alternative resolved to the first one installed)."""
    provides: dict[str, str] = {}
    for name, stanza in installed.items():
        field = re.search(r"^Provides: (.*)$", stanza, re.M)
        for item in field.group(1).split(",") if field else []:
            provides.setdefault(item.strip().split(" ")[0].split(":")[0], name)

    def depends(stanza: str) -> list[str]:
        names = []
        for key in ("Depends", "Pre-Depends"):
            field = re.search(rf"^{key}: (.*)$", stanza, re.M)
            for group in field.group(1).split(",") if field else []:
                for alternative in group.split("|"):
                    want = alternative.strip().split(" ")[0].split(":")[0]
                    if want in installed or want in provides:
                        names.append(want if want in installed else provides[want])
                        break
        return names

    base = {n for n, s in installed.items() if re.search(r"^Priority: required$", s, re.M)}
    todo = list(base)
    while todo:
        for dep in depends(installed[todo.pop()]):
            if dep not in base:
                base.add(dep)
                todo.append(dep)
    return "\n\n".join(installed[n] for n in sorted(base)) + "\n"


def measure(status_file: str, options: list[str], packages: list[str]) -> tuple[int, float, float]:
    """(packages apt would install, their installed MB, their download MB)."""
    simulated = subprocess.run(
        ["apt-get", "install", "--simulate", "-o", f"Dir::State::status={status_file}", *options, *packages],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    names = [line.split()[1] for line in simulated.splitlines() if line.startswith("Inst ")]
    shown = subprocess.run(
        ["apt-cache", "show", "--no-all-versions", *names], capture_output=True, text=True, check=True
    ).stdout
    installed_kib = sum(int(v) for v in re.findall(r"^Installed-Size: (\d+)$", shown, re.M))
    download_b = sum(int(v) for v in re.findall(r"^Size: (\d+)$", shown, re.M))
    return len(names), installed_kib / 1024, download_b / 1e6


def main() -> None:
    installed = stanzas(Path("/var/lib/dpkg/status").read_text())
    with tempfile.NamedTemporaryFile("w", suffix=".status") as status:
        base = minimal_status(installed)
        status.write(base)
        status.flush()
        print(f"Base: {base.count('Package: ')} packages (Priority required and their dependencies).\n")
        print("| what dev.sh installs | packages | installed MB | download MB |")
        print("|---|---:|---:|---:|")
        for label, options, image_packages in ROWS:
            n, installed_mb, download_mb = measure(status.name, options, REST + image_packages)
            print(f"| {label} | {n} | {installed_mb:.0f} | {download_mb:.0f} |")


if __name__ == "__main__":
    sys.exit(main())
